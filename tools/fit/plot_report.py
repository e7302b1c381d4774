#!/usr/bin/python3
"""Plots of a filmgrain-fit report beside its datasheet's figures.

Usage: plot_report.py REPORT_DIR DATASHEET.json

Reads what `filmgrain-fit ... --report REPORT_DIR` wrote (curves.csv,
granularity.csv, figures.json) and the datasheet file the stock was fitted
to, and writes into REPORT_DIR:
  curves.png       each layer's characteristic curve at 1/100 s, the
                   datasheet's curve points, speed points and slope ranges;
  granularity.png  each layer's RMS granularity against net density (48 um
                   aperture, with its error bound), the datasheet's targets
                   with their tolerance;
  reciprocity.png  the extra exposure each layer needs at each time for the
                   speed point's density, the datasheet's targets with their
                   tolerance and its no-failure range.
Nothing here measures: every number and tolerance is the fitter's, read
from figures.json (one implementation of each figure and tolerance,
tools/sensitometry/datasheet.h).
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

DPI = 90
COLOURS = {"R": "#c0392b", "G": "#27ae60", "B": "#2c6fbb", "Y": "#222222"}


def colour(layer):
    return COLOURS.get(layer, None)


def tolerance(figures, match):
    """The tolerance of the first compared figure for which match(comparison)
    holds (figures.json's comparisons, as the fitter compared them)."""
    for c in figures["comparisons"]:
        if match(c):
            return c["tolerance"]
    return None


def finish(fig, ax, out_dir, name, title, ncol=2, which="major"):
    """Title, grid and legend; writes NAME into out_dir."""
    ax.set_title(title)
    ax.grid(alpha=0.3, which=which)
    ax.legend(fontsize=7, ncol=ncol)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, name), dpi=DPI)
    plt.close(fig)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def plot_curves(out_dir, sheet, figures):
    rows = [r for r in read_csv(os.path.join(out_dir, "curves.csv"))
            if float(r["shutter_s"]) == 0.01]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    speed = {layer["name"]: layer["speed_log10_h"][0] for layer in figures["layers"]}
    for t in sheet["layers"]:
        name = t["name"]
        pts = [(float(r["log10_h_lxs"]), float(r["density"])) for r in rows
               if r["layer"] == name]
        c = colour(name)
        ax.plot([p[0] for p in pts], [p[1] for p in pts], color=c, lw=1.6,
                label=f"{name} model")
        if "curve" in t:
            ax.plot(t["curve"]["log_h"], t["curve"]["density"], "o", mfc="none",
                    color=c, ms=5, label=f"{name} datasheet")
        if "slope" in t:
            lo, hi = t["slope"]["log_h_range"]
            ax.axvspan(lo, hi, color=c or "grey", alpha=0.06)
        if name in speed:
            ax.axvline(speed[name], color=c, ls=":", lw=1)
    xs = [float(r["log10_h_lxs"]) for r in rows]
    ax.set_xlim(max(min(xs), -5.0), max(xs))
    ax.set_xlabel("log10 exposure (lux-seconds), 1/100 s; dotted: speed points, "
                  "shaded: slope ranges")
    ax.set_ylabel("density (gross)")
    finish(fig, ax, out_dir, "curves.png",
           f"{figures['stock']['name']}: characteristic curves")


def plot_granularity(out_dir, sheet, figures):
    rows = read_csv(os.path.join(out_dir, "granularity.csv"))
    rel = tolerance(figures, lambda c: " RMS at " in c["figure"])
    d_min = {layer["name"]: layer["d_min"][0] for layer in figures["layers"]}
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for t in sheet["layers"]:
        name = t["name"]
        c = colour(name)
        pts = [(float(r["net_density"]), float(r["rms_granularity"]), float(r["error"]))
               for r in rows if r["layer"] == name]
        x = [p[0] for p in pts]
        y = [p[1] for p in pts]
        e = [p[2] for p in pts]
        ax.plot(x, y, color=c, lw=1.6, label=f"{name} model")
        ax.fill_between(x, [a - b for a, b in zip(y, e)], [a + b for a, b in zip(y, e)],
                        color=c or "grey", alpha=0.2, lw=0)
        g = t.get("rms_granularity", {})
        if "gross_density" in g:  # on the net axis: above the model's D-min
            targets = [(float(k) - d_min[name], v) for k, v in g["gross_density"].items()]
        else:
            targets = [(float(k), v) for k, v in g.get("net_density", {}).items()]
        if targets:
            ax.errorbar([p[0] for p in targets], [p[1] for p in targets],
                        yerr=[rel * p[1] for p in targets], fmt="s", mfc="none",
                        color=c, capsize=3, label=f"{name} datasheet +-{100 * rel:g}%")
    ax.set_xlabel("net density (above D-min), 1/100 s")
    ax.set_ylabel("RMS granularity (1000 sigma_D, 48 um)")
    ax.set_ylim(bottom=0)
    finish(fig, ax, out_dir, "granularity.png",
           f"{figures['stock']['name']}: granularity against density")


def plot_reciprocity(out_dir, sheet, figures):
    rec = figures.get("reciprocity", [])
    target = sheet.get("reciprocity")
    if not rec or not target:
        return False
    fig, ax = plt.subplots(figsize=(7, 4.5))
    times = [r["shutter_s"] for r in rec]
    names = [layer["name"] for layer in figures["layers"]]
    stock_layers = [layer["name"] for layer in figures["stock"]["layers"]]
    for name in names:
        k = stock_layers.index(name)
        ax.plot(times, [r["per_layer"][k] for r in rec], "o-", color=colour(name), ms=4,
                label=f"{name} model")
    lo, hi = target.get("none_between", [None, None])
    if lo is not None:
        none = tolerance(figures, lambda c: c["figure"].endswith("(none)"))
        ax.fill_between([lo, hi], [-none] * 2, [none] * 2, color="grey",
                        alpha=0.2, lw=0, label=f"datasheet: none (+-{none:.3g} stop)")
    extra = target.get("extra_stops", {})
    if extra:
        tol = tolerance(figures, lambda c: c["figure"].startswith("reciprocity")
                        and not c["figure"].endswith("(none)"))
        ts = [float(k) for k in extra]
        ax.errorbar(ts, list(extra.values()), yerr=tol, fmt="s", mfc="none",
                    color="black", capsize=3, label=f"datasheet +-{tol:.3g} stop")
    ax.set_xscale("log")
    ax.axhline(0.0, color="black", lw=0.5)
    ax.set_xlabel(f"exposure time, s (reference {target.get('reference_s', 0.01)} s)")
    ax.set_ylabel("extra exposure for the speed point's density, stops")
    finish(fig, ax, out_dir, "reciprocity.png", f"{figures['stock']['name']}: reciprocity",
           ncol=1, which="both")
    return True


def main(argv):
    if len(argv) != 3 or argv[1] in ("-h", "--help"):
        print(__doc__.strip(), file=sys.stderr if len(argv) != 2 else sys.stdout)
        return 0 if len(argv) == 2 else 2
    out_dir, sheet_path = argv[1], argv[2]
    with open(sheet_path) as f:
        sheet = json.load(f)
    with open(os.path.join(out_dir, "figures.json")) as f:
        figures = json.load(f)
    plot_curves(out_dir, sheet, figures)
    plot_granularity(out_dir, sheet, figures)
    wrote = ["curves.png", "granularity.png"]
    if plot_reciprocity(out_dir, sheet, figures):
        wrote.append("reciprocity.png")
    print(f"plot_report.py: wrote {', '.join(wrote)} in {out_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
