"""Every plate a pipeline hands it (issue 45 parts 3 and 6): channels taken
by name, from the default view and the first part that has them; --subimage,
--view and --ch to choose otherwise; a file without such channels is an
error that names what it has; everything the header says is checked before
any pixel is read, in the render and in --dry-run; -o's modifiers go on the
option."""

import json
import time

import numpy as np
import OpenImageIO as oiio
import pytest

from conftest import Exr, assert_nothing_written, listing, read_json

# A tiny frame of the paper stock: every render well under a second.
QUICK = "--filmgrain:stock=paper:width_mm=0.3"
W, H = 32, 24


def write_parts(path, parts):
    """A multi-part EXR: parts = [(name, channel names, value per channel)]."""
    specs = []
    for name, channels, _ in parts:
        spec = oiio.ImageSpec(W, H, len(channels), "float")
        spec.channelnames = tuple(channels)
        spec.attribute("name", name)
        specs.append(spec)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), tuple(specs)), out.geterror()
    for i, (_, channels, values) in enumerate(parts):
        if i:
            assert out.open(str(path), specs[i], "AppendSubimage"), out.geterror()
        px = np.empty((H, W, len(channels)), np.float32)
        px[...] = np.asarray(values, np.float32)
        assert out.write_image(px), out.geterror()
    out.close()
    return path


def write_channels(path, channels, values, views=None):
    """A single-part EXR with these channels (values per channel), and a
    multiView attribute when `views` is given."""
    spec = oiio.ImageSpec(W, H, len(channels), "float")
    spec.channelnames = tuple(channels)
    if views:
        spec.attribute("multiView", oiio.TypeDesc(f"string[{len(views)}]"), tuple(views))
    buf = oiio.ImageBuf(spec)
    px = np.empty((H, W, len(channels)), np.float32)
    px[...] = np.asarray(values, np.float32)
    buf.set_pixels(oiio.ROI(), px)
    assert buf.write(str(path)), buf.geterror()
    return path


def mean_density(path):
    e = Exr(path)
    return float(np.mean([c.mean() for c in e.channels.values()]))


def test_the_first_part_with_rgb_is_read_not_depth(run, dirs):
    """A multi-part file whose first part is depth (Z = 5) renders its beauty
    part: the negative is the beauty's, not Z read as light."""
    indir, outdir = dirs
    src = write_parts(indir / "mp.exr", [("depth", ["Z"], [5.0]),
                                         ("beauty", ["R", "G", "B"], [0.18, 0.18, 0.18])])
    ref = write_channels(indir / "grey.exr", ["R", "G", "B"], [0.18, 0.18, 0.18])
    r = run(src, QUICK, "-o", outdir / "mp.exr")
    assert r.returncode == 0, r.stderr
    assert "part 1 'beauty' of 2, channels R,G,B" in r.stderr
    r = run(ref, QUICK, "-o", outdir / "grey.exr")
    assert r.returncode == 0, r.stderr
    a, b = Exr(outdir / "mp.exr"), Exr(outdir / "grey.exr")
    assert all(np.array_equal(a.channels[n], b.channels[n]) for n in a.names)
    # Chosen by name or index; the depth part has no R, G, B or Y.
    r = run(src, QUICK, "--subimage", "beauty", "-o", outdir / "n.exr")
    assert r.returncode == 0, r.stderr
    r = run(src, QUICK, "--subimage", "0", "-o", outdir / "z.exr")
    assert r.returncode == 1
    assert "part 0 'depth' has Z" in r.stderr and "--ch" in r.stderr, r.stderr
    r = run(src, QUICK, "--subimage", "depth", "--ch", "Z", "-o", outdir / "z.exr")
    assert r.returncode == 0, r.stderr
    r = run(src, QUICK, "--subimage", "7", "-o", outdir / "bad.exr")
    assert r.returncode == 1 and "has no such part (it has 2: 0 'depth', 1 'beauty')" in r.stderr
    assert not (outdir / "bad.exr").exists()


def test_views_default_and_chosen(run, dirs):
    """A two-view file: the default view (the first listed) unless --view
    names another; an unknown view is an error listing the views."""
    indir, outdir = dirs
    src = write_channels(indir / "mv.exr", ["R", "G", "B", "right.R", "right.G", "right.B"],
                         [0.05, 0.05, 0.05, 0.8, 0.8, 0.8], views=["left", "right"])
    r = run(src, QUICK, "-o", outdir / "left.exr")
    assert r.returncode == 0 and "view 'left', channels R,G,B" in r.stderr, r.stderr
    r = run(src, QUICK, "--view", "right", "-o", outdir / "right.exr")
    assert r.returncode == 0, r.stderr
    assert "view 'right', channels right.R,right.G,right.B" in r.stderr
    # The right view is brighter: a denser negative.
    assert mean_density(outdir / "right.exr") > mean_density(outdir / "left.exr") + 0.1
    r = run(src, QUICK, "--view", "centre", "-o", outdir / "c.exr")
    assert r.returncode == 1 and "has no such view (it has left, right)" in r.stderr, r.stderr


def test_two_view_luminance_is_grey_not_two_channels(run, dirs):
    """Y and right.Y: a grey image per view (once refused as '2 channels')."""
    indir, outdir = dirs
    src = write_channels(indir / "y.exr", ["Y", "right.Y"], [0.18, 0.5],
                         views=["left", "right"])
    for view, name in (("left", "Y"), ("right", "right.Y")):
        r = run(src, QUICK, "--view", view, "-o", outdir / f"{view}.exr")
        assert r.returncode == 0, r.stderr
        assert f"channels {name}" in r.stderr


def test_grey_with_alpha_and_aov_channels(run, dirs):
    indir, outdir = dirs
    ya = write_channels(indir / "ya.exr", ["Y", "A"], [0.18, 1.0])
    r = run(ya, QUICK, "-o", outdir / "ya.exr")
    assert r.returncode == 0 and "channels Y" in r.stderr, r.stderr
    aov = write_channels(indir / "aov.exr", ["Z", "diffuse.R", "diffuse.G", "diffuse.B"],
                         [3.0, 0.18, 0.18, 0.18])
    r = run(aov, QUICK, "-o", outdir / "aov.exr")
    assert r.returncode == 1
    assert "has no channels R, G, B or Y (part 0 has" in r.stderr and "diffuse.R" in r.stderr
    r = run(aov, QUICK, "--ch", "diffuse.R,diffuse.G,diffuse.B", "-o", outdir / "aov.exr")
    assert r.returncode == 0, r.stderr
    r = run(aov, QUICK, "--ch", "diffuse.R,diffuse.G", "-o", outdir / "x.exr")
    assert r.returncode == 1 and "expected three channel names" in r.stderr
    r = run(aov, QUICK, "--ch", "R,G,B", "-o", outdir / "x.exr")
    assert r.returncode == 1 and "has no channels R, G, B (part 0 has" in r.stderr
    assert sorted(listing(outdir)) == ["aov.exr", "ya.exr"]


def test_luminance_chroma_is_a_clear_error(run, dirs):
    indir, outdir = dirs
    src = write_channels(indir / "yc.exr", ["Y", "RY", "BY"], [0.18, 0.0, 0.0])
    r = run(src, QUICK, "-o", outdir / "o.exr")
    assert r.returncode == 1 and "luminance/chroma" in r.stderr and "--ch Y" in r.stderr
    r = run(src, QUICK, "--ch", "Y", "-o", outdir / "o.exr")
    assert r.returncode == 0, r.stderr


def test_header_refused_before_any_pixel_is_read(run, dirs):
    """A header that asks for a 2,101,364-pixel-wide display window over a
    small data window is refused at once, naming the file, in the render and
    in --dry-run (once read in full: 13.8 s, 3.2 GB)."""
    indir, outdir = dirs
    spec = oiio.ImageSpec(64, 48, 3, "half")
    spec.full_x, spec.full_y, spec.full_width, spec.full_height = 0, 0, 2101364, 48
    path = indir / "wide.exr"
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(np.full((48, 64, 3), 0.18, np.float16))
    out.close()
    t = time.monotonic()
    r = run(path, QUICK, "-o", outdir / "o.exr")
    assert time.monotonic() - t < 10  # a generous bound on "at once" (it takes ~0.1 s)
    assert r.returncode == 1 and str(path) in r.stderr and "2101364x48" in r.stderr, r.stderr
    r = run(path, QUICK, "-o", outdir / "o.exr", "--dry-run")
    assert r.returncode == 0, r.stderr
    line = json.loads(r.stdout.splitlines()[0])
    assert line["error"] and "2101364x48" in line["error"]
    good = write_channels(indir / "g.exr", ["R", "G", "B"], [0.18, 0.18, 0.18])
    r = run(good, QUICK, "-o", outdir / "g.exr", "--dry-run")
    assert json.loads(r.stdout.splitlines()[0])["error"] is None
    assert_nothing_written(outdir)


def test_output_modifiers_after_the_file_name_say_where_they_go(run, dirs):
    indir, outdir = dirs
    src = write_channels(indir / "g.exr", ["R", "G", "B"], [0.18, 0.18, 0.18])
    r = run(src, QUICK, "-o", str(outdir / "o.exr") + ":compression=dwaa")
    assert r.returncode == 1
    assert "modifiers go on the option" in r.stderr and "-o:compression=dwaa" in r.stderr, r.stderr
    r = run(src, QUICK, "-o:compression=dwaa", outdir / "o.exr")
    assert r.returncode == 0, r.stderr


def test_pixels_read_counts_the_data_window(run, dirs):
    """A 20x10 data window of a 32x24 display window: the pixels read are
    the data window's (the rest of the frame is no light, not input)."""
    indir, outdir = dirs
    spec = oiio.ImageSpec(20, 10, 3, "float")
    spec.x, spec.y = 6, 7
    spec.full_x, spec.full_y, spec.full_width, spec.full_height = 0, 0, W, H
    path = indir / "crop.exr"
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(np.full((10, 20, 3), 0.18, np.float32))
    out.close()
    # vision3-500t spreads light: its render reads the whole film.
    r = run(path, "--filmgrain:width_mm=0.3", "-o", outdir / "o.exr", "--stats", outdir / "s.json")
    assert r.returncode == 0, r.stderr
    assert read_json(outdir / "s.json")["input"]["pixels_read"] == 200
