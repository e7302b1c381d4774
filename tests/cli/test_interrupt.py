"""An interrupted run (SIGINT, SIGTERM) cancels the render, removes its
temporary files, writes no output and exits with 128 + the signal number."""

import signal
import subprocess
import time

import pytest

from conftest import clean_env, listing
from fgtest import read_stderr_until, reaped

# The wedge of color-negative (paper-scale grains) over a 6 mm frame on one
# thread takes several seconds (tens on a slow machine): long enough to be
# interrupted mid-render. Small tiles keep the cancellation prompt (it is
# checked between tiles).
SLOW = ["--wedge", "--filmgrain:stock=color-negative:width_mm=6:tile=16", "--threads", "1",
        "--progress"]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_interrupt_leaves_nothing(fg_bin, tmp_path, sig):
    out = tmp_path / "out"
    out.mkdir()
    args = [fg_bin, *SLOW, "-o", out / "w.exr", "--stats", out / "s.json", "--preview",
            out / "w.png"]
    with reaped(subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 env=clean_env())) as proc:
        # The first progress report: the render is running.
        seen = read_stderr_until(proc, b"simulating", timeout=60)
        # While it renders, no file exists yet: outputs are created only
        # when written (unnamed until complete), so even SIGKILL leaves none.
        assert listing(out) == []
        proc.send_signal(sig)
        start = time.monotonic()
        _, err = proc.communicate(timeout=60)
        elapsed = time.monotonic() - start
    err = (seen + err).decode(errors="replace")
    assert proc.returncode == 128 + sig, err
    assert "interrupted" in err and signal.Signals(sig).name in err
    assert "no output written" in err
    assert elapsed < 20, f"cancellation took {elapsed:.1f} s"
    assert listing(out) == []
