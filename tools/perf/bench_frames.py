#!/usr/bin/python3
"""Whole-frame benchmarks of the filmgrain CLI against the issue's targets.

    /usr/bin/python3 tools/perf/bench_frames.py --bin build/plugin/filmgrain --out docs/performance

Runs the CLI (Release build, default auto engine unless a case says
otherwise) on generated inputs and prints, per case, wall and CPU seconds,
peak memory, grains per second and the ratio of each measurement to its
target; ratios between cases (ROI against image, 4x and 16x area against
1x, 2 threads against 1) are always measured in the same run. Writes
benchmarks.md and benchmarks.json into --out. Never stops at a missed
target: it reports the number and the ratio. A run longer than --timeout
(600 s) is killed and recorded as such; fine4k's full-frame time is
estimated from a 1/64-area ROI of the same frame.

Cases (--only NAME,...):
  paper2k   paper stock (1 layer), 2048x1556 over 24.89 mm: <= 1 s
  color4k   color-negative (3 layers), 4096x3112: <= 3 s
  fine4k    tools/perf/stocks/fine-color.json (1 um grains, 3/um^2 per
            layer, 3 layers), 4096x3112: <= 15 s, peak memory <= 1.5 GB;
            time estimated from a 1/64 ROI when that predicts more than
            --timeout, the full frame then run for --fine-full-timeout
            seconds only, for its memory
  real4k    tools/perf/stocks/real-scale.json (0.5 and 0.9 um grains, 16/um^2
            per layer, 3 layers: ~5.7e10 grains), 4096x3112: <= 10 s,
            peak memory <= 2 GB
  paper16k  paper on a 16384x12288 single-channel input, -d half:
            completes, peak memory <= 2.5 GB
  roi16k    a 256x256 ROI of that 16K frame against a 256x256 image of the
            same film area (same grains per pixel): ratio <= 2
  linear    paper at 1x, 4x, 16x area (512x389 on 6.2225 mm, 1024x778 on
            12.445 mm, 2048x1556 on 24.89 mm: same pixel pitch): time
            within 15% of linear in the grain count
  threads   paper 1024x778 (the 4x case): 2 threads >= 1.8x faster than 1
  exact     the exact engine on the 1x paper frame and a 256x256 ROI of
            the 1x colour frame: grains/s and absorbed photons/s, beside
            auto

--quick: one repeat, and the 16K frame replaced by an 8192x6144 one.
Inputs are generated once into --cache (default ~/.cache/filmgrain-perf):
grace_hopper.jpg (matplotlib's sample data) resized with oiiotool, and a
procedural numpy image for the 16K frame. They are not committed.

Tables: every run builds its P(develop|N) tables (FILMGRAIN_CACHE_DIR=off
unless the environment sets it: fgperf.cli_env), so the times are a
machine's first render of a stock; later renders read the tables from disk.

Timing on a shared machine: wall time depends on the other jobs; CPU time
(user + system of the CLI, all threads) much less. The tables give both, and
"wall if idle" = serial + (CPU - serial) / threads, serial = the stages that
run on one thread (read, colour, write) and the process's time outside the
CLI's own stages (dynamic loading of the libraries, start-up, exit: its wall
time less --stats seconds.total): what the wall time would be with both
cores to ourselves. Targets are compared with both.
"""

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fgperf  # noqa: E402

GRACE_HOPPER = "/usr/share/matplotlib/mpl-data/sample_data/grace_hopper.jpg"
HERE = os.path.dirname(os.path.abspath(__file__))
FINE_STOCK = os.path.join(HERE, "stocks", "fine-color.json")
REAL_STOCK = os.path.join(HERE, "stocks", "real-scale.json")
FRAME_MM = 24.89


# --------------------------------------------------------------------------
# Inputs

def gh_input(cache, w, h):
    """grace_hopper resized to w x h (sRGB values, half EXR), cached."""
    path = os.path.join(cache, f"grace_hopper_{w}x{h}.exr")
    if not os.path.exists(path):
        tmp = path + ".tmp.exr"
        subprocess.run(["oiiotool", GRACE_HOPPER, "--resize", f"{w}x{h}", "-d", "half",
                        "-o", tmp], check=True)
        os.replace(tmp, path)
    return path


def procedural_input(cache, w, h):
    """A single-channel scene-linear image: grey * 2^stops, stops a ramp
    from -4 to +3 across plus slow ripples (every exposure of the curve),
    half EXR written in strips (never the whole image in Python memory)."""
    path = os.path.join(cache, f"procedural_{w}x{h}.exr")
    if os.path.exists(path):
        return path
    tmp = path + ".tmp.exr"
    spec = fgperf.oiio.ImageSpec(w, h, 1, "half")
    spec.channelnames = ("Y",)
    spec.attribute("compression", "zip")
    out = fgperf.oiio.ImageOutput.create(tmp)
    if out is None or not out.open(tmp, spec):
        raise RuntimeError(f"cannot write {tmp}: {fgperf.oiio.geterror()}")
    x = np.arange(w, dtype=np.float32)
    ramp = -4.0 + 7.0 * x / (w - 1)
    strip = 256
    for y0 in range(0, h, strip):
        y1 = min(h, y0 + strip)
        y = np.arange(y0, y1, dtype=np.float32)[:, None]
        stops = ramp[None, :] + 1.5 * np.sin(x[None, :] / 517.0) * np.cos(y / 389.0)
        v = (0.18 * np.exp2(stops)).astype(np.float16)
        if not out.write_scanlines(y0, y1, 0, v[:, :, None]):
            raise RuntimeError(f"cannot write {tmp}: {out.geterror()}")
    out.close()
    os.replace(tmp, path)
    return path


# --------------------------------------------------------------------------
# Running

class Bench:
    def __init__(self, args):
        self.args = args
        self.binary = os.path.abspath(args.bin)
        self.tmp = os.path.join(args.cache, "out")
        os.makedirs(self.tmp, exist_ok=True)
        self.runs = []

    def run(self, label, inp, mods, threads=0, half=False, repeats=1, iscolorspace=None,
            timeout=None):
        """Runs the CLI `repeats` times; returns a summary dict (min and
        median of wall and CPU, max peak memory, the last run's stats)."""
        timeout = timeout or self.args.timeout
        stem = label.replace("/", "_")
        out = os.path.join(self.tmp, f"{stem}.exr")
        stats = os.path.join(self.tmp, f"{stem}.json")
        argv = [self.binary]
        argv += ["--wedge"] if inp == "wedge" else [inp]
        if iscolorspace:
            argv += ["--iscolorspace", iscolorspace]
        argv += [f"--filmgrain:{mods}", "-o", out, "--stats", stats, "-q"]
        if half:
            argv += ["-d", "half"]
        if threads:
            argv += ["--threads", str(threads)]
        results = []
        for i in range(repeats):
            r = fgperf.run_logged(f"{label:28s} run {i + 1}/{repeats}", argv, timeout_s=timeout,
                                  stats_path=stats)
            results.append(r)
            if not r.ok:
                if r.returncode != -9:
                    print("    " + r.stderr.strip().replace("\n", "\n    "), flush=True)
                break
        for p in (out, stats):
            if os.path.exists(p):
                os.remove(p)
        ok = [r for r in results if r.ok]
        s = {"label": label, "argv": argv, "repeats": len(results), "ok": len(ok) == len(results),
             "timed_out": any(r.returncode == -9 for r in results),
             "error": next((r.stderr.strip() for r in results if not r.ok and r.returncode != -9),
                           ""),
             "wall_all": [r.wall_s for r in results], "cpu_all": [r.cpu_s for r in results],
             "peak_rss_mib": max(r.peak_rss_mib for r in results),
             "threads": threads or os.cpu_count()}
        src = ok if ok else results
        s["wall_min"] = min(r.wall_s for r in src)
        s["wall_median"] = float(np.median([r.wall_s for r in src]))
        s["cpu_min"] = min(r.cpu_s for r in src)
        s["cpu_median"] = float(np.median([r.cpu_s for r in src]))
        if ok:
            # The fastest run's own figures, as wall_min is its wall time.
            best = min(ok, key=lambda r: r.wall_s)
            st = best.stats
            s["stats_seconds"] = st["seconds"]
            s["grains"] = sum(l["grains"] for l in st["layers"])
            s["photons"] = sum(l["absorbed_photons"] for l in st["layers"])
            s["setup_s"] = sum(l["setup_seconds"] for l in st["layers"])
            s["paths"] = sorted({l["path"] for l in st["layers"]})
            s["scan"] = st["scan"]
            # Serial stages (read, colour conversion, write) and the process
            # outside them (dynamic loading of ~270 libraries, start-up,
            # exit: the run's wall time less the CLI's own total) cannot use
            # the second core; the rest of the CPU time divides among the
            # threads.
            sec = st["seconds"]
            s["process_s"] = max(0.0, best.wall_s - sec.get("total", best.wall_s))
            serial = (sec.get("read", 0) + sec.get("color", 0) + sec.get("write", 0)
                      + s["process_s"])
            s["serial_s"] = serial
            s["idle_wall_est"] = serial + max(0.0, s["cpu_min"] - serial) / s["threads"]
        self.runs.append(s)
        return s


def rate(n, seconds):
    return n / seconds if seconds and seconds > 0 else float("nan")


def fmt_rate(v):
    if v != v:
        return "n/a"
    for unit, div in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if v >= div:
            return f"{v / div:.3g}{unit}"
    return f"{v:.3g}"


# --------------------------------------------------------------------------
# Cases

def case_paper2k(b, rep):
    inp = gh_input(b.args.cache, 2048, 1556)
    s = b.run("paper2k", inp, f"stock=paper:width_mm={FRAME_MM}", repeats=rep,
              iscolorspace="sRGB")
    return [target_row("paper2k", "paper, 1 layer, 2048x1556, 24.89 mm", s, time_s=1.0)]


def case_color4k(b, rep):
    inp = gh_input(b.args.cache, 4096, 3112)
    s = b.run("color4k", inp, f"stock=color-negative:width_mm={FRAME_MM}", repeats=1,
              iscolorspace="sRGB")
    return [target_row("color4k", "color-negative, 3 layers, 4096x3112", s, time_s=3.0)]


def case_fine4k(b, rep):
    inp = gh_input(b.args.cache, 4096, 3112)
    mods = f"stock={FINE_STOCK}:width_mm={FRAME_MM}"
    roi_mods = ":roi=1792,1361,512,389"
    factor = 4096 * 3112 / (512 * 389)
    # A 1/64-area ROI (512x389 at the centre) predicts the full frame (about
    # 4e9 grains): time is linear in grains (see the linear case). Memory:
    # the ROI run holds every per-tile buffer the full frame holds (same
    # stock, tile and threads); the frame-sized buffers (the input read as
    # float, the 3-layer output, the EXR write) are the colour stock's too,
    # so the full frame's peak = the ROI's peak + (color4k's peak - the peak
    # of the same ROI with the colour stock).
    roi = b.run("fine4k_roi1/64", inp, mods + roi_mods, repeats=1, iscolorspace="sRGB")
    croi = b.run("color4k_roi1/64", inp, f"stock=color-negative:width_mm={FRAME_MM}" + roi_mods,
                 repeats=1, iscolorspace="sRGB")
    color_full = next((r for r in b.runs if r["label"] == "color4k" and r["ok"]), None)
    est = None
    if roi["ok"]:
        est = {k: roi[k] * factor for k in ("wall_min", "cpu_min")}
        est["grains"] = roi["grains"] * factor
        est["factor"] = factor
        if color_full and croi["ok"]:
            est["peak_rss_mib"] = roi["peak_rss_mib"] + color_full["peak_rss_mib"] \
                - croi["peak_rss_mib"]
    full = None
    if est is None or est["wall_min"] <= b.args.timeout:
        full = b.run("fine4k", inp, mods, repeats=1, iscolorspace="sRGB")
    return [target_row("fine4k", "fine-color (1 um, 3/um^2 x 3 layers), 4096x3112",
                       full or roi, time_s=15.0, rss_mib=1.5 * 1024, estimate=est,
                       estimated_only=full is None)]


def case_real4k(b, rep):
    inp = gh_input(b.args.cache, 4096, 3112)
    s = b.run("real4k", inp, f"stock={REAL_STOCK}:width_mm={FRAME_MM}", repeats=1,
              iscolorspace="sRGB")
    return [target_row("real4k", "real-scale (0.5-0.9 um, 16/um^2 x 3 layers), 4096x3112", s,
                       time_s=10.0, rss_mib=2.0 * 1024)]


def case_paper16k(b, rep):
    w, h = (8192, 6144) if b.args.quick else (16384, 12288)
    inp = procedural_input(b.args.cache, w, h)
    s = b.run(f"paper{w // 1024}k", inp, f"stock=paper:width_mm={FRAME_MM}", half=True,
              repeats=1)
    return [target_row("paper16k", f"paper on {w}x{h} single channel, -d half", s,
                       rss_mib=2.5 * 1024, completes=True)]


def case_roi16k(b, rep):
    w, h = (8192, 6144) if b.args.quick else (16384, 12288)
    big = procedural_input(b.args.cache, w, h)
    x0, y0 = w // 2 - 128, h // 2 - 128
    roi = b.run("roi256_of_16k", big, f"stock=paper:width_mm={FRAME_MM}:roi={x0},{y0},256,256",
                half=True, repeats=rep)
    # The same 256x256 pixels cut out as an image on the same film area.
    small = os.path.join(b.args.cache, f"procedural_{w}x{h}_crop256.exr")
    if not os.path.exists(small):
        subprocess.run(["oiiotool", big, "--cut", f"256x256+{x0}+{y0}", "-o", small + ".tmp.exr"],
                       check=True)
        os.replace(small + ".tmp.exr", small)
    img = b.run("image256", small,
                f"stock=paper:width_mm={FRAME_MM * 256 / w:.9g}", half=True, repeats=rep)
    ratio = roi["wall_min"] / img["wall_min"]
    cratio = roi["cpu_min"] / img["cpu_min"]
    # auto chooses its kinetics (table or chain) from the whole frame, never
    # the ROI, so that a ROI is bit-identical to the same pixels of the
    # frame: the ROI may build a table the 256x256 image does not need.
    # (setup_s is wall time; the build runs on every thread.)
    rs, ist = roi.get("setup_s", 0.0), img.get("setup_s", 0.0)
    setup = (f"table build: ROI {rs:.2f} s, image {ist:.2f} s (wall); wall ratio without it: "
             f"{(roi['wall_min'] - rs) / max(1e-9, img['wall_min'] - ist):.2f}")
    return [ratio_row("roi16k", f"256x256 ROI of the {w}x{h} frame / 256x256 image", roi, img,
                      ratio, cratio, "<= 2", ratio <= 2.0, cratio <= 2.0, extra=setup)]


def linear_inputs(b):
    specs = [(512, 389, FRAME_MM / 4), (1024, 778, FRAME_MM / 2), (2048, 1556, FRAME_MM)]
    return [(gh_input(b.args.cache, w, h), w, h, mm) for w, h, mm in specs]


def case_linear(b, rep):
    runs = []
    for inp, w, h, mm in linear_inputs(b):
        runs.append(b.run(f"linear_{w}", inp, f"stock=paper:width_mm={mm:.9g}", repeats=rep,
                          iscolorspace="sRGB"))
    rows = []
    base = runs[0]
    for k, s in zip((4, 16), runs[1:]):
        g = s["grains"] / base["grains"]
        # Ratio of time per grain: 1 is linear.
        r_wall = (s["wall_min"] / base["wall_min"]) / g
        r_cpu = (s["cpu_min"] / base["cpu_min"]) / g
        # Without the table build (a fixed cost per frame, in setup_s).
        sim = lambda x: x["stats_seconds"]["simulate"] - x["setup_s"]  # noqa: E731
        r_sim = (sim(s) / sim(base)) / g
        rows.append(ratio_row(f"linear{k}x", f"paper {s['scan']['width']}x{s['scan']['height']} "
                              f"({k}x area, {g:.2f}x grains) time per grain / 1x",
                              s, base, r_wall, r_cpu, "0.85-1.15",
                              0.85 <= r_wall <= 1.15, 0.85 <= r_cpu <= 1.15,
                              extra=f"without table build: {r_sim:.2f}"))
    return rows


def case_threads(b, rep):
    inp, w, h, mm = linear_inputs(b)[1]
    one = b.run("threads1", inp, f"stock=paper:width_mm={mm:.9g}", threads=1, repeats=rep,
                iscolorspace="sRGB")
    two = b.run("threads2", inp, f"stock=paper:width_mm={mm:.9g}", threads=2, repeats=rep,
                iscolorspace="sRGB")
    speedup = one["wall_min"] / two["wall_min"]
    # Amdahl from the 1-thread run: serial stages and the process's own
    # start-up and exit stay, the rest halves.
    serial = one["serial_s"]
    amdahl = one["wall_min"] / (serial + (one["wall_min"] - serial) / 2)
    cpu_overhead = two["cpu_min"] / one["cpu_min"]
    return [ratio_row("threads", f"paper 1024x778: wall(1 thread) / wall(2 threads)", one, two,
                      speedup, amdahl, ">= 1.8", speedup >= 1.8, amdahl >= 1.8,
                      extra=f"CPU(2)/CPU(1) = {cpu_overhead:.2f}; second value: Amdahl "
                            "estimate for an idle machine from the 1-thread run's serial "
                            f"{serial:.2f} s (read, colour, write, and "
                            f"{one['process_s']:.2f} s of loading, start-up and exit)",
                      cpu_label="idle est.")]


def case_exact(b, rep):
    rows = []
    inp, w, h, mm = linear_inputs(b)[0]
    for eng in ("exact", "auto"):
        s = b.run(f"{eng}_paper512", inp, f"stock=paper:width_mm={mm:.9g}:engine={eng}",
                  repeats=rep, iscolorspace="sRGB")
        rows.append(throughput_row(f"{eng} paper 512x389", s))
    # Colour: a 256x256 ROI of the 512x389 frame (1.1e7 grains; the exact
    # engine takes about 4 us a grain there).
    for eng in ("exact", "auto"):
        s = b.run(f"{eng}_color512_roi256", inp,
                  f"stock=color-negative:width_mm={mm:.9g}:engine={eng}:roi=128,66,256,256",
                  repeats=1, iscolorspace="sRGB")
        rows.append(throughput_row(f"{eng} color-negative, 256x256 ROI of 512x389", s))
    return rows


# --------------------------------------------------------------------------
# Rows

def target_row(name, what, s, time_s=None, rss_mib=None, completes=False, estimate=None,
               estimated_only=False):
    """estimated_only: s is the ROI run the estimate comes from, not the case."""
    r = {"kind": "target", "case": name, "what": what, "run": s, "time_target_s": time_s,
         "rss_target_mib": rss_mib, "completes_target": completes, "estimate": estimate,
         "estimated_only": estimated_only}
    return r


def ratio_row(name, what, a, b, ratio, ratio_cpu, target, ok, ok_cpu, extra="",
              cpu_label="CPU"):
    return {"kind": "ratio", "case": name, "what": what, "runs": [a, b], "ratio": ratio,
            "ratio_cpu": ratio_cpu, "target": target, "ok": ok, "ok_cpu": ok_cpu, "extra": extra,
            "cpu_label": cpu_label}


def throughput_row(what, s):
    return {"kind": "throughput", "what": what, "run": s}


def yes_no(ok):
    return "yes" if ok else "**no**"


def table_head(title, columns):
    """Markdown lines: the heading of section `title` and the head of its
    table, with `columns`."""
    return [f"### {title}", "", "| " + " | ".join(columns) + " |", "|" + " --- |" * len(columns)]


def of_kind(rows, kind):
    """The rows of one table: `rows` whose kind is `kind`."""
    return [r for r in rows if r["kind"] == kind]


def render_tables(rows):
    L = table_head("Targets", [
        "case", "what", "wall s (min of runs)", "CPU s", "wall if idle (est.)", "target",
        "wall / target", "idle est. / target", "peak memory", "memory target", "grains",
        "grains/s (wall)", "grains per CPU-s", "paths"])
    for r in of_kind(rows, "target"):
        s = r["run"]
        t = r["time_target_s"]
        if s["timed_out"]:
            wall = f"> {s['wall_min']:.0f} (killed)"
        elif not s["ok"]:
            wall = f"failed: {s['error'][:80]}"
        else:
            wall = f"{s['wall_min']:.2f}"
        ratio = (f"{s['wall_min'] / t:.1f}x" if t and s["ok"]
                 else f"> {s['wall_min'] / t:.1f}x" if t else "")
        idle = s.get("idle_wall_est")
        idle_ratio = f"{idle / t:.1f}x" if t and idle else ""
        est = r.get("estimate")
        if est and r.get("estimated_only"):
            f = est["factor"]
            wall = f"est. {est['wall_min']:.0f} ({f:.0f} x the 1/{f:.0f} ROI's {s['wall_min']:.1f})"
            ratio = f"est. {est['wall_min'] / t:.0f}x"
            idle = est["cpu_min"] / s["threads"]
            idle_ratio = f"est. {idle / t:.0f}x"
        elif est:
            wall += f" ({est['factor']:.0f} x ROI: {est['wall_min']:.0f})"
        mem = f"{s['peak_rss_mib']:.0f} MiB"
        mem_value = s["peak_rss_mib"]
        if r.get("estimated_only"):
            mem_value = (est or {}).get("peak_rss_mib")
            mem = (f"est. {mem_value:.0f} MiB (ROI {s['peak_rss_mib']:.0f} + frame buffers)"
                   if mem_value else "n/a")
        if s["timed_out"]:
            mem = f">= {mem} (when killed)"
        mt = (f"{r['rss_target_mib']:.0f} MiB ({yes_no(mem_value <= r['rss_target_mib'])})"
              if r["rss_target_mib"] and mem_value else "")
        target = f"<= {t:g} s" if t else ("completes: " + yes_no(s["ok"]) if r["completes_target"]
                                          else "")
        grains = est["grains"] if r.get("estimated_only") else \
            (s.get("grains") or (est or {}).get("grains"))
        gtxt = "n/a"
        if grains:
            gtxt = f"{grains:.3g}" + (" (est.)" if r.get("estimated_only") or not s.get("grains")
                                      else "")
        idle_txt = (f"est. {idle:.0f}" if r.get("estimated_only") else f"{idle:.2f}") \
            if idle else "n/a"
        cpu_txt = ("> " if s["timed_out"] else "") + f"{s['cpu_min']:.2f}"
        if r.get("estimated_only"):
            cpu_txt = f"est. {est['cpu_min']:.0f}"
        g_wall = fmt_rate(rate(s["grains"], s["wall_min"])) if s.get("grains") else "n/a"
        g_cpu = fmt_rate(rate(s["grains"], s["cpu_min"])) if s.get("grains") else "n/a"
        paths = "; ".join("`" + p + "`" for p in s.get("paths", []))
        L.append(f"| {r['case']} | {r['what']} | {wall} | {cpu_txt} | {idle_txt} | {target} | "
                 f"{ratio} | {idle_ratio} | {mem} | {mt} | {gtxt} | {g_wall} | {g_cpu} | "
                 f"{paths} |")
    L.append("")
    L += table_head("Ratios (measured in the same run)", [
        "case", "what", "ratio (wall)", "ratio (CPU or idle estimate)", "target", "met (wall)",
        "met (CPU / idle est.)", "runs (wall s, CPU s)", "notes"])
    for r in of_kind(rows, "ratio"):
        runs = "; ".join(f"{s['label']}: {s['wall_min']:.2f}, {s['cpu_min']:.2f}"
                         for s in r["runs"])
        L.append(f"| {r['case']} | {r['what']} | {r['ratio']:.2f} | {r['ratio_cpu']:.2f} "
                 f"({r['cpu_label']}) | {r['target']} | {yes_no(r['ok'])} | "
                 f"{yes_no(r['ok_cpu'])} | "
                 f"{runs} | {r['extra']} |")
    L.append("")
    L += table_head("Throughput", [
        "run", "paths", "wall s", "CPU s", "grains", "absorbed photons", "grains/s (wall)",
        "grains per CPU-s", "photons/s (wall)", "photons per CPU-s"])
    for r in of_kind(rows, "throughput"):
        s = r["run"]
        if not s["ok"]:
            L.append(f"| {r['what']} | failed | | | | | | | | |")
            continue
        L.append(f"| {r['what']} | {'; '.join('`' + p + '`' for p in s['paths'])} | "
                 f"{s['wall_min']:.2f} | {s['cpu_min']:.2f} | {s['grains']:.3g} | "
                 f"{s['photons']:.3g} | {fmt_rate(rate(s['grains'], s['wall_min']))} | "
                 f"{fmt_rate(rate(s['grains'], s['cpu_min']))} | "
                 f"{fmt_rate(rate(s['photons'], s['wall_min']))} | "
                 f"{fmt_rate(rate(s['photons'], s['cpu_min']))} |")
    L.append("")
    return L


CASES = {
    "paper2k": case_paper2k, "color4k": case_color4k, "fine4k": case_fine4k,
    "real4k": case_real4k,
    "paper16k": case_paper16k, "roi16k": case_roi16k, "linear": case_linear,
    "threads": case_threads, "exact": case_exact,
}


def frame_parser(doc):
    """The command line of the whole-frame scripts (this one and
    profile_frames.py), described by the first paragraph of `doc`: --bin,
    --out and --cache (where the inputs are generated once)."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/plugin/filmgrain")
    ap.add_argument("--out", default="docs/performance")
    ap.add_argument("--cache", default=os.path.join(os.path.expanduser("~"), ".cache",
                                                    "filmgrain-perf"))
    return ap


def parse_case_args(ap, argv, cases, prog):
    """Parses a whole-frame script's command line (frame_parser's, with
    --only): exits with a message when --bin is not an executable, oiiotool
    is missing or --only names an unknown case; makes --cache. Returns
    (args, the case names to run, in order)."""
    args = ap.parse_args(argv)
    if not os.access(args.bin, os.X_OK):
        sys.exit(f"{prog}: {args.bin} is not an executable (build first)")
    if not shutil.which("oiiotool"):
        sys.exit(f"{prog}: needs oiiotool (openimageio-tools)")
    os.makedirs(args.cache, exist_ok=True)
    names = args.only.split(",") if args.only else list(cases)
    unknown = [n for n in names if n not in cases]
    if unknown:
        sys.exit(f"{prog}: unknown case(s) {', '.join(unknown)}; known: {', '.join(cases)}")
    return args, names


def main(argv=None):
    ap = frame_parser(__doc__)
    ap.add_argument("--only", default=None, help="comma-separated cases: " + ",".join(CASES))
    ap.add_argument("--quick", action="store_true", help="one repeat; 8K instead of 16K")
    ap.add_argument("--repeats", type=int, default=2,
                    help="repeats of the short cases (paper2k, roi16k, linear, threads, exact "
                         "paper); the long ones run once")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds before a run is killed")
    ap.add_argument("--fine-full-timeout", type=float, default=90.0,
                    help="seconds the full fine4k frame runs (to measure its memory) when its "
                         "1/64 ROI predicts more than --timeout")
    ap.add_argument("--no-write", action="store_true", help="print only; write no files")
    args, names = parse_case_args(ap, argv, CASES, "bench_frames")
    rep = 1 if args.quick else args.repeats
    b = Bench(args)
    rows, seconds = [], {}
    t_all = time.perf_counter()
    load_start = os.getloadavg()
    for n in names:
        print(f"{n}:", flush=True)
        t0 = time.perf_counter()
        try:
            rows += CASES[n](b, rep)
        except Exception as e:  # report and go on: one case never stops the others
            print(f"  {n} failed: {e}", flush=True)
            rows.append({"kind": "ratio", "case": n, "what": f"failed: {e}", "runs": [],
                         "ratio": float("nan"), "ratio_cpu": float("nan"), "target": "",
                         "ok": False, "ok_cpu": False, "extra": "", "cpu_label": ""})
        seconds[n] = time.perf_counter() - t0
    total = time.perf_counter() - t_all
    tables = render_tables(rows)
    print("\n".join(tables))
    print(f"bench_frames: {total:.0f} s")
    if args.no_write:
        return 0
    os.makedirs(args.out, exist_ok=True)
    repo = os.path.dirname(os.path.dirname(HERE))
    cmd = ("/usr/bin/python3 tools/perf/bench_frames.py --bin "
           f"{os.path.relpath(os.path.abspath(args.bin), repo)} --out "
           f"{os.path.relpath(os.path.abspath(args.out), repo)}"
           + (" --quick" if args.quick else "") + (f" --only {args.only}" if args.only else ""))
    head = ["# Whole-frame benchmarks", "",
            f"Generated by `{cmd}` in {total / 60:.1f} min at commit {fgperf.git_describe(repo)}; "
            f"{fgperf.machine_note()}; load average {load_start[0]:.1f} when it started. "
            f"Repeats: {rep} for the short cases (minimum reported), one for fine4k and the 16K "
            "frame. Per-case seconds: " + ", ".join(f"{k} {v:.0f}" for k, v in seconds.items())
            + ".", "",
            "Wall times on this shared machine are inflated by other jobs; *wall if idle* = "
            "serial + (CPU seconds - serial) / threads, serial = read + colour + write seconds "
            "and the process outside them (loading its libraries, start-up, exit: wall less "
            "--stats seconds.total), estimates the wall time with both cores free. "
            "Targets are judged on both; neither is asserted in CI. "
            "Tables on disk: FILMGRAIN_CACHE_DIR="
            + os.environ.get("FILMGRAIN_CACHE_DIR", "off")
            + " (unless set, off: every run builds its P(develop|N) tables, as a machine's "
            "first render of a stock does; a second render reads them from disk).",
            ""]
    with open(os.path.join(args.out, "benchmarks.md"), "w") as f:
        f.write("\n".join(head + tables))
    with open(os.path.join(args.out, "benchmarks.json"), "w") as f:
        json.dump({"rows": rows, "runs": b.runs, "seconds": seconds, "total_s": total,
                   "machine": fgperf.machine_note(), "quick": args.quick}, f, indent=1,
                  default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
