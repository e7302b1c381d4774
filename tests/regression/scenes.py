"""The regression scenes, shared by test_regression.py and update_refs.py.

Each scene is rendered by the filmgrain CLI with a stock file kept here in
stocks/ (never a preset: presets are still being calibrated) into a small
half-float, zip-compressed EXR, and compared with ref/<scene>.exr.
Inputs are generated here (exact float32 formulas), not stored.
"""

import os
import subprocess

import numpy as np
import OpenImageIO as oiio

HERE = os.path.dirname(os.path.abspath(__file__))
STOCKS = os.path.join(HERE, "stocks")
REF = os.path.join(HERE, "ref")


def gradient(width, height):
    """Scene-linear RGB: R ramps across (1/64 .. 1), G ramps down, B is a
    slow diagonal; every value exactly representable in float32."""
    x = (np.arange(width, dtype=np.float32) + 1) / np.float32(width)
    y = (np.arange(height, dtype=np.float32) + 1) / np.float32(height)
    img = np.empty((height, width, 3), np.float32)
    img[:, :, 0] = x[None, :]
    img[:, :, 1] = y[::-1, None] * np.float32(0.5)
    img[:, :, 2] = (x[None, :] + y[:, None]) * np.float32(0.25)
    return img


def wedge_args(options):
    """The arguments of a wedge scene: the README's main job (--wedge) with
    the one-layer stock, scanned small (1008x96 input over a 2 mm frame
    scanned at 168x16: 11.9 um pixels), seed 1; `options` end the
    --filmgrain option string."""
    return ["--wedge", "--filmgrain:stock={stocks}/one_layer.json"
            ":width_mm=2:scan=168x16:seed=1:" + options]


def three_layer_args(options):
    """The arguments of a gradient scene: the three-layer stock (one layer
    with two populations) over a 1 mm frame, seed 2; `options` end the
    --filmgrain option string."""
    return ["--filmgrain:stock={stocks}/three_layer.json:width_mm=1:seed=2:" + options]


SCENES = {
    # The README's main job with a one-layer stock (wedge_args).
    "wedge_one_layer": {
        "input": None,
        "args": wedge_args("engine=exact:edge=gate"),
    },
    # A 40x30 RGB gradient through three layers (three_layer_args).
    "gradient_three_layer": {
        "input": (40, 30),
        "args": three_layer_args("engine=exact:edge=gate"),
    },
    # A scan of another size than the input: 32x24 in, 48x36 out (ratio 1.5,
    # so scan pixels straddle input pixels).
    "scan_resample": {
        "input": (32, 24),
        "args": ["--filmgrain:stock={stocks}/one_layer.json:width_mm=1:scan=48:seed=3"
                 ":engine=exact:edge=gate"],
    },
    # The default engine (auto: on frames this small the early-stopped
    # chain, exact coverage) and the fast one with its table forced
    # (tabulated kinetics, centre exposure, raster coverage; until 0.2 it
    # was scanline coverage, hence the reference's change then), and the
    # fast per-grain kernel (kinetics=curve) on the same scenes: all are
    # deterministic too (tables' Monte Carlo streams are seeded).
    "wedge_one_layer_auto": {
        "input": None,
        "args": wedge_args("engine=auto:edge=gate"),
    },
    "gradient_three_layer_kernel": {
        "input": (40, 30),
        "args": three_layer_args("engine=fast:kinetics=curve:edge=gate"),
    },
    "gradient_three_layer_fast": {
        "input": (40, 30),
        "args": three_layer_args("engine=fast:kinetics=table:edge=gate"),
    },
    # The scenes above keep edge=gate (no light beyond the frame, the rule
    # before MODEL.md 2 continued the scene): their references are those
    # of that rule. The same two main scenes with the scene continued
    # (edge=clamp, the default), references made with it.
    "wedge_one_layer_clamp": {
        "input": None,
        "args": wedge_args("engine=exact"),
    },
    "gradient_three_layer_clamp": {
        "input": (40, 30),
        "args": three_layer_args("engine=exact"),
    },
}


def render(fg_bin, scene, workdir, output):
    """Renders `scene` to `output` (half float, zip). Returns the
    CompletedProcess."""
    spec = SCENES[scene]
    args = [a.format(stocks=STOCKS) for a in spec["args"]]
    if spec["input"]:
        w, h = spec["input"]
        src = os.path.join(workdir, scene + "_input.exr")
        buf = oiio.ImageBuf(oiio.ImageSpec(w, h, 3, oiio.FLOAT))
        buf.set_pixels(oiio.ROI(), gradient(w, h))
        assert buf.write(src), buf.geterror()
        args = [src] + args
    env = {k: v for k, v in os.environ.items() if k != "OCIO"}  # embedded config
    return subprocess.run([fg_bin, *args, "-d", "half", "-o:compression=zip", output, "-q"],
                          capture_output=True, text=True, env=env, timeout=300)
