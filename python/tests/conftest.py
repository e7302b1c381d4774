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

import numpy as np
import OpenImageIO as oiio
import pytest

import filmgrain

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


@pytest.fixture(scope="session")
def fg_bin():
    path = os.environ.get("FILMGRAIN_BIN")
    if not path:
        pytest.fail("FILMGRAIN_BIN is not set (run through ctest)")
    assert os.access(path, os.X_OK), path
    return path


def clean_env():
    """The environment without $OCIO: the CLI uses its embedded config."""
    return {k: v for k, v in os.environ.items() if k != "OCIO"}


def run_cli(fg_bin, *args, timeout=120):
    return subprocess.run([fg_bin, *[str(a) for a in args]], capture_output=True, text=True,
                          env=clean_env(), timeout=timeout)


def cli_error(result):
    """The CLI's message: its last stderr line without "filmgrain: error: "."""
    assert result.returncode != 0, result.stderr
    line = result.stderr.strip().splitlines()[-1]
    prefix = "filmgrain: error: "
    assert line.startswith(prefix), result.stderr
    return line[len(prefix):]


def scene_pixels(width=WIDTH, height=HEIGHT, channels=3):
    """A scene-linear image with structure in x, y and colour (0.004 .. ~2)."""
    x = np.linspace(0.0, 1.0, width, dtype=np.float64)[None, :]
    y = np.linspace(0.0, 1.0, height, dtype=np.float64)[:, None]
    planes = [0.004 * 500.0 ** x + 0 * y, 0.18 + 0.5 * y * x, 0.05 + 1.5 * (1 - y) ** 2 + 0 * x]
    img = np.stack(planes[:channels] if channels > 1 else [planes[1]], axis=-1)
    return np.ascontiguousarray(img.astype(np.float32))


def write_exr(path, pixels, window=None):
    """Writes (h, w, c) float32 pixels as a float EXR; window = (x, y,
    full_x, full_y, full_width, full_height) sets data and display windows."""
    h, w, c = pixels.shape
    spec = oiio.ImageSpec(w, h, c, oiio.FLOAT)
    if window:
        spec.x, spec.y, spec.full_x, spec.full_y, spec.full_width, spec.full_height = window
    out = oiio.ImageOutput.create(str(path))
    assert out, oiio.geterror()
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()
    return path


class Exr:
    """An EXR read back: spec, channels by name (EXR sorts them by name)."""

    def __init__(self, path):
        buf = oiio.ImageBuf(str(path))
        assert not buf.has_error, buf.geterror()
        self.spec = buf.spec()
        pixels = buf.get_pixels(oiio.FLOAT)
        assert pixels is not None, buf.geterror()
        self.names = list(self.spec.channelnames)
        self.channels = {n: np.ascontiguousarray(pixels[:, :, i])
                         for i, n in enumerate(self.names)}

    def layers(self, names):
        """(h, w, len(names)) float32 in the order of `names`."""
        return np.ascontiguousarray(np.stack([self.channels[n] for n in names], axis=-1))

    def attributes(self):
        return {p.name: p.value for p in self.spec.extra_attribs
                if p.name.startswith("filmgrain:")}


def read_json(path):
    with open(path) as f:
        return json.load(f)


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
    return write_exr(tmp_path / "scene.exr", pixels), pixels


__all__ = ["filmgrain"]
