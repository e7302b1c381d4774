"""Data and display windows (MODEL.md 2; issue 45 part 4): the negative
covers the input's data window, scaled to the scan and rounded outward to
whole scan pixels, whether it is larger than the display window (overscan)
or smaller (a crop, a CG element's box); the rounding is said in --stats and
in the EXR header; a ROI or another tiling is a crop of the whole render."""

from fractions import Fraction
import math

import numpy as np
import OpenImageIO as oiio

from conftest import FAST, Exr, read_json


def write_windowed(path, data, display, value=None):
    """An EXR with data window `data` = (x, y, w, h) and display window
    `display` = (x, y, w, h); pixels: a smooth ramp (or `value`)."""
    x, y, w, h = data
    spec = oiio.ImageSpec(w, h, 3, "float")
    spec.x, spec.y = x, y
    spec.full_x, spec.full_y, spec.full_width, spec.full_height = display
    if value is None:
        gx = np.linspace(0.05, 0.6, w, dtype=np.float32)[None, :, None]
        gy = np.linspace(0.5, 1.0, h, dtype=np.float32)[:, None, None]
        pixels = np.broadcast_to(gx * gy, (h, w, 3)).copy()
    else:
        pixels = np.full((h, w, 3), value, np.float32)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()


def expected_scan_window(data, display, scan_w):
    """The data window's scan pixels, computed here independently: the scan
    is scan_w wide over the display window and follows its aspect (height
    rounded half away from zero, as std::round); each edge is rounded
    outward. Returns (x0, y0, x1, y1) and the exact edges."""
    dx, dy, dw, dh = data
    fx, fy, fw, fh = display
    scan_h = int(Fraction(scan_w * fh, fw) + Fraction(1, 2))  # positive: half up
    sx, sy = Fraction(scan_w, fw), Fraction(scan_h, fh)
    exact = ((dx - fx) * sx, (dy - fy) * sy, (dx + dw - fx) * sx, (dy + dh - fy) * sy)
    return (math.floor(exact[0]), math.floor(exact[1]), math.ceil(exact[2]),
            math.ceil(exact[3])), [float(e) for e in exact], scan_h


def render_at_scan(run, src, out, options, scan, data, display):
    """Renders `src` (data window `data`, display window `display`) to `out`
    with `--filmgrain:<options>:scan=<scan>` and --stats (`out` with .json)
    and asserts that it succeeded and that the negative's data window is
    expected_scan_window's. Returns the output's spec, the stats'
    data_window, and expected_scan_window's result."""
    stats = out.with_suffix(".json")
    r = run(src, f"--filmgrain:{options}:scan={scan}", "-o", out, "--stats", stats)
    assert r.returncode == 0, r.stderr
    expected = expected_scan_window(data, display, scan)
    x0, y0, x1, y1 = expected[0]
    s = Exr(out).spec
    assert (s.x, s.y, s.width, s.height) == (x0, y0, x1 - x0, y1 - y0)
    return s, read_json(stats)["data_window"], expected


def test_any_overscan_renders_at_any_scan(run, dirs):
    """A 2048x1556 display window with 155 px of overscan left and right and
    1 px above and below (the issue's plates), at proxy scans 256 and 1024:
    the negative covers the overscan rounded outward, and says so. The
    plate is a 2K scan of a Super 35 frame (24.89 mm, 12 um pixels): FAST's
    0.5 mm would make its pixels 0.24 um, finer than any scan, and the
    default stock's base halation (2.5 mm) would then need a transform over
    the limit (refused with a clear error, docs/model.md)."""
    indir, outdir = dirs
    display = (0, 0, 2048, 1556)
    data = (-155, -1, 2048 + 310, 1556 + 2)
    write_windowed(indir / "plate.exr", data, display)
    for scan in (256, 1024):
        out = outdir / f"n{scan}.exr"
        s, st, ((x0, y0, x1, y1), exact, scan_h) = render_at_scan(
            run, indir / "plate.exr", out, "width_mm=24.89", scan, data, display)
        assert (s.full_x, s.full_y, s.full_width, s.full_height) == (0, 0, scan, scan_h)
        assert (st["x"], st["y"], st["width"], st["height"]) == (x0, y0, x1 - x0, y1 - y0)
        assert np.allclose(st["exact"], exact, rtol=0, atol=1e-9)
        rounded = [x0, y0, x1, y1] != exact
        assert st["rounded"] == rounded
        note = Exr(out).attr("filmgrain:data_window_rounding")
        assert (note is not None) == rounded, note
        # Film everywhere: every layer's densities finite, the overscan
        # developed like the display window beside it.
        for c in Exr(out).channels.values():
            assert np.isfinite(c).all()


def test_one_pixel_of_overscan(run, dirs):
    """1 px of overscan on every side of a 64x48 display window: at scan 40
    (0.625 scan pixel per input pixel) it rounds out to one scan pixel."""
    indir, outdir = dirs
    display, data = (0, 0, 64, 48), (-1, -1, 66, 50)
    write_windowed(indir / "p.exr", data, display)
    r = run(indir / "p.exr", f"--filmgrain:{FAST}:scan=40", "-o", outdir / "n.exr")
    assert r.returncode == 0, r.stderr
    (x0, y0, x1, y1), _, scan_h = expected_scan_window(data, display, 40)
    assert (x0, y0, x1, y1) == (-1, -1, 41, 31)
    s = Exr(outdir / "n.exr").spec
    assert (s.x, s.y, s.width, s.height) == (x0, y0, x1 - x0, y1 - y0)


def test_a_data_window_inside_the_display_window_is_kept_in_proportion(run, dirs):
    """A 40x30 data window at (12, 9) of a 64x48 display window: the negative
    covers the data window's scan, not the whole display window, within a
    pixel of its proportion at a scan that does not divide it."""
    indir, outdir = dirs
    display, data = (0, 0, 64, 48), (12, 9, 40, 30)
    write_windowed(indir / "crop.exr", data, display)
    for scan in (128, 100):
        s, st, (_, exact, scan_h) = render_at_scan(
            run, indir / "crop.exr", outdir / f"c{scan}.exr", FAST, scan, data, display)
        assert (s.full_width, s.full_height) == (scan, scan_h)
        for got, want in zip((s.x, s.y, s.x + s.width, s.y + s.height), exact):
            assert abs(got - want) < 1.0
        assert st["rounded"] == (scan == 100)


def test_roi_and_tiles_are_crops_of_the_whole_render(run, dirs):
    """With rounded overscan the grid is the display window's, continued: a
    ROI reaching into the overscan, and another tile size, give the same
    pixels as the whole render."""
    indir, outdir = dirs
    display, data = (0, 0, 64, 48), (-7, -3, 64 + 14, 48 + 6)
    write_windowed(indir / "p.exr", data, display)
    r = run(indir / "p.exr", f"--filmgrain:{FAST}:scan=50", "-o", outdir / "all.exr")
    assert r.returncode == 0, r.stderr
    whole = Exr(outdir / "all.exr")
    r = run(indir / "p.exr", f"--filmgrain:{FAST}:scan=50:tile=5", "-o", outdir / "t.exr")
    assert r.returncode == 0, r.stderr
    tiled = Exr(outdir / "t.exr")
    for n in whole.names:
        assert np.array_equal(whole.channels[n], tiled.channels[n])
    s = whole.spec
    roi = (s.x, s.y, 13, 9)
    r = run(indir / "p.exr", f"--filmgrain:{FAST}:scan=50:roi={roi[0]},{roi[1]},13,9", "-o",
            outdir / "r.exr")
    assert r.returncode == 0, r.stderr
    part = Exr(outdir / "r.exr")
    assert (part.spec.x, part.spec.y, part.spec.width, part.spec.height) == roi
    for n in whole.names:
        assert np.array_equal(part.channels[n], whole.channels[n][0:9, 0:13])


def test_beyond_the_data_window_the_scene_continues(run, dirs):
    """A uniform 40x30 data window inside a 64x48 display window, rendered
    over the whole display window: with the scene continued (edge=clamp, the
    default) the film beyond the data window is exposed as its edge, so it
    reads the inside's density (within 0.02 D: both means are over
    hundreds of pixels of a pixel-scale layer whose pixel spread is ~0.05
    D); with edge=gate it is unexposed, fog only (far lighter)."""
    indir, outdir = dirs
    display, data = (0, 0, 64, 48), (12, 9, 40, 30)
    write_windowed(indir / "crop.exr", data, display, value=0.18)
    inside = np.zeros((48, 64), bool)
    inside[9:39, 12:52] = True
    means = {}
    for edge in ("clamp", "gate"):
        out = outdir / f"{edge}.exr"
        r = run(indir / "crop.exr", f"--filmgrain:{FAST}:edge={edge}:roi=0,0,64,48", "-o", out)
        assert r.returncode == 0, r.stderr
        e = Exr(out)
        assert e.attr("filmgrain:edge") == edge
        for n in e.names:
            c = e.channels[n]
            means[edge, n] = (float(c[inside].mean()), float(c[~inside].mean()))
    for n in ("R", "G", "B"):
        inner, outer = means["clamp", n]
        assert abs(outer - inner) < 0.02, (n, inner, outer)
        inner, outer = means["gate", n]
        assert outer < inner - 0.2, (n, inner, outer)
