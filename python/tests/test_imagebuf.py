"""filmgrain.render_imagebuf / to_imagebuf: OpenImageIO ImageBufs through
NumPy, with the CLI's channels, windows and metadata; progress reports."""

import numpy as np
import OpenImageIO as oiio
import pytest

import filmgrain
from conftest import (CLI_ONLY_ATTRIBUTES, FAST_WIDTH_MM, Exr, assert_same_as_cli, render_cli,
                      scene_pixels, write_image)


def assert_buf_equals_cli(buf, tmp_path, cli_path):
    """buf written as EXR equals the CLI's EXR: channels, windows, pixels,
    filmgrain:* metadata."""
    assert not buf.has_error, buf.geterror()
    mine_path = tmp_path / "module.exr"
    assert buf.write(str(mine_path)), buf.geterror()
    mine, cli = Exr(mine_path), Exr(cli_path)
    assert mine.names == cli.names
    for a, b in ((mine.spec, cli.spec),):
        assert (a.x, a.y, a.width, a.height) == (b.x, b.y, b.width, b.height)
        assert (a.full_x, a.full_y, a.full_width, a.full_height) == (
            b.full_x, b.full_y, b.full_width, b.full_height)
    for name in cli.names:
        assert mine.channels[name].tobytes() == cli.channels[name].tobytes(), name
    cli_attributes = cli.attributes()
    for name in CLI_ONLY_ATTRIBUTES:
        cli_attributes.pop(name, None)
    assert mine.attributes() == cli_attributes


def test_render_imagebuf_equals_cli(fg_bin, tmp_path, scene_exr):
    path, _ = scene_exr
    mods = {"stock": "color-negative", "seed": 21, "frame": 7, "width_mm": FAST_WIDTH_MM,
            "roi": "10,5,30,20"}
    cli_exr, cli_stats = render_cli(fg_bin, tmp_path, path, mods)
    kwargs = dict(mods, roi=(10, 5, 30, 20))
    buf, stats = filmgrain.render_imagebuf(oiio.ImageBuf(str(path)), **kwargs)
    assert stats["roi"] == cli_stats["roi"]
    assert_buf_equals_cli(buf, tmp_path, tmp_path / "cli.exr")
    assert cli_exr.names  # read back


def test_data_window_inside_the_display_window_is_placed_as_by_the_cli(fg_bin, tmp_path):
    """A 40x30 data window at (12, 9) of a 64x48 display window: the film
    frame is the display window, and the negative covers the data window
    (MODEL.md 2), in the display window's scan."""
    pixels = scene_pixels(40, 30)
    window = (12, 9, 0, 0, 64, 48)
    path = write_image(tmp_path / "crop.exr", pixels, window=window)
    mods = {"stock": "paper", "seed": 5, "width_mm": FAST_WIDTH_MM}
    render_cli(fg_bin, tmp_path, path, mods)
    buf, stats = filmgrain.render_imagebuf(oiio.ImageBuf(str(path)), **mods)
    assert (buf.spec().full_width, buf.spec().full_height) == (64, 48)
    # The stats describe that scan (the CLI's --stats says 40x30 here: it
    # measures the data window; reported to the lead).
    assert (stats["scan"]["width"], stats["scan"]["height"]) == (64, 48)
    assert stats["scan"]["pitch_x_um"] == FAST_WIDTH_MM * 1000.0 / 64
    assert_buf_equals_cli(buf, tmp_path, tmp_path / "cli.exr")
    s = buf.spec()
    assert (s.x, s.y, s.width, s.height) == (12, 9, 40, 30)
    # Not the same as rendering the bare 40x30 array as a whole frame: its
    # pixels are 64/40 as wide.
    bare = filmgrain.render(pixels, **mods)
    assert bare.density.shape[:2] == (30, 40)
    assert not np.array_equal(bare.density, buf.get_pixels(oiio.FLOAT))


def test_to_imagebuf_of_a_render(fg_bin, tmp_path, scene_exr):
    path, pixels = scene_exr
    mods = {"stock": "paper", "seed": 8, "width_mm": FAST_WIDTH_MM}
    exr, cli_stats = render_cli(fg_bin, tmp_path, path, mods)
    negative = filmgrain.render(pixels, **mods)
    assert_same_as_cli(negative, exr, cli_stats)
    assert_buf_equals_cli(filmgrain.to_imagebuf(negative), tmp_path, tmp_path / "cli.exr")


def test_imagebuf_in_other_pixel_types_is_read_as_float():
    pixels = scene_pixels(24, 16)
    spec = oiio.ImageSpec(24, 16, 3, oiio.HALF)
    half = oiio.ImageBuf(spec)
    assert half.set_pixels(half.roi, pixels)
    as_float = half.get_pixels(oiio.FLOAT)
    buf, _ = filmgrain.render_imagebuf(half, seed=1, width_mm=0.2)
    expect = filmgrain.render(np.ascontiguousarray(as_float, dtype=np.float32), seed=1,
                              width_mm=0.2)
    assert buf.get_pixels(oiio.FLOAT).tobytes() == expect.density.tobytes()


def test_bad_imagebufs_raise():
    with pytest.raises(filmgrain.Error, match="has an error"):
        filmgrain.render_imagebuf(oiio.ImageBuf("/no/such/file.exr"))
    two = oiio.ImageBuf(oiio.ImageSpec(8, 8, 2, oiio.FLOAT))
    with pytest.raises(filmgrain.Error, match="2 channels"):
        filmgrain.render_imagebuf(two)


def test_progress_reports_and_cancels():
    pixels = scene_pixels()
    # A render of well over a tenth of a second (a larger frame: more grains;
    # the paper-scale stock: the default's 50 grains/um^2 a layer would take
    # minutes grain by grain).
    kw = {"stock": "color-negative", "seed": 1, "width_mm": 1.0, "engine": "exact"}
    seen = []
    negative = filmgrain.render(pixels, progress=lambda f: seen.append(f), **kw)
    assert negative.stats["seconds"]["simulate"] > 0.25, "the render is too short to test"
    assert seen, "progress was never called"
    assert all(0.0 <= f <= 1.0 for f in seen) and seen == sorted(seen)

    with pytest.raises(filmgrain.Error, match="cancelled"):
        filmgrain.render(pixels, progress=lambda f: False, **kw)

    class Stop(Exception):
        pass

    def boom(_):
        raise Stop("from the callback")

    with pytest.raises(Stop, match="from the callback"):
        filmgrain.render(pixels, progress=boom, **kw)
