#!/usr/bin/python3
"""The pictures of docs/look (README, "Halation, scatter and inhibitors").

Renders the built-in look chart (filmgrain --chart) with `vision3-500t`
(fitted to VISION3 500T's datasheet; its residual halation behind rem-jet,
scatter, inhibitors and dye clouds, MODEL.md 8-10) and with `no-remjet`
(the same film without rem-jet: strong halation), then writes
  docs/look/chart_<stock>.png   the whole chart, as --preview shows it
  docs/look/halation.png        the point lights, both stocks side by side
  docs/look/edge_profile.png    the density across the grey rectangle's
                                left edge: no-remjet with and without its
                                inhibition (the adjacency effect)
  docs/look/dye_vs_silver.png   the grey rectangle, 2x: the paper-scale
                                `color-negative`'s silver grains beside the
                                same grains as gaussian dye clouds that block
                                as much light on a uniform patch (the same
                                density; at VISION3's sub-micron scale no
                                single grain or cloud is visible in a
                                6.25 um pixel)
and prints each render's time. Usage (from the repository root, after
scripts/build):  tools/look/look_pictures.py [--filmgrain build/plugin/filmgrain]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import OpenImageIO as oiio
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

# The chart's layout (core/include/filmgrain/chart.h defaults): 6.25 um
# pixels, a point light at (256, 256), the grey rectangle from x = 576.
PITCH_UM = 6.25
POINT = (256, 256)
RECT_X0, RECT_Y0, RECT_Y1 = 576, 192, 576


def render(filmgrain, stock, out_dir, name, preview=True):
    exr = os.path.join(out_dir, name + ".exr")
    cmd = [filmgrain, "--chart", "--filmgrain:stock=" + stock, "-o", exr, "-q"]
    if preview:
        cmd += ["--preview", os.path.join(out_dir, name + ".png")]
    t = time.monotonic()
    subprocess.run(cmd, check=True)
    print(f"{name}: {time.monotonic() - t:.1f} s  ({' '.join(cmd)})")
    return oiio.ImageBuf(exr).get_pixels(oiio.FLOAT)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--filmgrain", default="build/plugin/filmgrain")
    ap.add_argument("--out", default="docs/look")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        render(a.filmgrain, "vision3-500t", tmp, "chart_vision3-500t")
        look = render(a.filmgrain, "no-remjet", tmp, "chart_no-remjet")
        stock = json.loads(subprocess.run([a.filmgrain, "--print-stock", "no-remjet"], check=True,
                                          capture_output=True, text=True).stdout)
        stock["inhibition"] = [[0.0] * 3 for _ in range(3)]
        no_inhibition = os.path.join(tmp, "no-remjet-without-inhibition.json")
        with open(no_inhibition, "w") as f:
            json.dump(stock, f)
        uninhibited = render(a.filmgrain, no_inhibition, tmp, "uninhibited", preview=False)
        # color-negative's silver grains, and the same grains as gaussian
        # dye clouds of peak density 1 and 1.177 grain radii, which block as
        # much light on a uniform patch as the grain's opaque disc
        # (cloud_area_factor: (1 - 10^-D) integrated over the cloud).
        plain = render(a.filmgrain, "color-negative", tmp, "chart_color-negative")
        plain_stock = json.loads(subprocess.run(
            [a.filmgrain, "--print-stock", "color-negative"], check=True, capture_output=True,
            text=True).stdout)
        for layer in plain_stock["layers"]:
            layer.update(image="dye", cloud_profile="gaussian", cloud_diameter_ratio=1.177,
                         cloud_density=1.0)
        dye_stock = os.path.join(tmp, "color-negative-dye.json")
        with open(dye_stock, "w") as f:
            json.dump(plain_stock, f)
        dye = render(a.filmgrain, dye_stock, tmp, "chart_dye")
        crops = []
        for name, img in (("chart_color-negative", plain), ("chart_dye", dye)):
            rx, ry = RECT_X0 + 128, RECT_Y0 + 128
            d = img[ry:ry + 128, rx:rx + 128, :]
            print(f"{name}: grey rectangle crop, mean density R G B "
                  + " ".join(f"{d[..., c].mean():.3f}" for c in range(3))
                  + ", mean transmittance " + " ".join(f"{(10.0 ** -d[..., c]).mean():.4f}"
                                                       for c in range(3)))
            png = oiio.ImageBuf(os.path.join(tmp, name + ".png")).get_pixels(oiio.UINT8)
            crops.append(png[ry:ry + 128, rx:rx + 128])
        gap = np.full((128, 8, crops[0].shape[2]), 255, np.uint8)
        both = np.concatenate([crops[0], gap, crops[1]], axis=1)
        both = both.repeat(2, axis=0).repeat(2, axis=1)  # 2x, nearest: grains visible
        out = oiio.ImageBuf(oiio.ImageSpec(both.shape[1], both.shape[0], both.shape[2], oiio.UINT8))
        out.set_pixels(oiio.ROI(), both)
        out.write(os.path.join(a.out, "dye_vs_silver.png"))
        for name in ("chart_vision3-500t", "chart_no-remjet"):
            os.replace(os.path.join(tmp, name + ".png"), os.path.join(a.out, name + ".png"))

    # The point lights, 1:1, side by side.
    crops = []
    x, y = POINT
    for name in ("chart_vision3-500t", "chart_no-remjet"):
        img = oiio.ImageBuf(os.path.join(a.out, name + ".png")).get_pixels(oiio.UINT8)
        crops.append(img[y - 96:y + 352, x - 96:x + 96])
    gap = np.full((crops[0].shape[0], 8, crops[0].shape[2]), 255, np.uint8)
    side = np.concatenate([crops[0], gap, crops[1]], axis=1)
    out = oiio.ImageBuf(oiio.ImageSpec(side.shape[1], side.shape[0], side.shape[2], oiio.UINT8))
    out.set_pixels(oiio.ROI(), side)
    out.write(os.path.join(a.out, "halation.png"))

    # The adjacency effect: mean density of rows inside the rectangle, per
    # column, across its left edge.
    x = (np.arange(RECT_X0 - 48, RECT_X0 + 64) + 0.5 - RECT_X0) * PITCH_UM
    rows = slice(RECT_Y0 + 32, RECT_Y1 - 32)
    cols = slice(RECT_X0 - 48, RECT_X0 + 64)
    fig, ax = plt.subplots(figsize=(7, 3.6), dpi=110)
    for layer, colour in ((0, "tab:red"), (1, "tab:green"), (2, "tab:blue")):
        ax.plot(x, look[rows, cols, layer].mean(axis=0), color=colour,
                label=f"no-remjet, layer {'RGB'[layer]}")
        ax.plot(x, uninhibited[rows, cols, layer].mean(axis=0), color=colour, ls=":",
                label=f"same, inhibition off" if layer == 1 else None)
    ax.axvline(0.0, color="grey", lw=0.8)
    ax.set_xlabel("distance from the edge of the grey rectangle (um on the film)")
    ax.set_ylabel("mean density (rows of the rectangle)")
    ax.set_title("Adjacency effect: inhibitor diffusion 20 um (MODEL.md 10)")
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "edge_profile.png"))
    print("wrote", ", ".join(os.path.join(a.out, f) for f in
                             ("chart_vision3-500t.png", "chart_no-remjet.png", "halation.png",
                              "edge_profile.png", "dye_vs_silver.png")))


if __name__ == "__main__":
    sys.exit(main())
