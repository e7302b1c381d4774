"""Bad input of every kind: exit status 1, a message that says what is wrong
(checked by key words), and nothing written: no EXR, no --stats, no
--preview, no temporary file."""

import json
import os
import subprocess

import numpy as np
import pytest

from conftest import (FAST, assert_nothing_written, clean_env, listing, minimal_ocio_config,
                      rgb_ramp, write_image)


def truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    return path


def stock_file(d, text):
    p = d / "stock.json"
    p.write_text(text if isinstance(text, str) else json.dumps(text))
    return p


# Each case: (name, setup(indir) -> extra args before --filmgrain, modifiers,
# expected words in stderr). The run always asks for -o, --stats and
# --preview in outdir unless the case overrides the outputs.
def ramp(d):
    return write_image(d / "ramp.exr", rgb_ramp())


CASES = [
    ("missing_input", lambda d: [d / "missing.exr"], FAST, ["missing.exr", "does not exist"]),
    ("truncated_exr", lambda d: [truncate(write_image(d / "t.exr", rgb_ramp()))], FAST,
     ["cannot read", "t.exr"]),
    ("truncated_png",
     lambda d: [truncate(write_image(d / "t.png", (rgb_ramp() * 255).astype(np.uint8),
                                     fmt="uint8"))],
     FAST, ["cannot read", "t.png"]),
    ("two_channels", lambda d: [write_image(d / "two.exr", rgb_ramp()[:, :, :2])], FAST,
     ["has no channels R, G, B or Y", "part 0 has R,G", "--ch"]),
    ("unknown_iscolorspace", lambda d: [ramp(d), "--iscolorspace", "NoSuchSpace"], FAST,
     ["NoSuchSpace", "unknown colour space"]),
    ("file_declares_unknown_colorspace",
     lambda d: [write_image(d / "in.png", (rgb_ramp() * 255).astype(np.uint8), fmt="uint8"),
                "--colorconfig", write_text(d / "min.ocio", minimal_ocio_config())],
     FAST, ["declares colour space 'sRGB'", "--iscolorspace"]),
    ("unknown_config_file",
     lambda d: [ramp(d), "--colorconfig", d / "nope.ocio"], FAST,
     ["cannot load OCIO config", "nope.ocio"]),
    ("unknown_modifier", lambda d: [ramp(d)], FAST + ":foo=1",
     ["unknown modifier 'foo'", "valid modifiers", "exposure"]),
    ("duplicated_modifier", lambda d: [ramp(d)], FAST + ":seed=1:seed=2",
     ["'seed' given twice"]),
    ("exposure_abc", lambda d: [ramp(d)], FAST + ":exposure_stops=abc",
     ["exposure_stops=abc", "not a decimal number", "STOPS"]),
    ("exposure_nan", lambda d: [ramp(d)], FAST + ":exposure_stops=nan", ["exposure_stops=nan", "finite"]),
    ("exposure_out_of_range", lambda d: [ramp(d)], FAST + ":exposure_stops=100",
     ["exposure_stops = 100", "[-64, 64]"]),
    ("seed_negative", lambda d: [ramp(d)], FAST + ":seed=-1", ["seed=-1", "whole number"]),
    ("seed_fraction", lambda d: [ramp(d)], FAST + ":seed=1.5", ["seed=1.5", "whole number"]),
    ("scan_zero", lambda d: [ramp(d)], FAST + ":scan=0x0", ["scan=0x0", "at least 1"]),
    ("scan_no_height", lambda d: [ramp(d)], FAST + ":scan=10x", ["scan=10x", "height"]),
    ("empty_value", lambda d: [ramp(d)], FAST + ":stock=", ["stock=", "empty value"]),
    ("roi_zero_size", lambda d: [ramp(d)], FAST + ":roi=0,0,0,5", ["roi=0,0,0,5", "width"]),
    ("roi_outside_scan", lambda d: [ramp(d)], FAST + ":roi=20,10,20,20",
     ["roi = 20,10,20,20", "inside the 32x24 scan"]),
    ("stock_syntax_error", lambda d: [ramp(d)], "stock={stock}:" + FAST,
     ["stock.json", "not valid JSON"]),
    ("stock_unknown_key", lambda d: [ramp(d)], "stock={stock}:" + FAST,
     ["nmae", "unknown key"]),
    ("stock_wrong_type", lambda d: [ramp(d)], "stock={stock}:" + FAST,
     ["base_density", "must be a number"]),
    ("stock_negative_diameter", lambda d: [ramp(d)], "stock={stock}:" + FAST,
     ["layers[0].populations[0].diameter_um", "-1"]),
    ("unknown_stock", lambda d: [ramp(d)], "stock=no-such-stock:" + FAST,
     ["no-such-stock", "preset"]),
    ("input_and_wedge", lambda d: [ramp(d), "--wedge"], FAST, ["both", "--wedge"]),
    ("bad_data_type", lambda d: [ramp(d), "-d", "uint8"], FAST, ["-d uint8", "half or float"]),
    ("bad_compression", lambda d: [ramp(d)], FAST, ["compression=jpeg", "zip"]),
]

STOCK_TEXT = {
    "stock_syntax_error": '{"name": "broken", ',
    "stock_unknown_key": {"nmae": "typo"},
    "stock_wrong_type": {"base_density": "high"},
    "stock_negative_diameter": {"layers": [{"name": "Y", "populations": [{"diameter_um": -1}]}]},
}


def write_text(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize("name,setup,mods,words", CASES, ids=[c[0] for c in CASES])
def test_bad_input(run, dirs, name, setup, mods, words):
    indir, outdir = dirs
    args = setup(indir)
    if name in STOCK_TEXT:
        mods = mods.format(stock=stock_file(indir, STOCK_TEXT[name]))
    out_flag = "-o:compression=jpeg" if name == "bad_compression" else "-o"
    inputs = listing(indir)
    r = run(*args, f"--filmgrain:{mods}", out_flag, outdir / "o.exr",
            "--stats", outdir / "s.json", "--preview", outdir / "p.png")
    assert r.returncode == 1, r.stderr
    assert "filmgrain: error:" in r.stderr
    for w in words:
        assert w in r.stderr, (w, r.stderr)
    assert "Traceback" not in r.stderr and "terminate" not in r.stderr
    assert_nothing_written(outdir)
    assert_nothing_written(indir, inputs)


def run_expect_error(run, args, words, dirs_to_check):
    """dirs_to_check: [(dir, expected listing)]"""
    r = run(*args)
    assert r.returncode == 1, r.stderr
    assert "filmgrain: error:" in r.stderr
    for w in words:
        assert w in r.stderr, (w, r.stderr)
    for d, expected in dirs_to_check:
        assert_nothing_written(d, expected)
    return r


def test_output_is_input(run, dirs):
    indir, _ = dirs
    src = ramp(indir)
    before = src.read_bytes()
    run_expect_error(run, [src, f"--filmgrain:{FAST}", "-o", src], ["same file"],
                     [(indir, ["ramp.exr"])])
    # Another spelling of the same path.
    run_expect_error(run, [src, f"--filmgrain:{FAST}", "-o", indir / ".." / "in" / "ramp.exr"],
                     ["same file"], [(indir, ["ramp.exr"])])
    assert src.read_bytes() == before


def test_stats_is_output(run, dirs):
    indir, outdir = dirs
    run_expect_error(run, [ramp(indir), f"--filmgrain:{FAST}", "-o", outdir / "o.exr",
                           "--stats", outdir / "o.exr"], ["same file"], [(outdir, [])])


def test_output_directory_missing(run, dirs):
    indir, outdir = dirs
    run_expect_error(run, [ramp(indir), f"--filmgrain:{FAST}", "-o", outdir / "no" / "o.exr",
                           "--preview", outdir / "p.png"],
                     ["cannot write", "no/o.exr", "No such file"], [(outdir, [])])


def test_output_parent_is_a_file(run, dirs):
    indir, outdir = dirs
    src = ramp(indir)
    run_expect_error(run, [src, f"--filmgrain:{FAST}", "-o", src / "o.exr"],
                     ["cannot write", "Not a directory"], [(indir, ["ramp.exr"])])


def as_unprivileged(run, fg_bin):
    """`run`, or as root (which ignores directory permissions: CI runs as
    root) the same command as user nobody through util-linux's setpriv.
    Skips, saying why, where nobody cannot run the CLI (a build tree under
    a directory closed to others)."""
    if os.geteuid() != 0:
        return run
    drop = ["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups"]
    probe = subprocess.run([*drop, fg_bin, "--version"], capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip(f"root, and user nobody cannot run {fg_bin}: {probe.stderr.strip()}")

    def _run(*args, env=None, timeout=120):
        return subprocess.run([*drop, fg_bin, *[str(a) for a in args]], capture_output=True,
                              text=True, env=env if env is not None else clean_env(),
                              timeout=timeout)

    return _run


def test_output_directory_unwritable(run, fg_bin, dirs):
    indir, outdir = dirs
    src = ramp(indir)
    # pytest makes its temporary directories 0700: open them (and the base
    # above) to nobody, who runs the CLI when the tests run as root.
    for d in (indir.parent.parent, indir.parent, indir, outdir):
        d.chmod(0o755)
    src.chmod(0o644)
    outdir.chmod(0o555)
    try:
        run_expect_error(as_unprivileged(run, fg_bin),
                         [src, f"--filmgrain:{FAST}", "-o", outdir / "o.exr"],
                         ["cannot write", "Permission denied"], [(outdir, [])])
    finally:
        outdir.chmod(0o755)


def test_unwritable_stats_means_no_exr_either(run, dirs):
    indir, outdir = dirs
    run_expect_error(run, [ramp(indir), f"--filmgrain:{FAST}", "-o", outdir / "o.exr",
                           "--preview", outdir / "p.png", "--stats", outdir / "no" / "s.json"],
                     ["cannot write", "s.json"], [(outdir, [])])


def test_non_exr_output(run, dirs):
    indir, outdir = dirs
    for name in ("o.png", "o.tif", "o"):
        run_expect_error(run, [ramp(indir), f"--filmgrain:{FAST}", "-o", outdir / name],
                         ["OpenEXR", name], [(outdir, [])])


def test_preview_must_be_png(run, dirs):
    indir, outdir = dirs
    run_expect_error(run, [ramp(indir), f"--filmgrain:{FAST}", "-o", outdir / "o.exr",
                           "--preview", outdir / "p.jpg"], ["--preview", ".png"],
                     [(outdir, [])])


def test_filmgrain_twice(run, dirs):
    indir, outdir = dirs
    run_expect_error(run, [ramp(indir), "--filmgrain", f"--filmgrain:{FAST}", "-o",
                           outdir / "o.exr"], ["--filmgrain", "at most once"], [(outdir, [])])


def test_missing_filmgrain_or_output_or_input(run, dirs):
    indir, outdir = dirs
    src = ramp(indir)
    run_expect_error(run, [src, "-o", outdir / "o.exr"], ["no --filmgrain"], [(outdir, [])])
    run_expect_error(run, [src, "--filmgrain"], ["-o FILE.exr"], [(outdir, [])])
    run_expect_error(run, ["--filmgrain", "-o", outdir / "o.exr"], ["no INPUT"],
                     [(outdir, [])])
    run_expect_error(run, [src, src, "--filmgrain", "-o", outdir / "o.exr"],
                     ["more than one INPUT"], [(outdir, [])])


def test_modifiers_on_other_options(run, dirs):
    indir, outdir = dirs
    run_expect_error(run, [ramp(indir), "--filmgrain", "--stats:x=1", outdir / "s.json",
                           "-o", outdir / "o.exr"], ["--stats takes no :modifiers"],
                     [(outdir, [])])


def test_iscolorspace_with_wedge(run, dirs):
    _, outdir = dirs
    run_expect_error(run, ["--wedge", "--iscolorspace", "sRGB", "--filmgrain", "-o",
                           outdir / "o.exr"], ["--iscolorspace", "wedge"], [(outdir, [])])


def test_bad_threads(run, dirs):
    indir, outdir = dirs
    run_expect_error(run, [ramp(indir), "--filmgrain", "-o", outdir / "o.exr", "--threads",
                           "-1"], ["--threads -1"], [(outdir, [])])
