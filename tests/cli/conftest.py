"""Helpers for the filmgrain CLI tests.

Run by ctest with Debian's /usr/bin/python3 (it can import OpenImageIO);
FILMGRAIN_BIN is the path of the built CLI (tests/cli/CMakeLists.txt).
Every render uses a tiny image and a small frame (width_mm) so that it takes
well under a second.
"""

import json
import os
import subprocess

import numpy as np
import OpenImageIO as oiio
import pytest

# A tiny, fast render: 32x24 pixels over a 0.5 mm frame.
WIDTH, HEIGHT = 32, 24
FAST = "width_mm=0.5"


@pytest.fixture(scope="session")
def fg_bin():
    path = os.environ.get("FILMGRAIN_BIN")
    if not path:
        pytest.fail("FILMGRAIN_BIN is not set (run through ctest)")
    assert os.access(path, os.X_OK), path
    return path


def clean_env(**extra):
    """The environment without $OCIO (tests choose their config)."""
    env = {k: v for k, v in os.environ.items() if k != "OCIO"}
    env.update(extra)
    return env


@pytest.fixture
def run(fg_bin):
    """run(*args, env=None, cwd=None) -> CompletedProcess (text)."""

    def _run(*args, env=None, cwd=None, timeout=120):
        return subprocess.run(
            [fg_bin, *[str(a) for a in args]],
            capture_output=True,
            text=True,
            env=env if env is not None else clean_env(),
            cwd=cwd,
            timeout=timeout,
        )

    return _run


@pytest.fixture
def dirs(tmp_path):
    """An empty input and an empty output directory: (in, out)."""
    indir, outdir = tmp_path / "in", tmp_path / "out"
    indir.mkdir()
    outdir.mkdir()
    return indir, outdir


def write_image(path, pixels, fmt="float", attrs=None):
    """Writes a (height, width, channels) array with OpenImageIO."""
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    h, w, c = pixels.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    for k, v in (attrs or {}).items():
        spec.attribute(k, v)
    out = oiio.ImageOutput.create(str(path))
    assert out, oiio.geterror()
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()
    return path


def rgb_ramp(width=WIDTH, height=HEIGHT):
    """A scene-linear RGB ramp, 0.01 .. ~1, different in each channel."""
    x = np.linspace(0.01, 1.0, width, dtype=np.float32)
    y = np.linspace(0.2, 1.0, height, dtype=np.float32)
    img = np.empty((height, width, 3), np.float32)
    img[:, :, 0] = x[None, :]
    img[:, :, 1] = y[:, None] * 0.5
    img[:, :, 2] = 0.18
    return img


class Exr:
    """An EXR read back: spec and channels by name (EXR sorts them)."""

    def __init__(self, path):
        buf = oiio.ImageBuf(str(path))
        assert not buf.has_error, buf.geterror()
        self.spec = buf.spec()
        pixels = buf.get_pixels(oiio.FLOAT)
        assert pixels is not None, buf.geterror()
        self.names = list(self.spec.channelnames)
        self.channels = {n: pixels[:, :, i] for i, n in enumerate(self.names)}

    def attr(self, name):
        return self.spec.getattribute(name)


def read_json(path):
    with open(path) as f:
        return json.load(f)


def listing(directory):
    return sorted(os.listdir(directory))


def assert_nothing_written(directory, expected=()):
    """Only `expected` (the test's inputs) is in `directory`: no output, no
    stats/preview, no temporary file."""
    assert listing(directory) == sorted(expected)


def minimal_ocio_config(linear_name="linear"):
    """A minimal valid OCIO v2 config: one scene-linear space and raw data
    (no sRGB)."""
    return f"""ocio_profile_version: 2
roles:
  default: {linear_name}
  scene_linear: {linear_name}
  data: raw
file_rules:
  - !<Rule> {{name: Default, colorspace: default}}
displays:
  None:
    - !<View> {{name: Raw, colorspace: raw}}
colorspaces:
  - !<ColorSpace>
    name: {linear_name}
    isdata: false
  - !<ColorSpace>
    name: raw
    isdata: true
"""
