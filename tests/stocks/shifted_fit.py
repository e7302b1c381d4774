#!/usr/bin/env python3
"""Leave-one-out check of filmgrain-fit's recipe (issue 43).

Measures a built-in stock against its datasheet (filmgrain-fit --measure),
writes a synthetic datasheet of those measured figures with the speed
shifted by STOPS (every absolute log H of the sheet moves with it) and each
RMS granularity scaled by 1 + GRANULARITY, and fits it with no options.
Passes when the fit meets every figure (filmgrain-fit's exit status 0);
the fit's table is printed either way.

    shifted_fit.py FIT_BINARY DATASHEET PRESET STOPS GRANULARITY WORKDIR
"""
import json
import math
import os
import subprocess
import sys


def synthetic_sheet(sheet, figures, stops, granularity):
    """The datasheet `sheet` with `figures` (figures.json) as its values,
    the speed moved by `stops` and the granularities scaled."""
    out = json.loads(json.dumps(sheet))
    out["name"] = "%s-shifted" % sheet["name"]
    out["sources"] = {
        "figures": "filmgrain-fit --measure of the built-in stock on %s, speed %+g stops, "
        "RMS granularity x %g (tests/stocks/shifted_fit.py)" % (sheet["name"], stops, 1 + granularity)
    }
    out.pop("printing_density", None)
    out["speed"]["value"] = round(figures["speed"]["value"] * 2.0**stops, 1)
    # More speed: the same densities at 2^stops times less exposure.
    dlog_h = -stops * math.log10(2.0)
    measured = {l["name"]: l for l in figures["layers"]}
    for layer in out["layers"]:
        m = measured[layer["name"]]
        if "d_min" in layer:
            layer["d_min"] = round(m["d_min"][0], 3)
        if "slope" in layer:
            layer["slope"]["value"] = round(m["slope"][0], 3)
            layer["slope"]["log_h_range"] = [round(x + dlog_h, 3) for x in layer["slope"]["log_h_range"]]
        if "rms_granularity" in layer:
            (basis, table), = layer["rms_granularity"].items()
            assert len(table) == len(m["rms_granularity"])
            # figures.json lists them in increasing density, as the parser does.
            for density, (rms, _) in zip(sorted(table, key=float), m["rms_granularity"]):
                table[density] = round(rms * (1.0 + granularity), 2)
        if "curve" in layer:
            layer["curve"] = [[round(x + dlog_h, 3), d] for x, d in layer["curve"]]
    if "reciprocity" in out and "extra_stops" in out["reciprocity"]:
        by_time = {r["shutter_s"]: r["extra_stops"] for r in figures["reciprocity"]}
        for t in out["reciprocity"]["extra_stops"]:
            out["reciprocity"]["extra_stops"][t] = round(by_time[float(t)], 3)
    return out


def main():
    fit, sheet_path, preset, stops, granularity, workdir = sys.argv[1:7]
    stops, granularity = float(stops), float(granularity)
    os.makedirs(workdir, exist_ok=True)
    measured = os.path.join(workdir, "measured")
    status = subprocess.call([fit, sheet_path, "--measure", preset, "--report", measured, "-q"],
                             stdout=subprocess.DEVNULL)
    if status not in (0, 3):
        sys.exit("shifted_fit: --measure %s exited %d" % (preset, status))
    with open(sheet_path) as f:
        sheet = json.load(f)
    with open(os.path.join(measured, "figures.json")) as f:
        figures = json.load(f)
    shifted = os.path.join(workdir, "shifted.json")
    with open(shifted, "w") as f:
        json.dump(synthetic_sheet(sheet, figures, stops, granularity), f, indent=2)
    print("shifted_fit: %s, speed %+g stops, granularity x %g: %s" % (preset, stops, 1 + granularity, shifted),
          flush=True)
    status = subprocess.call([fit, shifted, "-o", os.path.join(workdir, "fitted.json")])
    print("shifted_fit: filmgrain-fit exited %d (0: every figure met)" % status)
    sys.exit(0 if status == 0 else 1)


if __name__ == "__main__":
    main()
