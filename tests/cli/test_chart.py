"""--chart: the built-in look chart (core/include/filmgrain/chart.h) rendered
like the wedge, and the options it does not combine with.

The chart is rendered once, with the defaults, exactly as --help's example
does (a few seconds on two cores); the other tests are quick.
"""

import json
import subprocess

import numpy as np
import OpenImageIO as oiio
import pytest

from conftest import FAST, Exr, assert_nothing_written, clean_env, read_json, rgb_ramp, write_image

# ChartSpec{}: 1536x768 px on a 9.6 mm strip; the point light's centre, a
# patch's top-left corner and the grey rectangle, as chart.h documents them.
WIDTH, HEIGHT, STRIP_MM = 1536, 768, 9.6
POINT = (256, 256)  # (x, y), a disc of radius 3 px at 0.18 * 2^10
GROUND = (slice(640, 740), slice(40, 480))  # (rows, columns): ground only
RECT = (slice(250, 520), slice(620, 920))  # inside the 0.18 rectangle
PATCH, PATCH_STEP = (1044, 228), 80  # patch 1's corner; 72 px + 8 px gap


def patch_region(index):
    """The inner 48x48 pixels of ColorChecker patch `index` (1-based)."""
    col, row = (index - 1) % 6, (index - 1) // 6
    x, y = PATCH[0] + col * PATCH_STEP + 12, PATCH[1] + row * PATCH_STEP + 12
    return slice(y, y + 48), slice(x, x + 48)


@pytest.fixture(scope="module")
def chart(fg_bin, tmp_path_factory):
    """The default chart render: (CompletedProcess, directory)."""
    d = tmp_path_factory.mktemp("chart")
    r = subprocess.run([fg_bin, "--chart", "--filmgrain", "-o", str(d / "chart.exr"),
                        "--preview", str(d / "chart.png"), "--stats", str(d / "s.json")],
                       capture_output=True, text=True, env=clean_env(), timeout=240)
    return r, d


def test_chart_renders_exr_and_preview(chart):
    r, d = chart
    assert r.returncode == 0, r.stderr
    assert "look chart" in r.stderr
    exr = Exr(d / "chart.exr")
    assert (exr.spec.width, exr.spec.height, exr.spec.nchannels) == (WIDTH, HEIGHT, 3)
    # The chart's own strip width, as the wedge has its own.
    assert exr.attr("filmgrain:width_mm") == pytest.approx(STRIP_MM)
    png = oiio.ImageBuf(str(d / "chart.png"))
    assert not png.has_error, png.geterror()
    assert (png.spec().width, png.spec().height) == (WIDTH, HEIGHT)
    s = read_json(d / "s.json")
    assert s["input"]["file"] == "chart"
    assert s["input"]["colorspace"] == "scene_linear"
    assert s["width_mm"] == pytest.approx(STRIP_MM)


def test_chart_point_light_is_denser_than_the_ground(chart):
    r, d = chart
    assert r.returncode == 0, r.stderr
    exr = Exr(d / "chart.exr")
    x, y = POINT
    for name, density in exr.channels.items():
        ground = float(density[GROUND].mean())
        # The 3x3 pixels at the disc's centre, 10 stops over grey: well up
        # the curve (on the default stock ~1 above the ground's base + fog;
        # single pixels are grainy, hence a margin of half that).
        point = float(density[y - 1:y + 2, x - 1:x + 2].mean())
        assert point > ground + 0.5, (name, point, ground)
        # The grey rectangle too, and white 9.5 (patch 19) over black 2 (24).
        assert float(density[RECT].mean()) > ground + 0.5, name
        assert float(density[patch_region(19)].mean()) > \
            float(density[patch_region(24)].mean()) + 0.3, name


def test_chart_dry_run_reports_the_chart(run, tmp_path):
    r = run("--chart", f"--filmgrain:{FAST}", "-o", tmp_path / "o.exr", "--dry-run")
    assert r.returncode == 0, r.stderr
    line = json.loads(r.stdout.splitlines()[0])
    assert line["input"] == "chart" and line["input_exists"] is True
    # A different scene from the wedge's, so a different settings hash.
    w = run("--wedge", f"--filmgrain:{FAST}", "-o", tmp_path / "o.exr", "--dry-run")
    assert json.loads(w.stdout.splitlines()[0])["settings_hash"] != line["settings_hash"]


@pytest.mark.parametrize("args,words", [
    (["{input}", "--chart"], ["both INPUT", "--chart", "one or the other"]),
    (["--wedge", "--chart"], ["both --wedge and --chart", "one or the other"]),
    (["--chart", "--iscolorspace", "sRGB"], ["--iscolorspace applies to INPUT",
                                             "--chart is scene-linear"]),
    (["--chart", "--chart"], ["--chart may be given at most once"]),
], ids=["input_and_chart", "wedge_and_chart", "iscolorspace_with_chart", "chart_twice"])
def test_chart_does_not_combine(run, dirs, args, words):
    indir, outdir = dirs
    src = write_image(indir / "ramp.exr", rgb_ramp())
    args = [src if a == "{input}" else a for a in args]
    r = run(*args, f"--filmgrain:{FAST}", "-o", outdir / "o.exr", "--preview",
            outdir / "o.png", "--stats", outdir / "s.json")
    assert r.returncode == 1, r.stderr
    assert "filmgrain: error:" in r.stderr
    for w in words:
        assert w in r.stderr, (w, r.stderr)
    assert_nothing_written(outdir)
    assert_nothing_written(indir, ["ramp.exr"])


def test_help_describes_chart(run):
    r = run("--help")
    assert r.returncode == 0, r.stderr
    text = r.stdout
    assert "\n    --chart " in text
    flat = " ".join(text.split())
    # From ChartSpec's defaults.
    assert f"look chart instead of INPUT: {WIDTH}x{HEIGHT}" in flat
    assert f"{STRIP_MM} mm wide" in flat
    assert "ColorChecker" in flat
    assert "filmgrain --chart --filmgrain -o out/chart.exr --preview out/chart.png" in text
