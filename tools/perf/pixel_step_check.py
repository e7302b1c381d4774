#!/usr/bin/python3
"""One layer's pixel statistics on chosen steps of the wedge, per engine.

    /usr/bin/python3 tools/perf/pixel_step_check.py --bin build/plugin/filmgrain \\
        [--stock STOCK] --layer 2 --steps 5,7,15 --seeds 4 \\
        --config exact=engine=exact --config grain=scale=grain:kinetics=curve \\
        --config pixel=scale=pixel

Renders, for every step, seed and --config NAME=MODIFIERS, the ROI of the
built-in wedge (1008x96 on 6.3 mm: 6.25 um pixels, 48 pixels a step) that
holds the step less a 6-pixel margin (36x84 pixels), and prints per step
and config, over the seeds: the mean of the pixel densities, the variance
of the pixel transmittances 10^-D and the standard deviation of the pixel
densities, each with the standard error of its mean over the seeds. Small
enough for the exact engine (tens of seconds a render at VISION3's
~150 grains per um^2), so the pixel scale and the per-grain kernel can be
held against the reference where the wedge report (pixel_scale_report.py,
whole wedge, per-grain kernel only) shows a difference. Renders are kept in
--work and reused.
"""

import argparse
import math
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fgperf  # noqa: E402

STEP_PX, MARGIN_PX, ROWS = 48, 6, 96


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--stock", default=None, help="stock name or file (default: the default)")
    ap.add_argument("--layer", type=int, default=0)
    ap.add_argument("--steps", required=True, help="comma-separated wedge steps (0-20)")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--config", action="append", required=True, metavar="NAME=MODIFIERS")
    ap.add_argument("--work", default=os.path.join(os.environ.get("TMPDIR", "/tmp"),
                                                  "filmgrain-pixel-steps"))
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    configs = [c.split("=", 1) for c in args.config]
    print("| step | config | mean D | var T | sd D |")
    print("| --- | --- | --- | --- | --- |")
    for step in (int(s) for s in args.steps.split(",")):
        x0 = step * STEP_PX + MARGIN_PX
        w, h = STEP_PX - 2 * MARGIN_PX, ROWS - 2 * MARGIN_PX
        for name, mods in configs:
            stats = {"mean": [], "var": [], "sd": []}
            for seed in range(1, args.seeds + 1):
                out = os.path.join(args.work, f"{name}_{step}_{seed}.exr")
                if not os.path.exists(out):
                    m = (f"stock={args.stock}:" if args.stock else "") + mods
                    r = subprocess.run([args.bin, "--wedge",
                                        f"--filmgrain:{m}:seed={seed}:roi={x0},{MARGIN_PX},{w},{h}",
                                        "-o", out, "-q"], capture_output=True, text=True)
                    if r.returncode:
                        sys.exit(f"{name} step {step} seed {seed}: {r.stderr}")
                d, _, _ = fgperf.read_exr(out)
                D = d[..., args.layer].astype(np.float64)
                if D.shape != (h, w):  # the whole image back: cut the ROI
                    D = D[MARGIN_PX:MARGIN_PX + h, x0:x0 + w]
                stats["mean"].append(D.mean())
                stats["var"].append((10.0 ** -D).var())
                stats["sd"].append(D.std())

            def cell(key, fmt):
                a = np.array(stats[key])
                se = a.std(ddof=1) / math.sqrt(len(a)) if len(a) > 1 else float("nan")
                return f"{a.mean():{fmt}} +- {se:.1e}"

            print(f"| {step} | {name} | {cell('mean', '.4f')} | {cell('var', '.4e')} | "
                  f"{cell('sd', '.4f')} |", flush=True)


if __name__ == "__main__":
    main()
