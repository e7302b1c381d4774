#!/usr/bin/python3
"""The pictures of docs/look (its README.md, "Halation, scatter, adjacency
and dye clouds").

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
  docs/look/preview_before_after.png
                                the wedge and the chart of the default stock
                                (vision3-500t), three ways (MODEL.md 11,
                                issue 40): the preview before printing
                                density (Status M above D-min as ADX10, no
                                gains: teal), output=adx16 as ACES reads it
                                (5219's Annex C map and ADX's gains, untimed),
                                and the preview now (the same, timed on the
                                stock's grey); each through the config's sRGB
                                / ACES 1.0 SDR view
and prints each render's time, and what keeps the wedge's preview from
neutral (`wedge neutrality`: the preview, the steps' mean transmittance
through the same chain, and the stock's published curves through it). Usage (from the repository root, after
scripts/build):  tools/look/look_pictures.py [--filmgrain build/plugin/filmgrain]
[--only preview_before_after]
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

from published_curves import datasheet, published_cdd  # noqa: E402

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


# The embedded OCIO config's source ($OCIO when set, as the CLI).
CONFIG = os.environ.get("OCIO") or os.path.join(
    os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
    "ocio", "src", "filmgrain_minimal.ocio")
DISPLAY, VIEW = "sRGB", "ACES 1.0 - SDR Video"


def rgb_attr(exr, name):
    """'R a, G b, B c' metadata -> numpy (a, b, c)."""
    parts = dict(p.split() for p in exr.spec().get_string_attribute(name).split(", "))
    return np.array([float(parts[c]) for c in "RGB"])


def adx_view(code, colorspace):
    """ADX code values / max code (h, w, 3) -> 8-bit through the config's view."""
    buf = oiio.ImageBuf(np.ascontiguousarray(code.astype(np.float32)))
    out = oiio.ImageBufAlgo.ociodisplay(buf, DISPLAY, VIEW, colorspace, colorconfig=CONFIG)
    assert not out.has_error, out.geterror()
    return np.round(255.0 * np.clip(out.get_pixels(oiio.FLOAT), 0.0, 1.0)).astype(np.uint8)


def display_of_cdd(cdd):
    """Timed CDD (n, 3) -> the preview's display code values, unrounded
    (ADX16 -> the config's view, x 255)."""
    code = (1520.0 + 8000.0 * np.asarray(cdd, np.float64)) / 65535.0
    buf = oiio.ImageBuf(np.ascontiguousarray(code[None].astype(np.float32)))
    out = oiio.ImageBufAlgo.ociodisplay(buf, DISPLAY, VIEW, "ADX16", colorconfig=CONFIG)
    assert not out.has_error, out.geterror()
    return 255.0 * out.get_pixels(oiio.FLOAT)[0].astype(np.float64)


def wedge_neutrality(filmgrain, stock, spec, m, dmin, k, tmp):
    """What keeps the default wedge's preview from neutral (issue 40's
    target: the steps from -2 to +2 stops within 3 code values between
    channels). Prints, per step, the spread of three previews of it: the
    preview itself (each pixel through the display's curve, then
    averaged); the render's step means through the same timed chain (the
    densitometer's -log10 of the mean transmittance: the grain's part left
    out); and the stock's published curves through the same chain, timed on
    their own grey (what a fit that met its datasheet exactly would give)."""
    exr, png = os.path.join(tmp, "neutral.exr"), os.path.join(tmp, "neutral.png")
    subprocess.run([filmgrain, "--wedge", f"--filmgrain:stock={stock}:output=adx16:timing=grey",
                    "-o", os.path.join(tmp, "neutral_adx.exr"), "-q"], check=True)
    timing = oiio.ImageBuf(os.path.join(tmp, "neutral_adx.exr")).spec().get_string_attribute(
        "filmgrain:adx_timing")
    parts = dict(p.split() for p in timing.split(": ", 1)[1].split(", "))
    offsets = np.array([float(parts[c]) for c in "RGB"])
    subprocess.run([filmgrain, "--wedge", f"--filmgrain:stock={stock}", "-o", exr,
                    "--preview", png, "-q"], check=True)
    e = oiio.ImageBuf(exr)
    names = e.spec().channelnames
    d = e.get_pixels(oiio.FLOAT)[..., [names.index(c) for c in "RGB"]].astype(np.float64)
    preview = oiio.ImageBuf(png).get_pixels(oiio.UINT8).astype(np.float64)
    steps = [(i, -8.0 + 0.75 * i) for i in range(21) if -2.0 <= -8.0 + 0.75 * i <= 2.0]
    mean_d = np.array([-np.log10(np.mean(10.0 ** -d[:, i * 48:(i + 1) * 48].reshape(-1, 3),
                                         axis=0)) for i, _ in steps])
    from_means = display_of_cdd(k * ((mean_d - dmin) @ m.T) + offsets)
    published = None
    sheet = datasheet(stock)
    if sheet is not None and "printing_density" in sheet[1]:
        log_h = np.log10(spec["exposure_at_grey_lxs"]) + np.array(
            [0.0] + [s for _, s in steps]) * np.log10(2.0)
        cdd = published_cdd(sheet[1], log_h, k)
        published = display_of_cdd(cdd[1:] + (0.70 - cdd[0]))
    for j, (i, stops) in enumerate(steps):
        px = np.ptp(preview[:, i * 48:(i + 1) * 48].reshape(-1, 3).mean(axis=0))
        line = (f"wedge neutrality {stops:+.2f} stops: preview {px:.1f}; "
                f"step means through the chain {np.ptp(from_means[j]):.1f}")
        if published is not None:
            line += f"; published curves ({sheet[0]}) {np.ptp(published[j]):.1f}"
        print(line)


def preview_before_after(filmgrain, out_dir, tmp, stock="vision3-500t"):
    """docs/look/preview_before_after.png and the numbers docs/look/README.md
    quotes: per-channel spreads (8-bit) of the wedge's steps and the chart's
    greys, before and after."""
    spec = json.loads(subprocess.run([filmgrain, "--print-stock", stock], check=True,
                                     capture_output=True, text=True).stdout)
    m = np.array(spec["printing_density"]["status_m_to_apd"]["matrix"])
    # D-min (Status M) and ADX's gains as the CLI states them: a tiny
    # output=adx16 render (they depend on the stock and shutter only).
    plate = os.path.join(tmp, "plate.exr")
    oiio.ImageBuf(np.full((4, 4, 3), 0.18, np.float32)).write(plate)
    probe = os.path.join(tmp, "probe.exr")
    subprocess.run([filmgrain, plate, f"--filmgrain:stock={stock}:width_mm=0.1:output=adx16",
                    "-o", probe, "-q"], check=True)
    probe = oiio.ImageBuf(probe)
    dmin, k = rgb_attr(probe, "filmgrain:adx_dmin"), rgb_attr(probe, "filmgrain:adx_gains")
    rows = []
    for scene in ("wedge", "chart"):
        exr, png = os.path.join(tmp, scene + ".exr"), os.path.join(tmp, scene + ".png")
        cmd = [filmgrain, "--" + scene, f"--filmgrain:stock={stock}", "-o", exr,
               "--preview", png, "-q"]
        t = time.monotonic()
        subprocess.run(cmd, check=True)
        print(f"{scene}: {time.monotonic() - t:.1f} s  ({' '.join(cmd)})")
        e = oiio.ImageBuf(exr)
        names = e.spec().channelnames
        d = e.get_pixels(oiio.FLOAT)[..., [names.index(c) for c in "RGB"]].astype(np.float64)
        # Before: each layer's Status M density above its D-min as ADX10
        # (95 + 500 D, rounded), no map, no gains, untimed: the old preview.
        before = adx_view(np.clip(np.round(95.0 + 500.0 * (d - dmin)), 0, 1023) / 1023.0,
                          "ADX10")
        # output=adx16 as a comp reads it: k M (D - D-min), untimed.
        cdd = k * ((d - dmin) @ m.T)
        untimed = adx_view(np.clip(np.round(1520.0 + 8000.0 * cdd), 0, 65535) / 65535.0,
                           "ADX16")
        after = oiio.ImageBuf(png).get_pixels(oiio.UINT8)
        rows.append((scene, before, untimed, after))

    def spread(img, x0, x1, y0, y1):
        mean = img[y0:y1, x0:x1].reshape(-1, 3).astype(np.float64).mean(axis=0)
        return mean, float(np.ptp(mean))

    wedge_neutrality(filmgrain, stock, spec, m, dmin, k, tmp)

    for scene, *imgs in rows:
        labels = ("before", "adx16 untimed", "after (preview)")
        if scene == "wedge":
            for i in range(21):
                stops = -8.0 + 0.75 * i
                if -4.25 <= stops <= 4.0:
                    print(f"wedge step {stops:+.2f} stops: " + "; ".join(
                        f"{lab} {' '.join(f'{v:.1f}' for v in spread(img, i * 48, (i + 1) * 48, 0, 96)[0])}"
                        f" (spread {spread(img, i * 48, (i + 1) * 48, 0, 96)[1]:.1f})"
                        for lab, img in zip(labels, imgs)))
        else:
            regions = [("grey rectangle", 576 + 32, 960 - 32, 192 + 32, 576 - 32)]
            for col, name in enumerate(("white 9.5", "neutral 8", "neutral 6.5", "neutral 5",
                                        "neutral 3.5", "black 2")):
                x0, y0 = 1044 + 80 * col, 228 + 3 * 80
                regions.append((name, x0 + 8, x0 + 64, y0 + 8, y0 + 64))
            for name, x0, x1, y0, y1 in regions:
                print(f"chart {name}: " + "; ".join(
                    f"{lab} {' '.join(f'{v:.1f}' for v in spread(img, x0, x1, y0, y1)[0])}"
                    f" (spread {spread(img, x0, x1, y0, y1)[1]:.1f})"
                    for lab, img in zip(labels, imgs)))

    # Each column 768 pixels wide: the chart at half size, the wedge scaled
    # to the same width.
    fig, axes = plt.subplots(2, 3, figsize=(23.8, 5.6), dpi=100,
                             gridspec_kw={"height_ratios": [96 * 768 / 1008, 384]})
    titles = ("before: Status M above D-min as ADX10\n(no map, no gains, untimed)",
              "output=adx16 as ACES reads it\n(5219's Annex C map, ADX gains, untimed)",
              "after: the preview, a timed print\n(the same, timed on the stock's 18% grey)")
    for r, (scene, *imgs) in enumerate(rows):
        for c, img in enumerate(imgs):
            ax = axes[r][c]
            ax.imshow(img, interpolation="antialiased", aspect="auto")
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(titles[c], fontsize=11)
    fig.suptitle(f"{stock}: --wedge (top) and --chart, previews through the config's "
                 f"{DISPLAY} / {VIEW} view (MODEL.md 11)", fontsize=12)
    fig.tight_layout()
    path = os.path.join(out_dir, "preview_before_after.png")
    fig.savefig(path)
    plt.close(fig)
    print("wrote", path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--filmgrain", default="build/plugin/filmgrain")
    ap.add_argument("--out", default="docs/look")
    ap.add_argument("--only", choices=["preview_before_after"],
                    help="write only this picture (the others are left as they are)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        preview_before_after(a.filmgrain, a.out, tmp)
    if a.only:
        return 0
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
    # The numbers docs/look quotes: what the inhibitors take from the area
    # (its last 32 columns, 200-400 um in), and how far the first 25 um
    # inside the edge stand above the 25-100 um behind them.
    inside = x > 0.0
    for layer in range(3):
        on = look[rows, cols, layer].mean(axis=0)
        off = uninhibited[rows, cols, layer].mean(axis=0)
        first = inside & (x < 25.0)
        behind = (x >= 25.0) & (x < 100.0)
        print(f"edge profile, layer {'RGB'[layer]}: inhibition lowers the area by "
              f"{off[-32:].mean() - on[-32:].mean():.4f}; first 25 um stand "
              f"{on[first].mean() - on[behind].mean():+.4f} above the 25-100 um behind")
    ax.axvline(0.0, color="grey", lw=0.8)
    ax.set_xlabel("distance from the edge of the grey rectangle (um on the film)")
    ax.set_ylabel("mean density (rows of the rectangle)")
    ax.set_title("Adjacency effect: inhibitor diffusion 20 um (MODEL.md 10)")
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "edge_profile.png"))
    print("wrote", ", ".join(os.path.join(a.out, f) for f in
                             ("chart_vision3-500t.png", "chart_no-remjet.png", "halation.png",
                              "edge_profile.png", "dye_vs_silver.png",
                              "preview_before_after.png")))


if __name__ == "__main__":
    sys.exit(main())
