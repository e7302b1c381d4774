"""Image sequences: --frames, frame patterns, per-frame grain, --skip-existing,
--skip-missing, and a sequence killed mid-frame (docs/usage.md "Sequences")."""

import json
import os
import signal
import subprocess

import numpy as np
import pytest

from conftest import FAST, Exr, clean_env, listing, read_json, rgb_ramp, write_image
from fgtest import read_stderr_until, reaped

MASK = (1 << 64) - 1


def mix64(x):
    x ^= x >> 33
    x = (x * 0xFF51AFD7ED558CCD) & MASK
    x ^= x >> 33
    x = (x * 0xC4CEB9FE1A85EC53) & MASK
    x ^= x >> 33
    return x


def frame_seed(seed, frame):
    """The documented per-frame seed, written out independently of the C++:
    hash_ids(seed, 0xf4a3e, frame) of core/src/util/rng.h."""
    h = mix64(seed ^ 0x5851F42D4C957F2D)
    for v in (0xF4A3E, frame & MASK):
        h = mix64(h ^ ((mix64(v) + 0x9E3779B97F4A7C15 + ((h << 6) & MASK) + (h >> 2)) & MASK))
    return h


def plates(directory, frames, pattern="plate.{:04d}.exr"):
    """A plate per frame: the same ramp, brightened a little per frame."""
    for f in frames:
        write_image(directory / pattern.format(f), rgb_ramp() * (1.0 + 0.01 * (f % 7)))


def pixels(path):
    return np.stack([c for _, c in sorted(Exr(path).channels.items())])


def test_sequence_equals_single_frames_with_documented_seeds(run, dirs):
    indir, outdir = dirs
    plates(indir, [1001, 1002, 1003])
    r = run(indir / "plate.####.exr", "--frames", "1001-1003",
            f"--filmgrain:{FAST}:seed=42", "-o", outdir / "neg.####.exr",
            "--stats", outdir / "neg.####.json")
    assert r.returncode == 0, r.stderr
    assert "3 rendered" in r.stderr
    seq = {f: pixels(outdir / f"neg.{f}.exr") for f in (1001, 1002, 1003)}
    for f in (1001, 1002, 1003):
        alone = outdir / f"alone.{f}.exr"
        r = run(indir / f"plate.{f}.exr", f"--filmgrain:{FAST}:seed=42:frame={f}", "-o", alone)
        assert r.returncode == 0, r.stderr
        assert np.array_equal(pixels(alone), seq[f]), f
        exr = Exr(outdir / f"neg.{f}.exr")
        assert exr.attr("filmgrain:frame") == str(f)
        assert exr.attr("filmgrain:grain_seed") == str(frame_seed(42, f))
        stats = read_json(outdir / f"neg.{f}.json")
        assert stats["frame"] == f and stats["grain_seed"] == frame_seed(42, f)
        # The seed of the frame, given as a plain seed, is the same grain.
        plain = outdir / f"plain.{f}.exr"
        r = run(indir / f"plate.{f}.exr", f"--filmgrain:{FAST}:seed={frame_seed(42, f)}",
                "-o", plain)
        assert r.returncode == 0, r.stderr
        assert np.array_equal(pixels(plain), seq[f]), f


def test_neighbouring_frames_differ_and_static_keeps_one_pattern(run, dirs):
    indir, outdir = dirs
    write_image(indir / "still.exr", rgb_ramp())
    r = run(indir / "still.exr", "--frames", "1,2", f"--filmgrain:{FAST}", "-o",
            outdir / "moving.#.exr")
    assert r.returncode == 0, r.stderr
    a, b = pixels(outdir / "moving.0001.exr"), pixels(outdir / "moving.0002.exr")
    assert np.mean(a != b) > 0.9, np.mean(a != b)
    r = run(indir / "still.exr", "--frames", "1,2", f"--filmgrain:{FAST}:static_grain=1", "-o",
            outdir / "static.@@@.exr")
    assert r.returncode == 0, r.stderr
    a, b = pixels(outdir / "static.001.exr"), pixels(outdir / "static.002.exr")
    assert np.array_equal(a, b)
    single = outdir / "single.exr"
    assert run(indir / "still.exr", f"--filmgrain:{FAST}", "-o", single).returncode == 0
    assert np.array_equal(pixels(single), a)


@pytest.mark.parametrize("spec,expected", [
    ("1-10,20,30-40x5", list(range(1, 11)) + [20, 30, 35, 40]),
    ("3-1", [3, 2, 1]),
    ("7", [7]),
])
def test_frame_lists_and_pattern_forms(run, dirs, spec, expected):
    _, outdir = dirs
    r = run("--wedge", "--frames", spec, f"--filmgrain:stock=paper:{FAST}:engine=fast",
            "-o", outdir / "w.%03d.exr", "-q")
    assert r.returncode == 0, r.stderr
    assert listing(outdir) == sorted(f"w.{f:03d}.exr" for f in expected)


def test_frame_list_in_the_input_pattern(run, dirs):
    indir, outdir = dirs
    plates(indir, [5, 6], pattern="p.{:04d}.exr")
    r = run(indir / "p.5-6#.exr", f"--filmgrain:{FAST}", "-o", outdir / "n.#.exr")
    assert r.returncode == 0, r.stderr
    assert listing(outdir) == ["n.0005.exr", "n.0006.exr"]


@pytest.mark.parametrize("args,message", [
    (["--frames", "1-3", "-o", "w.exr"], "no frame-number field"),
    (["-o", "w.####.exr"], "give the frames with --frames"),
    (["--frames", "1,2,1", "-o", "w.#.exr"], "listed twice"),
    (["--frames", "1-2000000", "-o", "w.#.exr"], "more than 1000000 frames"),
    (["--frames", "1-3y", "-o", "w.#.exr"], "unexpected character"),
    (["--frames", "1-3", "-o", "w.#.exr", "--stats", "s.json"], "--stats 's.json'"),
    (["-o", "w.exr", "--skip-missing"], "applies to sequences"),
])
def test_sequence_usage_errors(run, dirs, args, message):
    _, outdir = dirs
    r = run("--wedge", f"--filmgrain:{FAST}", *args, cwd=outdir)
    assert r.returncode == 1
    assert message in r.stderr, r.stderr
    assert listing(outdir) == []


def test_frame_modifier_conflicts_with_frames(run, dirs):
    _, outdir = dirs
    r = run("--wedge", "--frames", "1-2", f"--filmgrain:{FAST}:frame=3", "-o",
            outdir / "w.#.exr")
    assert r.returncode == 1 and "frame=3 with --frames" in r.stderr, r.stderr


def test_missing_input_frame_is_an_error_or_skipped_and_counted(run, dirs):
    indir, outdir = dirs
    plates(indir, [1, 3])
    args = [indir / "plate.####.exr", "--frames", "1-3", f"--filmgrain:{FAST}", "-o",
            outdir / "n.####.exr"]
    r = run(*args)
    assert r.returncode == 1
    assert "frame 2: input" in r.stderr and "plate.0002.exr" in r.stderr, r.stderr
    assert listing(outdir) == ["n.0001.exr"]  # frames before it are complete
    r = run(*args, "--skip-missing")
    assert r.returncode == 0, r.stderr
    assert "warning: frame 2" in r.stderr and "1 missing input" in r.stderr, r.stderr
    assert listing(outdir) == ["n.0001.exr", "n.0003.exr"]


def test_skip_existing_rerenders_only_what_changed(run, dirs):
    indir, outdir = dirs
    plates(indir, [1, 2, 3])
    args = [indir / "plate.####.exr", "--frames", "1-3", f"--filmgrain:{FAST}:seed=3",
            "-o", outdir / "n.####.exr", "--skip-existing"]
    r = run(*args)
    assert r.returncode == 0 and "3 rendered" in r.stderr, r.stderr
    first = {f: pixels(outdir / f"n.{f:04d}.exr") for f in (1, 2, 3)}
    # Frame 2 deleted; frame 3 replaced by one made with other settings.
    os.remove(outdir / "n.0002.exr")
    r = run(indir / "plate.0003.exr", f"--filmgrain:{FAST}:seed=4:frame=3", "-o",
            outdir / "n.0003.exr")
    assert r.returncode == 0, r.stderr
    mtime_1 = os.stat(outdir / "n.0001.exr").st_mtime_ns
    r = run(*args)
    assert r.returncode == 0, r.stderr
    assert "2 rendered, 1 up to date" in r.stderr, r.stderr
    assert "n.0001.exr' is up to date" in r.stderr
    assert os.stat(outdir / "n.0001.exr").st_mtime_ns == mtime_1
    for f in (1, 2, 3):
        assert np.array_equal(pixels(outdir / f"n.{f:04d}.exr"), first[f]), f
    # A changed setting re-renders every frame.
    r = run(*args[:3], f"--filmgrain:{FAST}:seed=3:exposure_stops=1", *args[4:])
    assert r.returncode == 0 and "3 rendered" in r.stderr, r.stderr


def test_sigkill_mid_frame_leaves_no_partial_file_and_resumes(fg_bin, dirs):
    """Farm pre-emption: SIGKILL while frame 2 renders. Frame 1 is complete,
    nothing else exists (no temporary file either), and --skip-existing
    renders only frame 2."""
    _, outdir = dirs
    args = [fg_bin, "--wedge", "--frames", "1-2", "--filmgrain:stock=color-negative:width_mm=4:tile=16",
            "--threads", "1", "--progress", "-o", outdir / "w.####.exr",
            "--stats", outdir / "w.####.json", "--skip-existing"]
    with reaped(subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 env=clean_env())) as proc:
        read_stderr_until(proc, b"frame 2/2 (2)", timeout=120)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    assert listing(outdir) == ["w.0001.exr", "w.0001.json"]
    done = pixels(outdir / "w.0001.exr")
    r = subprocess.run(args, capture_output=True, text=True, env=clean_env(), timeout=300)
    assert r.returncode == 0, r.stderr
    assert "1 rendered, 1 up to date" in r.stderr, r.stderr
    assert listing(outdir) == ["w.0001.exr", "w.0001.json", "w.0002.exr", "w.0002.json"]
    assert np.array_equal(pixels(outdir / "w.0001.exr"), done)


def test_progress_names_the_frame(run, dirs):
    _, outdir = dirs
    r = run("--wedge", "--frames", "1-2", f"--filmgrain:stock=paper:{FAST}", "--progress",
            "-o", outdir / "w.#.exr")
    assert r.returncode == 0, r.stderr
    assert "frame 1/2 (1)" in r.stderr and "frame 2/2 (2)" in r.stderr, r.stderr
    assert "elapsed" in r.stderr
    r = run("--wedge", "--frames", "1-2", f"--filmgrain:stock=paper:{FAST}", "-o",
            outdir / "q.#.exr", "-q")
    assert r.returncode == 0 and r.stderr == ""


def test_dry_run_lists_the_frames_and_what_is_up_to_date(run, dirs):
    indir, outdir = dirs
    plates(indir, [1, 2])
    args = [indir / "plate.####.exr", "--frames", "1-3", f"--filmgrain:{FAST}", "-o",
            outdir / "n.####.exr"]
    assert run(*args[:2], "1", *args[3:]).returncode == 0  # frame 1 rendered
    r = run(*args, "--dry-run")
    assert r.returncode == 0, r.stderr
    lines = [json.loads(line) for line in r.stdout.splitlines()]
    assert [d["frame"] for d in lines] == [1, 2, 3]
    assert [d["input_exists"] for d in lines] == [True, True, False]
    assert [d["up_to_date"] for d in lines] == [True, False, False]
    assert lines[0]["settings_hash"] == Exr(outdir / "n.0001.exr").attr("filmgrain:settings_hash")
    assert lines[1]["output"] == str(outdir / "n.0002.exr")
    assert listing(outdir) == ["n.0001.exr"]  # nothing rendered


def test_report_json_says_what_became_of_each_frame(run, dirs):
    """--report-json: one JSON line per frame on stdout, as it ends, with -q
    as without; frame 1 up to date, 2 rendered, 3 without input."""
    indir, outdir = dirs
    plates(indir, [1, 2])
    args = [indir / "plate.####.exr", "--frames", "1-3", f"--filmgrain:{FAST}", "-o",
            outdir / "n.####.exr", "--skip-existing", "--skip-missing", "-q"]
    assert run(*args[:2], "1", *args[3:6]).returncode == 0  # frame 1 rendered
    r = run(*args, "--report-json")
    assert r.returncode == 0 and r.stderr == "", r.stderr
    lines = [json.loads(line) for line in r.stdout.splitlines()]
    assert [(d["frame"], d["outcome"]) for d in lines] \
        == [(1, "up_to_date"), (2, "rendered"), (3, "missing_input")]
    assert lines[1]["output"] == str(outdir / "n.0002.exr")
    assert all(d["seconds"] >= 0 for d in lines)
    r = run(*args, "--report-json", "--dry-run")
    assert r.returncode == 1 and "give one or the other" in r.stderr
