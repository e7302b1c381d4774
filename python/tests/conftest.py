"""Helpers for the tests of the filmgrain Python module.

Run by ctest (python/CMakeLists.txt) with Debian's /usr/bin/python3 (it
imports OpenImageIO), PYTHONPATH = the build's python/ directory (the
assembled package) and FILMGRAIN_BIN = the built CLI, which every result
is compared with. Scenes are tiny (64x48 pixels over a 0.5 mm frame) so that
each render takes a fraction of a second.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import filmgrain

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))), "tests"))
# The helpers every suite shares (tests/fgtest.py); the tests import them
# from here.
from fgtest import Exr, clean_env, cli_error, fg_bin, read_json, write_image  # noqa: E402,F401

WIDTH, HEIGHT = 64, 48
FAST_WIDTH_MM = 0.5

# Attributes the CLI adds to the operator's filmgrain:* metadata: the hash of
# a sequence frame's settings, with which `--frames` resumes a stopped
# sequence (a CLI matter: the module renders arrays, not files).
CLI_ONLY_ATTRIBUTES = ("filmgrain:settings_hash",)

# Fields of the --stats document that measure time: they differ between two
# runs of the same render.
TIMING_FIELDS = ("seconds",)
LAYER_TIMING_FIELDS = ("setup_seconds",)


def run_cli(fg_bin, *args, timeout=120):
    return subprocess.run([fg_bin, *[str(a) for a in args]], capture_output=True, text=True,
                          env=clean_env(), timeout=timeout)


def scene_pixels(width=WIDTH, height=HEIGHT, channels=3):
    """A scene-linear image with structure in x, y and colour (0.004 .. ~2)."""
    x = np.linspace(0.0, 1.0, width, dtype=np.float64)[None, :]
    y = np.linspace(0.0, 1.0, height, dtype=np.float64)[:, None]
    planes = [0.004 * 500.0 ** x + 0 * y, 0.18 + 0.5 * y * x, 0.05 + 1.5 * (1 - y) ** 2 + 0 * x]
    img = np.stack(planes[:channels] if channels > 1 else [planes[1]], axis=-1)
    return np.ascontiguousarray(img.astype(np.float32))


def without_timing(stats):
    """The --stats document without its timings and input file name (the
    module renders an array: "<array>")."""
    s = json.loads(json.dumps(stats))
    for key in TIMING_FIELDS:
        assert key in s, key
        del s[key]
    for layer in s["layers"]:
        for key in LAYER_TIMING_FIELDS:
            assert key in layer, key
            del layer[key]
    assert s["input"]["file"] in ("<array>",) or s["input"]["file"].endswith(".exr")
    del s["input"]["file"]
    return s


def modifier_text(modifiers):
    """The CLI's --filmgrain word for a dict of modifiers (values as written)."""
    return ":".join(["--filmgrain"] + [f"{k}={v}" for k, v in modifiers.items()])


def render_cli(fg_bin, tmp_path, input_path, modifiers, name="cli"):
    """Runs the CLI on a scene-linear input; returns (Exr, stats dict).
    --iscolorspace scene_linear: the module takes scene-linear pixels (OIIO
    labels a float EXR "Linear", which the CLI would convert, as a no-op,
    and name in the stats)."""
    out, stats = tmp_path / f"{name}.exr", tmp_path / f"{name}.json"
    r = run_cli(fg_bin, input_path, "--iscolorspace", "scene_linear", modifier_text(modifiers),
                "-o", out, "--stats", stats, "-q")
    assert r.returncode == 0, r.stderr
    return Exr(out), read_json(stats)


def assert_same_as_cli(negative, exr, cli_stats):
    """Pixels bit-identical, layer names, windows and statistics equal."""
    if cli_stats["output"] == "density":  # else output='s channels: R, G, B
        assert list(negative.channels) == [layer["name"] for layer in cli_stats["layers"]]
    assert negative.stats["output"] == cli_stats["output"]
    assert sorted(negative.channels) == sorted(exr.names)
    cli = exr.layers(negative.channels)
    assert negative.density.dtype == np.float32
    assert negative.density.shape == cli.shape
    assert negative.density.tobytes() == cli.tobytes()
    spec = exr.spec
    assert negative.roi == (spec.x, spec.y, spec.width, spec.height)
    assert negative.scan == (spec.full_width, spec.full_height)
    assert without_timing(negative.stats) == without_timing(cli_stats)
    cli_attributes = exr.attributes()
    for name in CLI_ONLY_ATTRIBUTES:
        cli_attributes.pop(name, None)
    assert negative.attributes == cli_attributes
    assert "filmgrain:stock" in negative.attributes


@pytest.fixture
def scene_exr(tmp_path):
    """(path, pixels) of the 64x48 RGB scene written as a float EXR."""
    pixels = scene_pixels()
    return write_image(tmp_path / "scene.exr", pixels), pixels


__all__ = ["filmgrain"]
