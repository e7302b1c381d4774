"""An interrupted run (SIGINT, SIGTERM) cancels the render, removes its
temporary files, writes no output and exits with 128 + the signal number."""

import os
import select
import signal
import subprocess
import time

import pytest

from conftest import clean_env, listing
from fgtest import reaped

# The wedge of color-negative (paper-scale grains) over a 6 mm frame on one
# thread takes several seconds (tens on a slow machine): long enough to be
# interrupted mid-render. Small tiles keep the cancellation prompt (it is
# checked between tiles).
SLOW = ["--wedge", "--filmgrain:stock=color-negative:width_mm=6:tile=16", "--threads", "1",
        "--progress"]


def wait_for_progress(proc, timeout=60):
    """Reads stderr until the first progress report: the render is running."""
    seen = b""
    deadline = time.monotonic() + timeout
    fd = proc.stderr.fileno()
    while time.monotonic() < deadline:
        ready, _, _ = select.select([fd], [], [], 0.5)
        if ready:
            chunk = os.read(fd, 4096)
            if not chunk:
                break
            seen += chunk
            if b"simulating" in seen:
                return seen
    pytest.fail(f"no progress report within {timeout} s: {seen!r}")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_interrupt_leaves_nothing(fg_bin, tmp_path, sig):
    out = tmp_path / "out"
    out.mkdir()
    args = [fg_bin, *SLOW, "-o", out / "w.exr", "--stats", out / "s.json", "--preview",
            out / "w.png"]
    with reaped(subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 env=clean_env())) as proc:
        seen = wait_for_progress(proc)
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
