"""filmgrain.render against the filmgrain CLI: the same pixels and settings
give the same bytes of density and the same --stats document."""

import json

import numpy as np
import pytest

import filmgrain
from conftest import (FAST_WIDTH_MM, HEIGHT, WIDTH, Exr, assert_same_as_cli, modifier_text,
                      read_json, render_cli, run_cli,
                      scene_pixels, write_image)

# Each case: the CLI's modifiers as written on its command line, and the same
# settings as render() keywords (Python values: floats, ints, tuples).
CASES = {
    "paper": (
        {"stock": "paper", "seed": 11, "width_mm": FAST_WIDTH_MM, "exposure_stops": "0.75"},
        {"stock": "paper", "seed": 11, "width_mm": FAST_WIDTH_MM, "exposure_stops": 0.75},
    ),
    "color-negative-frame-roi": (
        {"stock": "color-negative", "seed": 18446744073709551615, "frame": -42,
         "width_mm": 0.6, "shutter_s": "1/24", "exposure_stops": "-0.3", "roi": "5,7,40,30"},
        {"stock": "color-negative", "seed": 2**64 - 1, "frame": -42, "width_mm": 0.6,
         "shutter_s": 1 / 24, "exposure_stops": -0.3, "roi": (5, 7, 40, 30)},
    ),
    "scan-static-exact": (
        {"seed": 3, "frame": 1001, "static_grain": 1, "width_mm": 0.3, "scan": "40x30",
         "engine": "exact", "tile": 16},
        {"seed": 3, "frame": 1001, "static_grain": True, "width_mm": 0.3, "scan": (40, 30),
         "engine": "exact", "tile": 16},
    ),
    "expert-tolerance": (
        {"seed": 5, "width_mm": FAST_WIDTH_MM, "tolerance": "0.01", "kinetics": "table",
         "samples": 8},
        {"seed": 5, "width_mm": FAST_WIDTH_MM, "tolerance": 0.01, "kinetics": "table",
         "samples": 8},
    ),
    "output-adx16": (
        {"seed": 8, "width_mm": FAST_WIDTH_MM, "output": "adx16"},
        {"seed": 8, "width_mm": FAST_WIDTH_MM, "output": "adx16"},
    ),
    "output-adx16-timed": (
        {"seed": 8, "width_mm": FAST_WIDTH_MM, "output": "adx16", "timing": "grey"},
        {"seed": 8, "width_mm": FAST_WIDTH_MM, "output": "adx16", "timing": "grey"},
    ),
    "output-regrain": (
        {"stock": "paper", "seed": 8, "width_mm": FAST_WIDTH_MM, "output": "regrain"},
        {"stock": "paper", "seed": 8, "width_mm": FAST_WIDTH_MM, "output": "regrain"},
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_module_equals_cli(fg_bin, tmp_path, scene_exr, case):
    path, pixels = scene_exr
    cli_mods, kwargs = CASES[case]
    exr, cli_stats = render_cli(fg_bin, tmp_path, path, cli_mods)
    negative = filmgrain.render(pixels, **kwargs)
    assert_same_as_cli(negative, exr, cli_stats)
    # The render did something: a grain pattern, not a constant.
    assert float(negative.density.std()) > 0.0
    assert cli_stats["input"]["file"] == str(path)
    assert negative.stats["input"]["file"] == "<array>"


def test_grey_input_equals_cli(fg_bin, tmp_path):
    grey = scene_pixels(channels=1)
    path = write_image(tmp_path / "grey.exr", grey)
    mods = {"stock": "paper", "seed": 9, "width_mm": FAST_WIDTH_MM}
    exr, cli_stats = render_cli(fg_bin, tmp_path, path, mods)
    for pixels in (grey, grey[:, :, 0]):  # (H, W, 1) and (H, W)
        assert_same_as_cli(filmgrain.render(pixels, **mods), exr, cli_stats)


def test_stock_dict_equals_cli_stock_file(fg_bin, tmp_path, scene_exr):
    path, pixels = scene_exr
    stock = filmgrain.stock("paper")
    assert stock["name"] == "paper"
    stock["name"] = "faster paper"
    stock["exposure_at_grey_lxs"] *= 0.5
    stock_file = tmp_path / "faster.json"
    stock_file.write_text(json.dumps(stock))
    mods = {"seed": 4, "width_mm": FAST_WIDTH_MM}
    exr, cli_stats = render_cli(fg_bin, tmp_path, path, {"stock": stock_file, **mods})
    from_dict = filmgrain.render(pixels, stock=stock, **mods)
    assert_same_as_cli(from_dict, exr, cli_stats)
    assert from_dict.stats["stock"] == "faster paper"
    # A file path (str or os.PathLike) gives the same.
    from_path = filmgrain.render(pixels, stock=stock_file, **mods)
    assert from_path.density.tobytes() == from_dict.density.tobytes()
    # And the change mattered: the unmodified preset renders differently.
    preset = filmgrain.render(pixels, stock="paper", **mods)
    assert preset.density.tobytes() != from_dict.density.tobytes()


def test_partial_stock_dict_takes_the_defaults():
    pixels = scene_pixels(16, 12)
    negative = filmgrain.render(pixels, stock={"name": "one layer"}, width_mm=0.2)
    assert negative.channels == ("Y",)
    assert negative.density.shape == (12, 16, 1)


def test_stocks_lists_the_presets(fg_bin):
    r = run_cli(fg_bin, "--list-stocks")
    assert r.returncode == 0, r.stderr
    names = [line.split()[0] for line in r.stdout.splitlines()
             if line and not line[0].isspace()]
    assert filmgrain.stocks() == names
    assert "(default)" in r.stdout.splitlines()[0]  # the default first, in both
    assert filmgrain.stock()["name"] == names[0]


def test_result_unpacks_and_describes_itself():
    pixels = scene_pixels()
    negative = filmgrain.render(pixels, width_mm=FAST_WIDTH_MM, roi=(8, 4, 20, 10))
    density, stats = negative
    assert density is negative.density and stats is negative.stats
    assert density.shape == (10, 20, 3)
    assert negative.channels == tuple(layer["name"] for layer in stats["layers"])
    assert negative.roi == (8, 4, 20, 10)
    assert negative.scan == (WIDTH, HEIGHT)
    assert stats["roi"] == {"x": 8, "y": 4, "width": 20, "height": 10}
    assert negative.attributes["filmgrain:stock_name"] == stats["stock"]


def test_output_does_not_depend_on_threads():
    pixels = scene_pixels()
    kw = {"seed": 7, "width_mm": FAST_WIDTH_MM}
    one = filmgrain.render(pixels, threads=1, **kw)
    two = filmgrain.render(pixels, threads=2, tile=8, **kw)
    assert one.density.tobytes() == two.density.tobytes()


def test_frames_have_their_own_grain_and_static_keeps_the_seeds():
    pixels = scene_pixels()
    kw = {"seed": 7, "width_mm": FAST_WIDTH_MM}
    single = filmgrain.render(pixels, **kw)
    f1 = filmgrain.render(pixels, frame=1, **kw)
    f2 = filmgrain.render(pixels, frame=2, **kw)
    static = filmgrain.render(pixels, frame=2, static_grain=True, **kw)
    assert f1.density.tobytes() != f2.density.tobytes()
    assert f1.stats["grain_seed"] != f2.stats["grain_seed"]
    assert static.stats["grain_seed"] == single.stats["grain_seed"] == 7
    assert static.density.tobytes() == single.density.tobytes()
    assert (f2.stats["frame"], f2.stats["static_grain"]) == (2, False)
    assert single.stats["frame"] is None


def test_renamed_keywords_still_read_with_a_deprecation_warning():
    pixels = scene_pixels()
    kw = {"seed": 4, "width_mm": FAST_WIDTH_MM, "frame": 2}
    now = filmgrain.render(pixels, exposure_stops=0.5, shutter_s="1/100", static_grain=True,
                           **kw)
    with pytest.warns(DeprecationWarning) as said:
        old = filmgrain.render(pixels, exposure=0.5, shutter="1/100", static=True, **kw)
    texts = sorted(str(w.message) for w in said)
    assert texts == [f"filmgrain: {o}= is now {n}= (the old name is still read)"
                     for o, n in [("exposure", "exposure_stops"), ("shutter", "shutter_s"),
                                  ("static", "static_grain")]]
    assert all(w.filename == __file__ for w in said)  # points at the caller
    assert old.density.tobytes() == now.density.tobytes()
    with pytest.raises(TypeError, match="name the same modifier"):
        filmgrain.render(pixels, exposure=1, exposure_stops=1, **kw)


def test_numbers_reach_the_core_exactly():
    """Floats go through the modifier string by repr: the core receives the
    same double (the stats print it back with 17 digits)."""
    pixels = scene_pixels(16, 12)
    exposure, shutter, width = 0.1 + 0.2, 1 / 3, 0.123456789012345678
    negative = filmgrain.render(pixels, exposure_stops=exposure, shutter_s=shutter, width_mm=width)
    assert negative.stats["exposure_stops"] == exposure
    assert negative.stats["shutter_s"] == shutter
    assert negative.stats["width_mm"] == width
    as_f32 = filmgrain.render(pixels, exposure_stops=np.float32(0.1), width_mm=0.2)
    assert as_f32.stats["exposure_stops"] == float(np.float32(0.1))


def test_regrain_to_another_colour_space_equals_cli(fg_bin, tmp_path, scene_exr):
    """ocolorspace= is the CLI's --ocolorspace (output="regrain" only)."""
    path, pixels = scene_exr
    mods = {"seed": 6, "width_mm": FAST_WIDTH_MM, "output": "regrain"}
    out, stats = tmp_path / "acescg.exr", tmp_path / "acescg.json"
    r = run_cli(fg_bin, path, "--iscolorspace", "scene_linear", modifier_text(mods),
                "--ocolorspace", "ACEScg", "-o", out, "--stats", stats, "-q")
    assert r.returncode == 0, r.stderr
    negative = filmgrain.render(pixels, ocolorspace="ACEScg", **mods)
    assert_same_as_cli(negative, Exr(out), read_json(stats))
    assert negative.attributes["filmgrain:colorspace"] == "ACEScg"
    plain = filmgrain.render(pixels, **mods)
    assert plain.density.tobytes() != negative.density.tobytes()
    with pytest.raises(filmgrain.Error, match="applies to output=regrain"):
        filmgrain.render(pixels, width_mm=FAST_WIDTH_MM, ocolorspace="ACEScg")
    with pytest.raises(filmgrain.Error, match="nonesuch"):
        filmgrain.render(pixels, ocolorspace="nonesuch", **mods)
