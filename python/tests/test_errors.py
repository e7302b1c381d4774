"""Bad arguments raise Python exceptions carrying the core's (the CLI's)
message; nothing is rendered."""

import json

import numpy as np
import pytest

import filmgrain
from conftest import FAST_WIDTH_MM, cli_error, modifier_text, run_cli, scene_pixels

PIXELS = scene_pixels(16, 12)


def cli_message(fg_bin, tmp_path, modifiers, pixels=PIXELS):
    """The CLI's error message for these modifiers on `pixels`."""
    from conftest import write_image

    path = write_image(tmp_path / "in.exr", pixels)
    r = run_cli(fg_bin, path, "--iscolorspace", "scene_linear", modifier_text(modifiers),
                "-o", tmp_path / "out.exr")
    return cli_error(r)


def module_message(**kwargs):
    pixels = kwargs.pop("pixels", PIXELS)
    with pytest.raises(filmgrain.Error) as info:
        filmgrain.render(pixels, **kwargs)
    assert isinstance(info.value, ValueError)
    return str(info.value)


# Modifier errors: the CLI's parser prefixes its option's name ("--filmgrain:
# "), the module its own ("filmgrain.render: "); the rest is the same text.
@pytest.mark.parametrize("cli_mods, kwargs", [
    ({"exposure_stops": 100}, {"exposure_stops": 100}),
    ({"exposure_stops": "nan"}, {"exposure_stops": float("nan")}),
    ({"seed": "1.5"}, {"seed": 1.5}),
    ({"seed": "-1"}, {"seed": -1}),
    ({"frame": "2000000000"}, {"frame": 2 * 10**9}),
    ({"tolerance": "0.0"}, {"tolerance": 0.0}),
    ({"engine": "bogus"}, {"engine": "bogus"}),
    ({"scan": "0x10"}, {"scan": (0, 10)}),
    ({"roi": "1,2,3"}, {"roi": (1, 2, 3)}),
    ({"shutter_s": "1/0"}, {"shutter_s": "1/0"}),
    ({"static_grain": "2"}, {"static_grain": 2}),
    ({"kinetics": "fastest"}, {"kinetics": "fastest"}),
    ({"colour": "red"}, {"colour": "red"}),
])
def test_modifier_errors_carry_the_cli_parsers_message(fg_bin, tmp_path, cli_mods, kwargs):
    cli = cli_message(fg_bin, tmp_path, cli_mods)
    mod = module_message(**kwargs)
    assert cli.startswith("--filmgrain: "), cli
    assert mod.startswith("filmgrain.render: "), mod
    assert mod[len("filmgrain.render: "):] == cli[len("--filmgrain: "):]


@pytest.mark.parametrize("cli_mods, kwargs", [
    ({"stock": "no-such-stock"}, {"stock": "no-such-stock"}),
    ({"roi": "60,0,10,10", "width_mm": FAST_WIDTH_MM}, {"roi": (60, 0, 10, 10),
                                                         "width_mm": FAST_WIDTH_MM}),
    ({"engine": "exact", "kinetics": "table"}, {"engine": "exact", "kinetics": "table"}),
])
def test_core_errors_are_the_clis(fg_bin, tmp_path, cli_mods, kwargs):
    assert module_message(**kwargs) == cli_message(fg_bin, tmp_path, cli_mods)


def test_two_channels_is_the_operators_error(fg_bin, tmp_path):
    two = np.ascontiguousarray(PIXELS[:, :, :2])
    mod = module_message(pixels=two)
    assert mod == "source image has 2 channels: expected 1 (grey) or at least 3 (R, G, B first)"
    # The CLI takes its INPUT's channels by name: it says which it lacks
    # and what the file has.
    assert cli_message(fg_bin, tmp_path, {}, pixels=two).endswith(
        "has no channels R, G, B or Y (part 0 has R,G): choose them with --ch, --subimage "
        "or --view")


def test_bad_stock_dict_names_the_key():
    stock = filmgrain.stock("paper")
    stock["layers"][0]["populations"][0]["diameter_um"] = -1.0
    msg = module_message(stock=stock)
    assert "stock dict" in msg and "layers[0].populations[0].diameter_um" in msg, msg
    assert "-1" in msg
    msg = module_message(stock={"name": "x", "colour": 1})
    assert "colour" in msg, msg


def test_bad_stock_file_is_the_cores_message(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text("{ not json")
    with pytest.raises(filmgrain.Error, match="broken.json"):
        filmgrain.stock(path)
    with pytest.raises(filmgrain.Error, match="broken.json"):
        filmgrain.render(PIXELS, stock=str(path))


@pytest.mark.parametrize("pixels, exc, text", [
    (PIXELS.astype(np.float64), TypeError, "dtype float64"),
    (PIXELS.astype(np.float16), TypeError, "dtype float16"),
    ((PIXELS * 255).astype(np.uint8), TypeError, "dtype uint8"),
    (PIXELS.tolist(), TypeError, "numpy.ndarray"),
    (PIXELS[None], ValueError, "shape (1, 12, 16, 3)"),
    (PIXELS[0, 0], ValueError, "shape (3,)"),
    (PIXELS[:0], filmgrain.Error, "at least one pixel"),
])
def test_bad_pixels_raise_naming_what_is_wrong(pixels, exc, text):
    with pytest.raises(exc) as info:
        filmgrain.render(pixels)
    assert text in str(info.value)


def test_non_contiguous_pixels_are_copied_not_refused():
    wide = np.ascontiguousarray(np.concatenate([PIXELS, PIXELS], axis=1))
    view = wide[:, ::2]  # every other column: strided
    assert not view.flags.c_contiguous
    kw = {"seed": 2, "width_mm": 0.2}
    assert (filmgrain.render(view, **kw).density.tobytes()
            == filmgrain.render(np.ascontiguousarray(view), **kw).density.tobytes())


@pytest.mark.parametrize("kwargs, exc, text", [
    ({"exposure_stops": True}, TypeError, "exposure_stops=True"),
    ({"exposure_stops": [1.0]}, TypeError, "exposure_stops=[1.0]"),
    ({"roi": (0, 0, 4.0, 4)}, TypeError, "roi="),
    ({"engine": "exact:seed=3"}, ValueError, "cannot contain ':'"),
    ({"stock": 3}, TypeError, "stock=3"),
    ({"stock": {"name": float("nan")}}, TypeError, "stock dict"),
    ({"threads": 1.5}, TypeError, "threads=1.5"),
    ({"threads": -1}, filmgrain.Error,
     "threads = -1: expected a whole number of threads in [0, 4096]"),
    ({"threads": 5000}, filmgrain.Error, "threads = 5000"),
    ({"progress": 3}, TypeError, "progress=3"),
])
def test_bad_python_values(kwargs, exc, text):
    with pytest.raises(exc) as info:
        filmgrain.render(PIXELS, **kwargs)
    assert text in str(info.value)


def test_error_is_exported_as_filmgrain_error():
    assert issubclass(filmgrain.Error, ValueError)
    assert filmgrain.Error.__module__ == "filmgrain"
    assert json.loads(json.dumps(filmgrain.stocks()))  # plain strings
