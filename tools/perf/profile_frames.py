#!/usr/bin/python3
"""Where the time of a whole-frame render goes, by stage of the model.

    /usr/bin/python3 tools/perf/profile_frames.py --bin build/plugin/filmgrain --out docs/performance

Samples the CLI with Linux perf (`apt install linux-perf`; call stacks
unwound from DWARF, so a plain Release build will do) on cases that do the
same work per grain as the benchmark frames (tools/perf/bench_frames.py),
at a fraction of their area:

  paper1x     paper, 512x389 over 6.2225 mm: 1/16 of the paper2k frame
  color/64    color-negative, a 512x389 ROI of the 4096x3112 frame
  color/16    the same, a 1024x778 ROI (the table build a smaller share)
  fine/256    the fine-grain benchmark stock, a 256x195 ROI of 4096x3112
  exact/64    the exact engine on the color/64 ROI's 256x194 corner

Each sample is charged to the table build when that is anywhere on its
stack (the chain runs inside it count as the table build), else to the
stage of the innermost model function on its stack (so the logarithms
inside the chain count as the chain, the disc integrals inside the fast
kernel as exposure):

  table build        DevelopTable::DevelopTable and its chain sampler
                     (sample_latent_image_by_spacings): P(develop | N)
  kinetics chain     simulate_latent_image outside the table build
  coverage           grid_coverage / scanline_coverage / the raster
                     (raster_coverage, its span and count loops)
  exposure           LayerExposure (integral of H over each disc), the
                     fast kernel's ExposurePlane and disc integrals
  grains             grain generation (PopulationGrains, the fast kernel's
                     FastGrains and develop_fast), Poisson and develop draws
                     (sample_poisson, n4_needed, table and curve lookups)
  pixel scale        the pixel model's draws (PixelModel)
  render, other      the rest of render_negative and the tile renderer
                     (tiles, density, copies)
  read/colour/write  OpenImageIO, OpenColorIO, OpenEXR
  start-up           the dynamic loader (ld.so relocations of the libraries)
  kernel, other      page faults, thread start, anything else

Writes profile.md (and profile.json) into --out; the inputs come from
bench_frames.py's cache (made there if missing).
"""

import collections
import json
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fgperf  # noqa: E402
import bench_frames  # noqa: E402

FRAME_MM = bench_frames.FRAME_MM

# (stage, substrings of a symbol). The table build wins wherever it is on
# the stack; otherwise the innermost frame that matches wins.
TABLE_BUILD = ("table build", ["DevelopTable::DevelopTable", "sample_latent_image_by_spacings"])
STAGES = [
    TABLE_BUILD,
    ("kinetics chain", ["simulate_latent_image"]),
    ("coverage", ["grid_coverage", "scanline_coverage", "raster_coverage", "raster_discs",
                  "count_points"]),
    ("exposure", ["LayerExposure", "ExposurePlane", "PlaneIntegrals", "plane_integrals"]),
    ("grains", ["PopulationGrains", "FastGrains", "develop_fast", "sample_poisson", "n4_needed",
                "PoissonTable", "DevelopTable::probability", "DevelopTable::interpolate",
                "DevelopCurve", "normal_quantile"]),
    ("pixel scale", ["PixelModel"]),
]


def classify(stack):
    """stack: [(symbol, dso)] leaf first. Returns the stage name."""
    stage, pats = TABLE_BUILD
    if any(p in frame_sym for frame_sym, _ in stack for p in pats):
        return stage
    for frame_sym, _ in stack:  # leaf first: the innermost match wins
        for stage, pats in STAGES[1:]:
            if any(p in frame_sym for p in pats):
                return stage
    syms = " ".join(s for s, _ in stack)
    dsos = " ".join(d for _, d in stack)
    if "render_negative" in syms or "TileRenderer" in syms:
        return "render, other"
    if "_dl_start" in syms or "dl_main" in syms or "_dl_relocate" in syms or "_dl_init" in syms:
        return "start-up (ld.so)"
    if any(k in dsos for k in ("OpenImageIO", "OpenColorIO", "OpenEXR", "libIex", "libImath",
                               "libz", "libdeflate", "libpng", "libjpeg")):
        return "read/colour/write"
    return "kernel, other"


def parse_script(text):
    """perf script output -> list of stacks [(symbol, dso)], leaf first."""
    stacks, cur = [], None
    for line in text.splitlines():
        if not line.strip():
            if cur is not None:
                stacks.append(cur)
            cur = None
            continue
        if not line.startswith("\t") and not line.startswith(" "):
            cur = []
            continue
        if cur is None:
            continue
        parts = line.strip().split(" ", 1)
        rest = parts[1] if len(parts) > 1 else ""
        dso = ""
        if rest.endswith(")") and " (" in rest:
            rest, dso = rest.rsplit(" (", 1)
            dso = dso[:-1]
        cur.append((rest, dso))
    if cur:
        stacks.append(cur)
    return stacks


def profile_case(binary, name, argv, freq, work):
    data = os.path.join(work, f"{name.replace('/', '_')}.data")
    out = os.path.join(work, "out.exr")
    stats = os.path.join(work, "stats.json")
    cmd = ["perf", "record", "-q", "-F", str(freq), "--call-graph", "dwarf,16384", "-o", data,
           "--", binary, *argv, "-o", out, "--stats", stats, "-q"]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env=fgperf.cli_env())
    wall = time.perf_counter() - t0
    with open(stats) as f:
        st = json.load(f)
    text = subprocess.run(["perf", "script", "-i", data, "-F", "comm,tid,ip,sym,dso"],
                          check=True, capture_output=True, text=True).stdout
    os.remove(data)
    stacks = parse_script(text)
    by_stage = collections.Counter(classify(s) for s in stacks)
    leaf = collections.Counter(s[0][0] if s else "?" for s in stacks)
    n = max(1, len(stacks))
    return {
        "case": name, "argv": argv, "samples": len(stacks), "wall_s_under_perf": wall,
        "stages": {k: v / n for k, v in by_stage.most_common()},
        "top_self": [(k, v / n) for k, v in leaf.most_common(12)],
        "grains": sum(l["grains"] for l in st["layers"]),
        "photons": sum(l["absorbed_photons"] for l in st["layers"]),
        "paths": sorted({l["path"] for l in st["layers"]}),
        "seconds": st["seconds"],
        "setup_s": sum(l["setup_seconds"] for l in st["layers"]),
    }


def main(argv=None):
    ap = bench_frames.frame_parser(__doc__)
    ap.add_argument("--freq", type=int, default=199, help="samples per second per thread")
    args = ap.parse_args(argv)
    binary = os.path.abspath(args.bin)
    os.makedirs(args.cache, exist_ok=True)
    fine = bench_frames.FINE_STOCK
    gh512 = bench_frames.gh_input(args.cache, 512, 389)
    gh4k = bench_frames.gh_input(args.cache, 4096, 3112)
    cases = [
        ("paper1x", [gh512, "--iscolorspace", "sRGB",
                     f"--filmgrain:stock=paper:width_mm={FRAME_MM / 4:.9g}"]),
        ("color/64", [gh4k, "--iscolorspace", "sRGB",
                      f"--filmgrain:stock=color-negative:width_mm={FRAME_MM}"
                      ":roi=1792,1361,512,389"]),
        ("color/16", [gh4k, "--iscolorspace", "sRGB",
                      f"--filmgrain:stock=color-negative:width_mm={FRAME_MM}"
                      ":roi=1536,1167,1024,778"]),
        ("fine/256", [gh4k, "--iscolorspace", "sRGB",
                      f"--filmgrain:stock={fine}:width_mm={FRAME_MM}:roi=1920,1458,256,195"]),
        ("exact/64", [gh4k, "--iscolorspace", "sRGB",
                      f"--filmgrain:stock=color-negative:width_mm={FRAME_MM}:engine=exact"
                      ":roi=1792,1361,256,194"]),
    ]
    t_all = time.perf_counter()
    results = []
    with tempfile.TemporaryDirectory() as work:
        for name, a in cases:
            print(f"{name}: perf record ...", flush=True)
            r = profile_case(binary, name, a, args.freq, work)
            print(f"  {r['samples']} samples; " + ", ".join(
                f"{k} {v * 100:.1f}%" for k, v in r["stages"].items()), flush=True)
            results.append(r)
    total = time.perf_counter() - t_all
    repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    stage_names = [s for s, _ in STAGES] + ["render, other", "read/colour/write",
                                            "start-up (ld.so)", "kernel, other"]
    L = ["# Where the time goes", "",
         f"Generated by `/usr/bin/python3 tools/perf/profile_frames.py --bin "
         f"{os.path.relpath(binary, repo)} --out {os.path.relpath(os.path.abspath(args.out), repo)}`"
         f" in {total / 60:.1f} min at commit {fgperf.git_describe(repo)}; "
         f"{fgperf.machine_note()}. Linux perf, {args.freq} samples/s per thread, DWARF call "
         "stacks; each sample is charged to the table build where that is on its stack (the "
         "chain runs inside it count as the table build), else to the innermost model "
         "function on its stack (the disc integrals inside the fast kernel count as exposure). "
         "Shares of CPU samples "
         "over all threads of one CLI run (read, render, EXR write).", "",
         "| stage | " + " | ".join(r["case"] for r in results) + " |",
         "| --- | " + " | ".join("---" for _ in results) + " |"]
    for s in stage_names:
        L.append(f"| {s} | " + " | ".join(f"{r['stages'].get(s, 0) * 100:.1f}%"
                                           for r in results) + " |")
    L.append("| samples | " + " | ".join(str(r["samples"]) for r in results) + " |")
    L.append("| grains | " + " | ".join(f"{r['grains']:.3g}" for r in results) + " |")
    L.append("| absorbed photons | " + " | ".join(f"{r['photons']:.3g}" for r in results) + " |")
    L.append("| table setup s (--stats) | " + " | ".join(f"{r['setup_s']:.2f}" for r in results)
             + " |")
    L.append("| simulate s (--stats) | " + " | ".join(
        f"{r['seconds']['simulate']:.2f}" for r in results) + " |")
    L.append("| paths | " + " | ".join("; ".join(r["paths"]) for r in results) + " |")
    L.append("")
    def shown(arg):  # inputs by name, the stock relative to the repository
        if arg.startswith("/"):
            return os.path.basename(arg)
        return arg.replace(os.path.dirname(fine) + "/", "tools/perf/stocks/")

    L.append("Cases: " + "; ".join(f"`{r['case']}` = `filmgrain "
                                   + " ".join(shown(x) for x in r["argv"]) + "`"
                                   for r in results) + ".")
    L.append("")
    for r in results:
        L.append(f"Top self time, {r['case']}: " + ", ".join(
            f"`{k.replace('(anonymous namespace)::', '').split('(')[0][:60]}` {v * 100:.1f}%"
            for k, v in r["top_self"][:8]) + ".")
        L.append("")
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "profile.md"), "w") as f:
        f.write("\n".join(L))
    with open(os.path.join(args.out, "profile.json"), "w") as f:
        json.dump({"results": results, "seconds": total, "machine": fgperf.machine_note()}, f,
                  indent=1)
    print("\n".join(L))
    return 0


if __name__ == "__main__":
    sys.exit(main())
