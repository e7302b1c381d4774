#!/usr/bin/python3
"""Each frame against the cost of reading and writing it (issue 46's targets).

    /usr/bin/python3 tools/perf/bench_floor.py --bin build/plugin/filmgrain --out docs/performance

The I/O floor of a frame is the issue's "oiiotool copy of the same plate":
`oiiotool PLATE -o copy.exr` (OpenImageIO reading the plate and writing it
as it is: half float, ZIP). Each case runs that copy and the CLI in turn,
`--repeats` times (copy, render, copy, render, ...: both see the same
load), and reports the median wall time of each, their ratio, the CLI's
CPU seconds and peak memory, beside the target. A second copy writes what
the CLI writes (`-d float --compression piz`: float RGB, PIZ) and is
reported beside it (on this machine it is the faster of the two: PIZ
compresses faster than ZIP).

Cases (--only NAME,...), vision3-500t (the default stock) on grace_hopper.jpg
resized (bench_frames.gh_input), EXR written:
  4k        4096x3112, tables built (FILMGRAIN_CACHE_DIR=off, a machine's
            first render): <= 1.5x the floor; peak memory <= 4x the plate
            in float (4 x 4096 x 3112 x 3 x 4 bytes)
  4k-warm   the same with the tables on disk from a render before (a
            farm node's second frame): <= 1.3x
  2k        2048x1556, tables built: <= 1.5x; and >= 3x faster than 4k
            (or at the floor's 1.5x)
  2k-warm   2048x1556, tables on disk: <= 1.3x
  8k        8192x6224 (the same Super 35 frame, 3 um pixels): <= 2x its
            floor, <= 4.5x the 4k render's wall time; memory as 4k
  16mm      4096x3112 over width_mm=12.52: <= 30 s
  super8    4096x3112 over width_mm=5.79: <= 60 s
  real4k    tools/perf/stocks/real-scale.json (every grain under 2 um),
            4096x3112: <= 2x the floor
  paper2k   stock=paper, 2048x1556: <= 1 s
  color4k   stock=color-negative, 4096x3112: <= 3 s

Long cases (8k, 16mm, super8) run once whatever --repeats says. Never
asserted in CI; the machine is shared: the load average at each run's start
is printed and written.
"""

import json
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_frames  # noqa: E402
import fgperf  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
REAL_STOCK = os.path.join(HERE, "stocks", "real-scale.json")
FLOAT_BYTES = 4

# name: (plate size, --filmgrain modifiers, warm cache, runs once, targets)
CASES = {
    "4k": ((4096, 3112), "", False, False, {"ratio": 1.5, "memory": 4.0}),
    "4k-warm": ((4096, 3112), "", True, False, {"ratio": 1.3}),
    "2k": ((2048, 1556), "", False, False, {"ratio": 1.5, "faster_than_4k": 3.0}),
    "2k-warm": ((2048, 1556), "", True, False, {"ratio": 1.3}),
    "8k": ((8192, 6224), "", False, True, {"ratio": 2.0, "times_4k": 4.5, "memory": 4.0}),
    "16mm": ((4096, 3112), "width_mm=12.52", False, True, {"wall_s": 30.0}),
    "super8": ((4096, 3112), "width_mm=5.79", False, True, {"wall_s": 60.0}),
    "real4k": ((4096, 3112), "stock=" + REAL_STOCK, False, False, {"ratio": 2.0}),
    "paper2k": ((2048, 1556), "stock=paper", False, False, {"wall_s": 1.0}),
    "color4k": ((4096, 3112), "stock=color-negative", False, False, {"wall_s": 3.0}),
}


def timed(label, argv, repeats, timeout, stats=None, cache_dir=None):
    """Runs argv `repeats` times (fgperf.run_logged); the list of RunResults."""
    out = []
    for i in range(repeats):
        r = fgperf.run_logged(f"{label:10s} run {i + 1}/{repeats}", argv, timeout_s=timeout,
                              stats_path=stats, cache_dir=cache_dir)
        out.append(r)
        if not r.ok:
            raise RuntimeError(f"{label}: {r.status}: {r.stderr.strip()[-400:]}")
    return out


def median(runs, attr):
    return float(np.median([getattr(r, attr) for r in runs]))


def run_case(name, args, tmp, warm_dir):
    (w, h), mods, warm, once, targets = CASES[name]
    plate = bench_frames.gh_input(args.cache, w, h)
    copy_out, float_out = os.path.join(tmp, "copy.exr"), os.path.join(tmp, "float.exr")
    out, stats = os.path.join(tmp, "frame.exr"), os.path.join(tmp, "frame.json")
    copy = ["oiiotool", plate, "-o", copy_out]
    as_ours = ["oiiotool", plate, "-d", "float", "--compression", "piz", "-o", float_out]
    render = [os.path.abspath(args.bin), plate, "--filmgrain" + (":" + mods if mods else ""),
              "-o", out, "--stats", stats, "-q"]
    cache_dir = warm_dir if warm else None
    if warm:  # the tables this frame needs, on disk before the timed runs
        timed("warm-up", render, 1, args.timeout, cache_dir=cache_dir)
    repeats = 1 if once else args.repeats
    copy_runs, float_copies, renders = [], [], []
    for _ in range(repeats):
        copy_runs += timed("copy", copy, 1, args.timeout)
        float_copies += timed("float copy", as_ours, 1, args.timeout)
        renders += timed(name, render, 1, args.timeout, stats=stats, cache_dir=cache_dir)
    layers = renders[-1].stats.get("layers", [])
    repo = os.path.dirname(os.path.dirname(HERE))
    shown = mods.replace(REAL_STOCK, os.path.relpath(REAL_STOCK, repo))
    row = {"case": name, "plate": f"{w}x{h}", "modifiers": shown or "(none)",
           "tables": "on disk" if warm else "built", "runs": repeats,
           "wall_s": median(renders, "wall_s"), "cpu_s": median(renders, "cpu_s"),
           "peak_rss_mib": max(r.peak_rss_mib for r in renders),
           "copy_s": median(copy_runs, "wall_s"), "float_copy_s": median(float_copies, "wall_s"),
           "loads": [round(r.load, 1) for r in copy_runs + float_copies + renders],
           "paths": {l["name"]: l["path"] for l in layers},
           "grains": sum(l["grains"] for l in layers), "targets": targets,
           "plate_float_mib": w * h * 3 * FLOAT_BYTES / 2**20}
    row["ratio"] = row["wall_s"] / row["copy_s"]
    row["ratio_to_float_copy"] = row["wall_s"] / row["float_copy_s"]
    for f in (copy_out, float_out, out, stats):
        if os.path.exists(f):
            os.remove(f)
    return row


def verdicts(rows):
    """Each row's targets as (what, measured, target, met) lines, with the
    cross-case ones (2k against 4k, 8k against 4k) from the same run."""
    by = {r["case"]: r for r in rows}
    for r in rows:
        t, v = r["targets"], []
        if "ratio" in t:
            v.append(("wall / copy", f"{r['ratio']:.2f}x", f"<= {t['ratio']}x",
                      r["ratio"] <= t["ratio"]))
        if "wall_s" in t:
            v.append(("wall", f"{r['wall_s']:.1f} s", f"<= {t['wall_s']:g} s",
                      r["wall_s"] <= t["wall_s"]))
        if "memory" in t:
            limit = t["memory"] * r["plate_float_mib"]
            v.append(("peak memory", f"{r['peak_rss_mib']:.0f} MiB", f"<= {limit:.0f} MiB",
                      r["peak_rss_mib"] <= limit))
        if "faster_than_4k" in t and "4k" in by:
            s = by["4k"]["wall_s"] / r["wall_s"]
            v.append(("4k wall / this wall", f"{s:.2f}x",
                      f">= {t['faster_than_4k']}x (or wall / copy <= 1.5x)",
                      s >= t["faster_than_4k"] or r["ratio"] <= 1.5))
        if "times_4k" in t and "4k" in by:
            s = r["wall_s"] / by["4k"]["wall_s"]
            v.append(("this wall / 4k wall", f"{s:.1f}x", f"<= {t['times_4k']}x",
                      s <= t["times_4k"]))
        r["verdicts"] = v
    return rows


def render_table(rows):
    lines = ["| case | plate | tables | runs | wall s (median) | CPU s | peak MiB | copy s "
             "| float copy s | wall / copy | wall / float copy | target | measured | met? |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        first = True
        for what, measured, target, met in r["verdicts"]:
            lead = (f"| {r['case']} | {r['plate']} {r['modifiers']} | {r['tables']} | {r['runs']} "
                    f"| {r['wall_s']:.2f} | {r['cpu_s']:.1f} | {r['peak_rss_mib']:.0f} "
                    f"| {r['copy_s']:.2f} | {r['float_copy_s']:.2f} | {r['ratio']:.2f} "
                    f"| {r['ratio_to_float_copy']:.2f} ") if first else "| " * 11
            lines.append(lead + f"| {what} {target} | {measured} | {'yes' if met else '**no**'} |")
            first = False
    lines += ["", "Paths per layer (--stats `path`):", ""]
    for r in rows:
        paths = "; ".join(f"{k}: `{v}`" for k, v in r["paths"].items())
        lines.append(f"- {r['case']} ({r['grains']:.3g} grains): {paths}")
    return lines


def main(argv=None):
    ap = bench_frames.frame_parser(__doc__)
    ap.add_argument("--only", default=None, help="comma-separated cases: " + ",".join(CASES))
    ap.add_argument("--repeats", type=int, default=3,
                    help="rounds of copy, float copy and render per case (8k, 16mm, super8: one)")
    ap.add_argument("--timeout", type=float, default=1200.0, help="seconds before a run is killed")
    ap.add_argument("--no-write", action="store_true", help="print only; write no files")
    args, names = bench_frames.parse_case_args(ap, argv, CASES, "bench_floor")
    rows, t0, load0 = [], time.perf_counter(), os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="bench_floor_") as tmp:
        warm_dir = os.path.join(tmp, "tables")
        os.makedirs(warm_dir)
        for n in names:
            print(f"{n}:", flush=True)
            try:
                rows.append(run_case(n, args, tmp, warm_dir))
            except RuntimeError as e:  # reported; the other cases still run
                print(f"  {n} failed: {e}", flush=True)
    total = time.perf_counter() - t0
    table = render_table(verdicts(rows))
    print("\n".join(table))
    if args.no_write:
        return 0
    repo = os.path.dirname(os.path.dirname(HERE))
    cmd = ("/usr/bin/python3 tools/perf/bench_floor.py --bin "
           f"{os.path.relpath(os.path.abspath(args.bin), repo)} --out "
           f"{os.path.relpath(os.path.abspath(args.out), repo)}"
           + (f" --repeats {args.repeats}" if args.repeats != 3 else "")
           + (f" --only {args.only}" if args.only else ""))
    head = ["# Each frame against its I/O floor (issue 46)", "",
            f"Generated by `{cmd}` in {total / 60:.1f} min at commit "
            f"{fgperf.git_describe(repo)}; {fgperf.machine_note()}; load average {load0:.1f} "
            "when it started (each run's: benchmarks_floor.json `loads`). The copy: `oiiotool "
            "PLATE -o copy.exr` (the plate as it is: half, ZIP), the issue's I/O floor; the "
            "float copy: `oiiotool PLATE -d float --compression piz -o copy.exr` (what the CLI "
            "writes). Copy, float copy and render run in turn, medians reported. Never "
            "asserted in CI.",
            ""]
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "benchmarks_floor.md"), "w") as f:
        f.write("\n".join(head + table) + "\n")
    with open(os.path.join(args.out, "benchmarks_floor.json"), "w") as f:
        json.dump({"rows": rows, "total_s": total, "machine": fgperf.machine_note(),
                   "command": cmd}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
