"""Helpers shared by every pytest suite of filmgrain (tests/cli, python/tests,
python/tests/test_farm.py): the built CLI, its environment, images written
and read back with OpenImageIO, JSON, and child processes watched and
stopped.

Each suite's conftest.py (test_farm.py itself: it runs with --noconftest)
puts this folder on sys.path and imports what it uses from here.
"""

import contextlib
import json
import os
import select
import time

import numpy as np
import OpenImageIO as oiio
import pytest


@pytest.fixture(scope="session")
def fg_bin():
    """The built CLI: $FILMGRAIN_BIN (ctest sets it)."""
    path = os.environ.get("FILMGRAIN_BIN")
    if not path:
        pytest.fail("FILMGRAIN_BIN is not set (run through ctest, or set it)")
    assert os.access(path, os.X_OK), path
    return path


def clean_env(**extra):
    """The environment without $OCIO (tests choose their config; none: the
    CLI's embedded one), plus `extra`."""
    env = {k: v for k, v in os.environ.items() if k != "OCIO"}
    env.update(extra)
    return env


def write_image(path, pixels, fmt="float", attrs=None, window=None):
    """Writes a (height, width, channels) array (2-D: one channel) with
    OpenImageIO. window = (x, y, full_x, full_y, full_width, full_height)
    sets the data and display windows; attrs, extra attributes."""
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    h, w, c = pixels.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    if window:
        spec.x, spec.y, spec.full_x, spec.full_y, spec.full_width, spec.full_height = window
    for k, v in (attrs or {}).items():
        spec.attribute(k, v)
    out = oiio.ImageOutput.create(str(path))
    assert out, oiio.geterror()
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()
    return path


class Exr:
    """An image read back: its spec, and channels by name (an EXR sorts
    them by name) as contiguous float32 planes."""

    def __init__(self, path):
        buf = oiio.ImageBuf(str(path))
        assert not buf.has_error, buf.geterror()
        self.spec = buf.spec()
        pixels = buf.get_pixels(oiio.FLOAT)
        assert pixels is not None, buf.geterror()
        self.names = list(self.spec.channelnames)
        self.channels = {n: np.ascontiguousarray(pixels[:, :, i])
                         for i, n in enumerate(self.names)}

    def attr(self, name):
        return self.spec.getattribute(name)

    def layers(self, names):
        """(h, w, len(names)) float32 in the order of `names`."""
        return np.ascontiguousarray(np.stack([self.channels[n] for n in names], axis=-1))

    def attributes(self):
        """The filmgrain:* attributes, by name."""
        return {p.name: p.value for p in self.spec.extra_attribs
                if p.name.startswith("filmgrain:")}


def read_json(path):
    with open(path) as f:
        return json.load(f)


def cli_error(result):
    """The CLI's message: its last stderr line without "filmgrain: error: "."""
    assert result.returncode != 0, result.stderr
    line = result.stderr.strip().splitlines()[-1]
    prefix = "filmgrain: error: "
    assert line.startswith(prefix), result.stderr
    return line[len(prefix):]


@contextlib.contextmanager
def reaped(proc):
    """Yields the child process `proc`; kills and waits for it on the way
    out if it still runs (a failed test leaves no process behind)."""
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def read_stderr_until(proc, marker, timeout):
    """Reads the child process `proc`'s stderr (a pipe of bytes) until
    `marker` appears in it; returns all read so far. Fails the test if it
    has not appeared within `timeout` seconds or stderr closes first."""
    seen = b""
    deadline = time.monotonic() + timeout
    fd = proc.stderr.fileno()
    while time.monotonic() < deadline:
        # A raw read of what is there (no buffered readline that could
        # block past the deadline).
        ready, _, _ = select.select([fd], [], [], 0.2)
        if ready:
            chunk = os.read(fd, 4096)
            if not chunk:
                break
            seen += chunk
            if marker in seen:
                return seen
    pytest.fail(f"{marker!r} not seen within {timeout} s: {seen!r}")
