"""Tests of filmgrain-farm (python/filmgrain/farm.py) on local Dask clusters.

Run by ctest (python/farm_tests.cmake) with Debian's /usr/bin/python3 and
FILMGRAIN_BIN = the built CLI, which every output is compared with, bit for
bit. The farm runs as a user runs it, through scripts/filmgrain-farm (which
loads farm.py without the compiled package). --noconftest: these tests need
neither the extension nor conftest.py's fixtures.

Scenes are tiny (64x48 plates over a 0.5 mm frame: a fraction of a second a
frame) except in the lost-worker test, whose frames must still be running
when a worker is killed (the wedge over 3 mm: about 1.5 s a frame on one
thread). Each farm run with frames to render starts a 2-worker local cluster
(about 3 s); the frames and files come from the CLI's --dry-run.
"""

import importlib.util
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import OpenImageIO as oiio
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FARM = os.path.join(ROOT, "scripts", "filmgrain-farm")
FAST = "--filmgrain:width_mm=0.5:seed=11"

sys.path.insert(0, os.path.join(ROOT, "tests"))
from fgtest import clean_env, fg_bin, reaped, write_image  # noqa: E402,F401 (shared)


def _load_farm():
    spec = importlib.util.spec_from_file_location(
        "filmgrain_farm_under_test", os.path.join(ROOT, "python", "filmgrain", "farm.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


farm = _load_farm()


def _env(fg_bin):
    return clean_env(FILMGRAIN_BIN=fg_bin)


def run_cli(fg_bin, *args):
    r = subprocess.run([fg_bin, *map(str, args)], capture_output=True, text=True,
                       env=_env(fg_bin), timeout=120)
    assert r.returncode == 0, r.stderr
    return r


def run_farm(fg_bin, *args, timeout=120, workers=2, cwd=None):
    extra = ["--workers", str(workers)] if workers else []
    return subprocess.run([sys.executable, FARM, *extra, *map(str, args)], capture_output=True,
                          text=True, env=_env(fg_bin), timeout=timeout, cwd=cwd)


def read_exr(path):
    inp = oiio.ImageInput.open(str(path))
    assert inp, oiio.geterror()
    spec = inp.spec()
    pixels = inp.read_image(spec.format)
    inp.close()
    attrs = {a.name: a.value for a in spec.extra_attribs}
    return spec, pixels, attrs


def assert_same_image(a, b, ignore=("DateTime",)):
    """Pixel data bytes, windows, channels, pixel type and metadata equal
    (but the attributes in `ignore`)."""
    sa, pa, aa = read_exr(a)
    sb, pb, ab = read_exr(b)
    assert pa.dtype == pb.dtype and pa.shape == pb.shape
    assert pa.tobytes() == pb.tobytes(), f"{a} and {b}: pixels differ"
    def windows(s):
        return (s.x, s.y, s.width, s.height, s.full_x, s.full_y, s.full_width, s.full_height)
    assert windows(sa) == windows(sb)
    assert tuple(sa.channelnames) == tuple(sb.channelnames)
    assert sa.format == sb.format
    for k in ignore:
        aa.pop(k, None)
        ab.pop(k, None)
    assert aa == ab


def write_plates(dirpath, frames, width=64, height=48):
    """Scene-linear RGB plates plate.####.exr: a gradient that changes per frame."""
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    for f in frames:
        img = np.stack([0.02 + 0.5 * x / width, 0.05 + 0.4 * y / height,
                        np.full_like(x, 0.03 * f)], axis=-1)
        write_image(dirpath / f"plate.{f:04d}.exr", img)


def leftovers(dirpath):
    """Hidden (temporary) files or directories the farm or the CLI left."""
    return [p.name for p in dirpath.iterdir() if p.name.startswith(".")]


# --- Unit: the frames are the CLI's (--dry-run), each task one of them -------

def test_tasks_are_the_cli_frames(fg_bin, tmp_path):
    """A frame list in INPUT: the farm's jobs are the CLI's frames in its
    order, and frame F's task is the user's command with --report-json,
    --frames F and F's input file (the list in INPUT would contradict
    --frames F)."""
    options = farm.cli_options(fg_bin)
    a = farm.parse_args([str(tmp_path / "p.3-1,7-11x2#.exr"), FAST, "-o",
                         str(tmp_path / "o.#.exr"), "--skip-missing"], options)
    jobs = farm.dry_run(fg_bin, a.cli)
    assert [j["frame"] for j in jobs] == [3, 2, 1, 7, 9, 11]
    assert jobs[0]["output"] == str(tmp_path / "o.0003.exr")
    assert farm.task_argv("fg", a, jobs[0]) == [
        "fg", str(tmp_path / "p.0003.exr"), FAST, "-o", str(tmp_path / "o.#.exr"),
        "--skip-missing", "--report-json", "--frames", "3"]
    todo, up_to_date, missing = farm.plan(a, jobs)
    assert (todo, up_to_date, len(missing)) == ([], [], 6)  # no plates
    a = farm.parse_args(["--wedge", "--frames", "5-6", FAST, "-o", "o.#.exr"], options)
    assert farm.task_argv("fg", a, {"frame": 6, "input": "wedge"}) == [
        "fg", "--wedge", FAST, "-o", "o.#.exr", "--report-json", "--frames", "6"]
    assert farm.task_argv("fg", a, {"frame": None}) == ["fg", *a.cli, "--report-json"]
    assert farm.with_modifier("--filmgrain:seed=1:roi=1,2,3,4", "roi", "0,0,1,1") \
        == "--filmgrain:seed=1:roi=0,0,1,1"


def test_every_cli_option_is_the_cli_s(fg_bin):
    """The farm knows the CLI's options from the CLI (--list-options), so
    that options it never listed by hand (--ch, --subimage, --view) reach
    the tasks with their values, and print-and-exit options are refused."""
    options = farm.cli_options(fg_bin)
    listed = json.loads(run_cli(fg_bin, "--list-options").stdout)
    assert {o["name"] for o in listed["options"]} <= set(options)
    assert options["--ch"]["value"] and not options["--wedge"]["value"]
    assert options["--filmgrain"]["modifiers"] and options["--list-stocks"]["exits"]
    a = farm.parse_args(["in.exr", "--ch", "R,G,B", "--subimage", "beauty", "--view", "left",
                         FAST, "-o", "o.exr"], options)
    assert a.cli == ["in.exr", "--ch", "R,G,B", "--subimage", "beauty", "--view", "left", FAST,
                     "-o", "o.exr"]


# --- Usage errors: clear, quick, before any cluster -------------------------

@pytest.mark.parametrize("args, message", [
    (["--wedge", FAST, "--frames", "1-3", "-o", "o.#.exr", "--tiles", "2"],
     "--tiles 2 renders one frame"),
    (["--wedge", FAST, "-o", "o.exr", "--tiles", "2", "--stats", "s.json"],
     "--tiles does not combine with --stats"),
    (["--wedge", FAST, "-o", "o.exr", "--bogus"], "unknown option '--bogus'"),
    (["--wedge", FAST, "-o", "o.exr", "--tiles", "0"], "--tiles 0: expected a whole number"),
    (["--wedge", FAST, "-o", "o.exr", "--filmgrain-bin", "/nonexistent/filmgrain"],
     "filmgrain CLI '/nonexistent/filmgrain' not found"),
    (["--version"], "--version: run the filmgrain CLI itself"),
    (["--list-options"], "--list-options: run the filmgrain CLI itself"),
    (["--wedge", FAST, "-o", "o.exr", "--dry-run"],
     "--dry-run: the farm runs the CLI's dry run itself"),
    (["--wedge", FAST, "-o", "o.exr", "--report-json"],
     "--report-json: the farm reads each task's report itself"),
    # The CLI's own messages, from its --dry-run:
    (["--wedge", FAST, "--frames", "1-3"], "no output given: -o FILE.exr is required"),
    (["--wedge", "-o", "o.exr"], "no --filmgrain command given"),
    (["a.exr", "b.exr", FAST, "-o", "o.exr"], "more than one INPUT ('a.exr' and 'b.exr')"),
    (["--wedge", FAST, "--frames", "1-3,2", "-o", "o.#.exr"],
     "--frames 1-3,2: frame 2 is listed twice"),
    (["--wedge", FAST, "--frames", "1-3y2", "-o", "o.#.exr"],
     "--frames 1-3y2: unexpected character 'y'"),
    (["--wedge", FAST, "--frames", "1-3", "-o", "o.exr"],
     "-o 'o.exr' has no frame-number field"),
    (["p.1-3#.exr", FAST, "--frames", "1-4", "-o", "o.#.exr"],
     "--frames 1-4 and INPUT 'p.1-3#.exr' name different frames"),
])
def test_usage_errors(fg_bin, tmp_path, args, message):
    t0 = time.monotonic()
    r = run_farm(fg_bin, *args, workers=0, timeout=30, cwd=tmp_path)
    assert r.returncode == 1
    assert f"filmgrain-farm: error: {message}" in r.stderr, r.stderr
    assert time.monotonic() - t0 < 10


def test_help_lists_options(fg_bin):
    r = run_farm(fg_bin, "--help", workers=0)
    assert r.returncode == 0
    for opt in ("--scheduler ADDRESS", "--workers N", "--scheduler-timeout", "--tiles N",
                "--filmgrain-bin PATH", "--progress", "-q, --quiet", "Default"):
        assert opt in r.stdout


def test_bad_scheduler_times_out(fg_bin, tmp_path):
    t0 = time.monotonic()
    r = run_farm(fg_bin, "--scheduler", "tcp://127.0.0.1:9", "--scheduler-timeout", "2",
                 "--wedge", FAST, "-o", tmp_path / "o.exr", workers=0, timeout=60)
    assert r.returncode == 1
    assert "cannot connect to the scheduler tcp://127.0.0.1:9 within 2 s" in r.stderr, r.stderr
    assert time.monotonic() - t0 < 20
    assert list(tmp_path.iterdir()) == []


# --- Sequences on a local cluster of 2 workers -----------------------------

def test_sequence_equals_cli(fg_bin, tmp_path):
    """Frames 1-4, plate 4 missing (--skip-missing), the list given in INPUT
    to the farm: every output equals the CLI's --frames run, bit for bit.
    --skip-existing then submits only the frame whose output was removed,
    and a run with nothing left to do starts no cluster and prints nothing
    with -q."""
    plates = tmp_path / "plates"
    plates.mkdir()
    write_plates(plates, [1, 2, 3])
    (tmp_path / "cli").mkdir()
    (tmp_path / "farm").mkdir()
    run_cli(fg_bin, plates / "plate.####.exr", "--frames", "1-4", "--skip-missing", FAST,
            "-o", tmp_path / "cli" / "neg.####.exr", "--stats", tmp_path / "cli" / "neg.####.json")
    farm_args = [plates / "plate.1-4#.exr", "--skip-missing", FAST,
                 "-o", tmp_path / "farm" / "neg.####.exr",
                 "--stats", tmp_path / "farm" / "neg.####.json"]
    r = run_farm(fg_bin, *farm_args)
    assert r.returncode == 0, r.stderr
    assert "sequence of 4 frames: 3 rendered, 0 up to date (skipped), 1 missing input " \
           "(skipped)" in r.stderr
    assert f"warning: frame 4: input '{plates / 'plate.0004.exr'}' does not exist" in r.stderr

    def check_outputs():
        for f in (1, 2, 3):
            assert_same_image(tmp_path / "cli" / f"neg.{f:04d}.exr",
                              tmp_path / "farm" / f"neg.{f:04d}.exr")
            assert (tmp_path / "farm" / f"neg.{f:04d}.json").exists()
        assert not (tmp_path / "farm" / "neg.0004.exr").exists()
        assert leftovers(tmp_path / "farm") == []
    check_outputs()

    def mtime_ns(f):
        return (tmp_path / "farm" / f"neg.{f:04d}.exr").stat().st_mtime_ns
    (tmp_path / "farm" / "neg.0002.exr").unlink()
    kept = {f: mtime_ns(f) for f in (1, 3)}
    r = run_farm(fg_bin, *farm_args, "--skip-existing")
    assert r.returncode == 0, r.stderr
    assert "sequence of 4 frames: 1 rendered, 2 up to date (skipped), 1 missing input " \
           "(skipped)" in r.stderr
    check_outputs()
    assert {f: mtime_ns(f) for f in (1, 3)} == kept

    r = run_farm(fg_bin, *farm_args, "--skip-existing", "-q")
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # -q: nothing but errors
    r = run_farm(fg_bin, *farm_args, "--skip-existing", workers=0)
    assert r.returncode == 0, r.stderr
    assert "sequence of 4 frames: 0 rendered, 3 up to date (skipped), 1 missing input " \
           "(skipped)" in r.stderr and " workers" not in r.stderr  # no cluster started
    assert {f: mtime_ns(f) for f in (1, 3)} == kept


def test_cli_error_stops_the_run(fg_bin, tmp_path):
    """A missing plate without --skip-missing: the CLI's error, naming the
    frame, and exit status 1 (not retried)."""
    write_plates(tmp_path, [1])
    r = run_farm(fg_bin, tmp_path / "plate.####.exr", "--frames", "1-2", FAST,
                 "-o", tmp_path / "neg.####.exr", "-q")
    assert r.returncode == 1
    assert "filmgrain-farm: error: frame 2 (on " in r.stderr
    assert "plate.0002.exr" in r.stderr
    assert not (tmp_path / "neg.0002.exr").exists()
    assert leftovers(tmp_path) == []


def _argv(pid):
    """The command line of process pid ([] when it is gone)."""
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().decode(errors="replace").split("\0")
    except OSError:
        return []


def _cli_processes_writing_to(dirpath):
    """pids of running filmgrain CLI processes whose arguments name dirpath."""
    found = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        argv = _argv(pid)
        if argv and os.path.basename(argv[0]) == "filmgrain" and any(
                str(dirpath) in a for a in argv):
            found.append(int(pid))
    return found


def _alive(pid):
    """pid runs (is not gone, nor a zombie)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _parent(pid):
    with open(f"/proc/{pid}/stat") as f:
        return int(f.read().rsplit(")", 1)[1].split()[1])


def test_lost_worker_frames_retried(fg_bin, tmp_path):
    """SIGKILL a worker process while it renders: its frame is rendered again
    on a worker, every frame completes and equals the CLI's; the killed
    worker's CLI process does not live on."""
    # Frames of a few seconds each (the paper-scale stock: the default's
    # 3 um scan pixels of 50 grains/um^2 a layer would take minutes a frame).
    slow = ["--wedge", "--filmgrain:stock=color-negative:width_mm=3:seed=5", "--frames", "1-4"]
    out = tmp_path / "farm"
    out.mkdir()
    with reaped(subprocess.Popen([sys.executable, FARM, "--workers", "2", *slow,
                                  "-o", out / "neg.####.exr"],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                 env=_env(fg_bin))) as proc:
        killed = None
        deadline = time.monotonic() + 60
        while killed is None and time.monotonic() < deadline and proc.poll() is None:
            # A worker's CLI: not the farm's own dry run (its child).
            cli = [p for p in _cli_processes_writing_to(out) if "--dry-run" not in _argv(p)]
            if cli:
                time.sleep(0.3)  # well into the frame
                try:
                    worker = _parent(cli[0])
                    os.kill(worker, signal.SIGKILL)
                    killed = (worker, cli[0])
                except (OSError, ValueError, IndexError):
                    pass  # that frame just finished: try the next one
                if killed:
                    # Its CLI dies with it (PR_SET_PDEATHSIG: SIGTERM), within
                    # a fraction of the second or more its frame still needs.
                    t_kill = time.monotonic()
                    while _alive(killed[1]) and time.monotonic() - t_kill < 0.5:
                        time.sleep(0.02)
                    assert not _alive(killed[1]), "the killed worker's CLI lives on"
            time.sleep(0.05)
        assert killed, "no CLI process seen running"
        _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert "4 rendered" in err
    (tmp_path / "cli").mkdir()
    run_cli(fg_bin, *slow, "-o", tmp_path / "cli" / "neg.####.exr", "--threads", "2", "-q")
    for f in range(1, 5):
        assert_same_image(tmp_path / "cli" / f"neg.{f:04d}.exr", out / f"neg.{f:04d}.exr")
    assert leftovers(out) == []


# --- --tiles ---------------------------------------------------------------

def test_tiles_equal_whole_frame(fg_bin, tmp_path):
    """--tiles 4 (half floats, lossy dwaa compression) equals the whole-frame
    render: pixel bytes, windows, channels, type, compression and every
    attribute but DateTime, the settings hash included; so a second run with
    --skip-existing skips the frame, and the CLI finds it up to date too."""
    write_plates(tmp_path, [1])
    args = [tmp_path / "plate.0001.exr", "--filmgrain:width_mm=0.5:seed=2", "-d", "half"]
    run_cli(fg_bin, *args, "-o:compression=dwaa", tmp_path / "whole.exr", "-q")
    r = run_farm(fg_bin, "--tiles", "4", *args, "-o:compression=dwaa", tmp_path / "tiled.exr")
    assert r.returncode == 0, r.stderr
    assert "4 tiles" in r.stderr
    whole_attrs = read_exr(tmp_path / "whole.exr")[2]
    assert whole_attrs["compression"] == "dwaa"
    assert read_exr(tmp_path / "tiled.exr")[2]["filmgrain:settings_hash"] \
        == whole_attrs["filmgrain:settings_hash"]
    assert_same_image(tmp_path / "whole.exr", tmp_path / "tiled.exr")
    assert leftovers(tmp_path) == []

    mtime_ns = (tmp_path / "tiled.exr").stat().st_mtime_ns
    r = run_farm(fg_bin, "--tiles", "4", *args, "-o:compression=dwaa", tmp_path / "tiled.exr",
                 "--skip-existing")
    assert r.returncode == 0, r.stderr
    assert f"'{tmp_path / 'tiled.exr'}' is up to date (same settings): skipped" in r.stderr
    assert (tmp_path / "tiled.exr").stat().st_mtime_ns == mtime_ns
    r = run_cli(fg_bin, *args, "-o:compression=dwaa", tmp_path / "tiled.exr", "--skip-existing")
    assert "is up to date (same settings): skipped" in r.stderr


def test_tiles_of_a_sequence_frame_with_roi(fg_bin, tmp_path):
    """One frame of a sequence (--frames 7, its grain) with a roi and a
    scan size, in 3 tiles: equals the CLI's frame (settings hash included)."""
    args = ["--wedge", "--filmgrain:seed=9:scan=500:roi=10,5,300,40",
            "--frames", "7"]
    run_cli(fg_bin, *args, "-o", tmp_path / "whole.#.exr", "-q")
    r = run_farm(fg_bin, "--tiles", "3", *args, "-o", tmp_path / "tiled.#.exr", "-q")
    assert r.returncode == 0, r.stderr
    spec, _, _ = read_exr(tmp_path / "tiled.0007.exr")
    assert (spec.x, spec.y, spec.width, spec.height) == (10, 5, 300, 40)
    assert_same_image(tmp_path / "whole.0007.exr", tmp_path / "tiled.0007.exr")
    assert leftovers(tmp_path) == []
