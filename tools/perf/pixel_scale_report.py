#!/usr/bin/python3
"""The pixel scale (scale=pixel) against the per-grain kernel, with CIs.

    /usr/bin/python3 tools/perf/pixel_scale_report.py --bin build/plugin/filmgrain \\
        --out docs/performance [--stock tools/perf/stocks/real-scale.json] [--seeds 8] \\
        [--width-mm MM] [--scale pixel|mixed|auto]

Renders the built-in step wedge (1008x96 on 6.3 mm: 6.25 um pixels, or
--width-mm) with
`scale=pixel` (or `scale=mixed`: the pixel scale only where a pixel's
exposure develops enough grains; or auto: no scale given, each layer as
the planner takes it) and with the per-grain kernel (`scale=grain:kinetics=curve`,
what auto runs otherwise) for each seed, and compares them step by step
(the step minus a 6-pixel margin) in distribution; the two renders share no
grains, so every comparison is unpaired and its 95% CI comes from the
spread over seeds (t quantile, seeds - 1 degrees of freedom):

  mean D       mean of the pixel densities, pixel - grain
  sd D         standard deviation of the pixel densities, ratio
  G48          RMS granularity: sd of the density of 8x8-pixel (50 um)
               block-mean transmittances, ratio
  NPS          noise power of the transmittance per octave band of spatial
               frequency (1/8-1/4, 1/4-1/2 and 1/2-1 of Nyquist), from the
               2-D periodogram of each step (rows x columns, mean removed),
               ratio
  quantiles    the 5% and 95% quantiles of the pixel density, difference

Writes pixel_scale.md and pixel_scale.json into --out. Timing is printed,
never asserted.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fgperf  # noqa: E402
from fgstats import t975  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def render(binary, mods, out, work):
    exr = os.path.join(work, out + ".exr")
    stats = os.path.join(work, out + ".json")
    t0 = time.time()
    r = subprocess.run([binary, "--wedge", f"--filmgrain:{mods}", "-o", exr, "--stats", stats,
                        "-q"], capture_output=True, text=True)
    if r.returncode:
        sys.exit(f"{binary} {mods} failed: {r.stderr}")
    d, names, _ = fgperf.read_exr(exr)
    with open(stats) as f:
        st = json.load(f)
    return d.astype(np.float64), names, st, time.time() - t0


def step_metrics(D, base):
    """Metrics of one step's patch (pixels x pixels of density)."""
    T = 10.0 ** -(D - base)
    h, w = D.shape
    bh, bw = h // 8, w // 8
    Tb = T[:bh * 8, :bw * 8].reshape(bh, 8, bw, 8).mean(axis=(1, 3))
    bands = fgperf.nps_octave_bands(T)
    q05, q95 = np.quantile(D, [0.05, 0.95])
    return {"mean": D.mean(), "sd": D.std(), "g48": (-np.log10(Tb)).std(), "nps": bands,
            "q05": q05, "q95": q95}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--stock", default=os.path.join(HERE, "stocks", "real-scale.json"))
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--width-mm", type=float, default=None,
                    help="strip width (default: the wedge's 6.3 mm, 6.25 um pixels)")
    ap.add_argument("--name", default="pixel_scale", help="output file names (NAME.md, NAME.json)")
    ap.add_argument("--scale", choices=("pixel", "mixed", "auto"), default="pixel",
                    help="the scale= of the renders held against the kernel (auto: none "
                         "given; default: pixel)")
    ap.add_argument("--work", default=None)
    args = ap.parse_args()
    work = args.work or os.path.join(os.environ.get("TMPDIR", "/tmp"), "filmgrain-pixel-scale")
    os.makedirs(work, exist_ok=True)
    os.makedirs(args.out, exist_ok=True)
    stock = json.loads(subprocess.run([args.bin, "--print-stock", args.stock], check=True,
                                      capture_output=True, text=True).stdout)
    base = stock["base_density"]
    configs = {"pixel": [] if args.scale == "auto" else [f"scale={args.scale}"],
               "grain": ["scale=grain", "kinetics=curve"]}
    if args.width_mm:
        configs = {c: m + [f"width_mm={args.width_mm}"] for c, m in configs.items()}
    per = {c: [] for c in configs}
    times = {c: [] for c in configs}
    paths = {}
    for seed in range(1, args.seeds + 1):
        for c, m in configs.items():
            d, names, st, secs = render(args.bin, ":".join([f"stock={args.stock}"] + m
                                                           + [f"seed={seed}"]),
                                        f"{c}_{seed}", work)
            times[c].append(secs)
            paths[c] = [layer["path"] for layer in st["layers"]]
            h, w, nl = d.shape
            sw = w // 21
            per[c].append([[step_metrics(d[6:-6, i * sw + 6:(i + 1) * sw - 6, l], base)
                            for i in range(21)] for l in range(nl)])
            print(f"seed {seed} {c}: {secs:.2f} s", flush=True)
    nl = len(per["pixel"][0])
    n = args.seeds
    rows = []
    for l in range(nl):
        for i in range(21):
            def series(key, c, j=None):
                return np.array([(s[l][i][key] if j is None else s[l][i][key][j])
                                 for s in per[c]])

            def diff(key):
                a, b = series(key, "pixel"), series(key, "grain")
                dd = a - b
                return dd.mean(), t975(n - 1) * math.sqrt((a.var(ddof=1) + b.var(ddof=1)) / n)

            def ratio(key, j=None):
                a, b = series(key, "pixel", j), series(key, "grain", j)
                la, lb = np.log(a), np.log(b)
                r = math.exp(la.mean() - lb.mean())
                half = t975(n - 1) * math.sqrt((la.var(ddof=1) + lb.var(ddof=1)) / n)
                return r, math.exp(-half) * r, math.exp(half) * r

            row = {"layer": names[l] if l < len(names) else str(l), "step": i,
                   "D_grain": series("mean", "grain").mean()}
            row["dD"], row["dD_ci"] = diff("mean")
            row["sd_ratio"] = ratio("sd")
            row["g48_ratio"] = ratio("g48")
            row["nps_ratio"] = [ratio("nps", j) for j in range(3)]
            row["dq05"], row["dq05_ci"] = diff("q05")
            row["dq95"], row["dq95_ci"] = diff("q95")
            rows.append(row)
    summary = {"stock": args.stock, "seeds": n, "paths": paths,
               "seconds": {c: float(np.median(t)) for c, t in times.items()}, "steps": rows}
    with open(os.path.join(args.out, args.name + ".json"), "w") as f:
        json.dump(summary, f, indent=1)
    def path_text(c):
        return "; ".join(f"`{p}`" for p in dict.fromkeys(paths[c]))

    L = ["# Pixel scale against the per-grain kernel", "",
         f"Generated by `tools/perf/pixel_scale_report.py --stock {os.path.relpath(args.stock)} "
         f"--seeds {n}" + (f" --width-mm {args.width_mm}" if args.width_mm else "")
         + (f" --scale {args.scale}" if args.scale != "pixel" else "")
         + f"` (the docstring defines every column). The built-in wedge ("
         + (f"{args.width_mm} mm strip, {args.width_mm * 1000 / 1008:.2f} um" if args.width_mm
            else "6.25 um") + f" pixels), {n} seeds each; {args.scale}: {path_text('pixel')}, "
         f"{summary['seconds']['pixel']:.2f} s a render; grain: {path_text('grain')}, "
         f"{summary['seconds']['grain']:.2f} s (median wall, whole CLI run). "
         "Unpaired: 95% CIs from the spread over seeds. One table per layer."]
    for r in rows:
        if r["step"] == 0:
            L += ["", f"## Layer {r['layer']}", "",
                  "| step | D (grain) | mean D diff (CI) | sd D ratio (CI) | G48 ratio (CI) | NPS ratio 1/8-1/4, 1/4-1/2, 1/2-1 Nyquist | 5% quantile diff | 95% quantile diff |",
                  "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        nps = ", ".join(f"{v[0]:.3f}" for v in r["nps_ratio"])
        L.append(f"| {r['step']} | {r['D_grain']:.3f} | {r['dD']:+.4f} +- {r['dD_ci']:.4f} | "
                 f"{r['sd_ratio'][0]:.3f} ({r['sd_ratio'][1]:.3f}-{r['sd_ratio'][2]:.3f}) | "
                 f"{r['g48_ratio'][0]:.3f} ({r['g48_ratio'][1]:.3f}-{r['g48_ratio'][2]:.3f}) | "
                 f"{nps} | {r['dq05']:+.4f} +- {r['dq05_ci']:.4f} | "
                 f"{r['dq95']:+.4f} +- {r['dq95_ci']:.4f} |")
    with open(os.path.join(args.out, args.name + ".md"), "w") as f:
        f.write("\n".join(L) + "\n")
    print("\n".join(L))


if __name__ == "__main__":
    main()
