"""Helpers for the filmgrain CLI tests.

Run by ctest with Debian's /usr/bin/python3 (it can import OpenImageIO);
FILMGRAIN_BIN is the path of the built CLI (tests/cli/CMakeLists.txt).
Every render uses a tiny image and a small frame (width_mm) so that it takes
well under a second.
"""

import os
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# The helpers every suite shares (tests/fgtest.py); the tests import them
# from here.
from fgtest import Exr, clean_env, fg_bin, read_json, write_image  # noqa: E402,F401

# A tiny, fast render: 32x24 pixels over a 0.5 mm frame.
WIDTH, HEIGHT = 32, 24
FAST = "width_mm=0.5"


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


def rgb_ramp(width=WIDTH, height=HEIGHT):
    """A scene-linear RGB ramp, 0.01 .. ~1, different in each channel."""
    x = np.linspace(0.01, 1.0, width, dtype=np.float32)
    y = np.linspace(0.2, 1.0, height, dtype=np.float32)
    img = np.empty((height, width, 3), np.float32)
    img[:, :, 0] = x[None, :]
    img[:, :, 1] = y[:, None] * 0.5
    img[:, :, 2] = 0.18
    return img



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
