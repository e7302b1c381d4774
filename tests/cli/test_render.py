"""Successful renders: EXR channels, pixel types, metadata, preview, stats,
the wedge, NaN/Inf input, colour spaces."""

import json
import math
import os

import numpy as np
import OpenImageIO as oiio
import pytest

from conftest import (FAST, HEIGHT, WIDTH, Exr, clean_env, listing, minimal_ocio_config,
                      read_json, rgb_ramp, write_image)

STATS_KEYS = {"engine", "seconds", "version", "stock", "seed", "exposure_stops",
              "shutter_s", "width_mm", "scan", "roi", "input", "layers"}


@pytest.fixture
def ramp_exr(tmp_path):
    return write_image(tmp_path / "ramp.exr", rgb_ramp())


@pytest.mark.parametrize("dtype,oiio_type", [("float", "float"), ("half", "half"),
                                             (None, "float")])
def test_normal_run(run, tmp_path, ramp_exr, dtype, oiio_type):
    out, stats, preview = tmp_path / "out.exr", tmp_path / "s.json", tmp_path / "p.png"
    # The default stock, vision3-500t: these 15.6 um pixels at pixel scale.
    args = [ramp_exr, f"--filmgrain:{FAST}:seed=42:exposure_stops=0.5:shutter_s=1/100",
            "-o", out, "--stats", stats, "--preview", preview]
    if dtype:
        args += ["-d", dtype]
    r = run(*args)
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stderr
    assert "input colour space: Linear" in r.stderr  # EXR's oiio:ColorSpace

    exr = Exr(out)
    stock = json.loads(run("--print-stock", "vision3-500t").stdout)
    layer_names = [l["name"] for l in stock["layers"]]
    assert sorted(exr.names) == sorted(layer_names)
    assert exr.spec.format == oiio.TypeDesc(oiio_type)
    assert (exr.spec.width, exr.spec.height) == (WIDTH, HEIGHT)
    assert (exr.spec.full_width, exr.spec.full_height) == (WIDTH, HEIGHT)
    for c in exr.channels.values():
        assert np.isfinite(c).all()
        assert (c >= stock["base_density"] - 1e-3).all()

    # Metadata contract.
    assert exr.attr("filmgrain:quantity") == \
        "negative density: -log10(transmittance) + base density"
    assert json.loads(exr.attr("filmgrain:stock")) == stock
    assert exr.attr("filmgrain:stock_name") == "vision3-500t"
    assert exr.attr("filmgrain:seed") == "42"
    assert exr.attr("filmgrain:exposure_stops") == pytest.approx(0.5)
    assert exr.attr("filmgrain:shutter_s") == pytest.approx(0.01)
    assert exr.attr("filmgrain:width_mm") == pytest.approx(0.5)
    assert exr.attr("filmgrain:engine") == "auto"
    assert exr.attr("filmgrain:version") == \
        run("--version").stdout.split()[1]

    # Preview: 8-bit RGB PNG of the same size.
    p = oiio.ImageBuf(str(preview))
    assert p.spec().format == oiio.TypeDesc("uint8")
    assert (p.spec().width, p.spec().height, p.spec().nchannels) == (WIDTH, HEIGHT, 3)
    px = p.get_pixels(oiio.UINT8)
    assert px.max() > 0

    # Stats contract.
    s = read_json(stats)
    assert STATS_KEYS <= set(s)
    assert set(s["seconds"]) == {"read", "color", "simulate", "write", "total"}
    assert set(s["scan"]) == {"width", "height", "pitch_x_um", "pitch_y_um"}
    assert set(s["roi"]) == {"x", "y", "width", "height"}
    assert set(s["input"]) == {"file", "colorspace", "chromaticities", "pixels_read",
                               "nonfinite_pixels", "nan_pixels", "saturated_pixels",
                               "negative_pixels", "denormal_pixels"}
    assert s["input"]["chromaticities"] is None  # the ramp has none
    assert s["engine"] == "auto" and s["stock"] == "vision3-500t" and s["seed"] == 42
    for layer in s["layers"]:  # which path ran, why, and its error bound
        assert "kinetics=" in layer["path"] and layer["reason"]
        assert 0 <= layer["error_estimate"] <= 0.002
    assert s["scan"]["width"] == WIDTH and s["scan"]["height"] == HEIGHT
    assert s["scan"]["pitch_x_um"] == pytest.approx(500.0 / WIDTH)
    assert s["roi"] == {"x": 0, "y": 0, "width": WIDTH, "height": HEIGHT}
    assert s["input"]["file"] == str(ramp_exr)
    assert s["input"]["pixels_read"] == WIDTH * HEIGHT
    assert s["input"]["nonfinite_pixels"] == 0
    assert [l["name"] for l in s["layers"]] == layer_names
    for l in s["layers"]:
        assert set(l) == {"name", "grains", "developed", "absorbed_photons",
                          "kinetics_events", "decided_early", "mean_density", "path",
                          "reason", "error_estimate", "setup_seconds",
                          "estimated_seconds"}
        if "scale=pixel" in l["path"]:  # drawn from the pixel statistics: no grains
            assert l["grains"] == 0 and l["developed"] == 0
        else:
            assert l["grains"] > 0 and 0 < l["developed"] <= l["grains"]
        assert l["mean_density"] == pytest.approx(float(exr.channels[l["name"]].mean()),
                                                  abs=2e-3)

    # Nothing else in the directory: no temporary file left.
    assert listing(tmp_path) == sorted(["ramp.exr", "out.exr", "s.json", "p.png"])


@pytest.mark.parametrize("stock,word", [("paper", "photons=disc"), ("t-max-100", "scale=pixel")])
def test_stats_path_is_modifiers(run, tmp_path, ramp_exr, stock, word):
    """A layer's grain path in --stats speaks the modifiers' words: joined
    with ':', it is accepted as --filmgrain modifiers and plans the same
    path (it once said exposure=disc, the name of a different modifier)."""
    def layer_path(extra, name):
        stats = tmp_path / f"{name}.json"
        r = run(ramp_exr, f"--filmgrain:{FAST}:stock={stock}{extra}", "-o",
                tmp_path / f"{name}.exr", "--stats", stats)
        assert r.returncode == 0, (extra, r.stderr)
        return read_json(stats)["layers"][0]["path"]

    chosen = layer_path("", "auto")
    assert "exposure=" not in chosen and word in chosen, chosen
    assert layer_path(":" + chosen.replace(" ", ":"), "pasted") == chosen


def test_renamed_modifiers_still_read_with_a_warning(run, tmp_path, ramp_exr):
    """exposure=, shutter= and static= (now exposure_stops=, shutter_s=,
    static_grain=) render the same pixels and say what they are now;
    --list-options maps them."""
    def render(mods, name):
        out = tmp_path / f"{name}.exr"
        r = run(ramp_exr, f"--filmgrain:{FAST}:frame=2:{mods}", "-o", out)
        assert r.returncode == 0, r.stderr
        return Exr(out), r.stderr

    now, quiet = render("exposure_stops=0.5:shutter_s=1/100:static_grain=1", "now")
    old, said = render("exposure=0.5:shutter=1/100:static=1", "old")
    assert "is now" not in quiet
    for old_key, key in [("exposure", "exposure_stops"), ("shutter", "shutter_s"),
                         ("static", "static_grain")]:
        assert f"warning: {old_key}= is now {key}=" in said, said
    for name in now.names:
        assert np.array_equal(now.channels[name], old.channels[name]), name
    table = json.loads(run("--list-options").stdout)
    assert table["renamed_modifiers"]["--filmgrain"] == {
        "exposure": "exposure_stops", "shutter": "shutter_s", "static": "static_grain"}
    both = run(ramp_exr, f"--filmgrain:{FAST}:exposure=1:exposure_stops=1", "-o",
               tmp_path / "both.exr")
    assert both.returncode != 0 and "given twice" in both.stderr, both.stderr


def test_same_seed_same_pixels_other_seed_other_pixels(run, tmp_path, ramp_exr):
    outs = []
    for i, seed in enumerate([1, 1, 2]):
        out = tmp_path / f"o{i}.exr"
        r = run(ramp_exr, f"--filmgrain:{FAST}:seed={seed}", "-o", out, "--threads", i + 1)
        assert r.returncode == 0, r.stderr
        outs.append(Exr(out).channels["G"])
    assert (outs[0] == outs[1]).all()
    assert not (outs[0] == outs[2]).all()


def test_one_layer_stock_and_grey_preview(run, tmp_path, ramp_exr):
    out, preview = tmp_path / "o.exr", tmp_path / "p.png"
    r = run(ramp_exr, f"--filmgrain:stock=paper:{FAST}", "-o", out, "--preview", preview)
    assert r.returncode == 0, r.stderr
    assert Exr(out).names == ["Y"]
    # The preview goes negative -> ADX (R = G = B for one layer) -> ACES ->
    # the config's sRGB view: neutral grey in an RGB PNG.
    png = oiio.ImageBuf(str(preview))
    assert png.spec().nchannels == 3
    p = png.get_pixels(oiio.UINT8).astype(int)
    assert np.abs(p[:, :, 0] - p[:, :, 1]).max() <= 1 and np.abs(p[:, :, 2] - p[:, :, 1]).max() <= 1


def test_scan_and_roi(run, tmp_path, ramp_exr):
    full, part = tmp_path / "full.exr", tmp_path / "part.exr"
    r = run(ramp_exr, f"--filmgrain:{FAST}:scan=64", "-o", full)
    assert r.returncode == 0, r.stderr
    f = Exr(full)
    assert (f.spec.width, f.spec.height) == (64, 48)  # height from the aspect
    r = run(ramp_exr, f"--filmgrain:{FAST}:scan=64:roi=8,4,20,10", "-o", part,
            "--stats", tmp_path / "s.json")
    assert r.returncode == 0, r.stderr
    p = Exr(part)
    assert (p.spec.x, p.spec.y, p.spec.width, p.spec.height) == (8, 4, 20, 10)
    assert (p.spec.full_width, p.spec.full_height) == (64, 48)
    assert "of the 64x48 scan" in r.stderr
    # The ROI's pixels are those of the full render (determinism).
    for name in f.names:
        assert (p.channels[name] == f.channels[name][4:14, 8:28]).all()
    assert read_json(tmp_path / "s.json")["roi"] == {"x": 8, "y": 4, "width": 20,
                                                      "height": 10}


def test_wedge_density_increases(run, tmp_path):
    out, stats = tmp_path / "wedge.exr", tmp_path / "s.json"
    # A 0.5 mm frame keeps it fast; the paper stock has one layer, Y.
    r = run("--wedge", "--filmgrain:stock=paper:width_mm=0.5", "-o", out,
            "--preview", tmp_path / "wedge.png", "--stats", stats)
    assert r.returncode == 0, r.stderr
    exr = Exr(out)
    assert (exr.spec.width, exr.spec.height) == (1008, 96)  # WedgeSpec{}
    y = exr.channels["Y"]
    steps = [float(y[:, i * 48:(i + 1) * 48].mean()) for i in range(21)]
    assert steps[-1] > steps[0] + 0.5, steps
    # Broadly monotonic: the brighter half is denser than the darker half.
    assert np.mean(steps[11:]) > np.mean(steps[:10])
    s = read_json(stats)
    assert s["input"]["file"] == "wedge"
    assert s["input"]["colorspace"] == "scene_linear"


def test_nan_and_inf_pixels(run, tmp_path):
    img = rgb_ramp()
    img[3, 4, 0] = np.nan
    img[10, 20, :] = np.inf
    img[15, 7, 2] = -np.inf
    img[1, 1, 1] = -0.5  # negative: counted separately
    src = write_image(tmp_path / "nan.exr", img)
    out, stats = tmp_path / "o.exr", tmp_path / "s.json"
    r = run(src, f"--filmgrain:{FAST}", "-o", out, "--stats", stats)
    assert r.returncode == 0, r.stderr
    assert "warning" in r.stderr and "NaN values" in r.stderr and "1 of the" in r.stderr
    assert "saturate" in r.stderr
    assert "negative" in r.stderr
    s = read_json(stats)
    assert s["input"]["nonfinite_pixels"] == 3
    assert s["input"]["nan_pixels"] == 1
    assert s["input"]["saturated_pixels"] == 1  # the +Inf pixel
    assert s["input"]["negative_pixels"] == 1
    for c in Exr(out).channels.values():
        assert np.isfinite(c).all()
    # -q silences the warning.
    r = run(src, f"--filmgrain:{FAST}", "-o", tmp_path / "q.exr", "-q")
    assert r.returncode == 0 and r.stderr == ""


def mean_density(run, tmp_path, src, *extra, name="o"):
    stats = tmp_path / f"{name}.json"
    r = run(src, *extra, f"--filmgrain:{FAST}", "-o", tmp_path / f"{name}.exr",
            "--stats", stats)
    assert r.returncode == 0, r.stderr
    return r, read_json(stats)


def test_iscolorspace_changes_the_result(run, tmp_path, ramp_exr):
    r1, s1 = mean_density(run, tmp_path, ramp_exr, "--iscolorspace", "scene_linear",
                          name="lin")
    r2, s2 = mean_density(run, tmp_path, ramp_exr, "--iscolorspace", "sRGB", name="srgb")
    assert "input colour space: scene_linear (--iscolorspace" in r1.stderr
    assert "input colour space: sRGB (--iscolorspace" in r2.stderr
    assert s1["input"]["colorspace"] == "scene_linear"
    assert s2["input"]["colorspace"] == "sRGB"
    # sRGB decoding darkens mid-tones: less exposure, less density.
    d1 = [l["mean_density"] for l in s1["layers"]]
    d2 = [l["mean_density"] for l in s2["layers"]]
    assert all(b < a for a, b in zip(d1, d2)), (d1, d2)
    lin = Exr(tmp_path / "lin.exr").channels["R"]
    srgb = Exr(tmp_path / "srgb.exr").channels["R"]
    assert not (lin == srgb).all()


def test_png_input_is_read_as_srgb(run, tmp_path):
    img = (rgb_ramp() * 255).round().astype(np.uint8)
    png = write_image(tmp_path / "in.png", img, fmt="uint8")
    r, auto = mean_density(run, tmp_path, png, name="auto")
    assert "input colour space: sRGB (the file's oiio:ColorSpace" in r.stderr
    assert auto["input"]["colorspace"] == "sRGB"
    _, srgb = mean_density(run, tmp_path, png, "--iscolorspace", "sRGB", name="srgb")
    _, lin = mean_density(run, tmp_path, png, "--iscolorspace", "scene_linear", name="lin")
    assert (Exr(tmp_path / "auto.exr").channels["G"]
            == Exr(tmp_path / "srgb.exr").channels["G"]).all()
    assert not (Exr(tmp_path / "auto.exr").channels["G"]
                == Exr(tmp_path / "lin.exr").channels["G"]).all()


def test_grey_input(run, tmp_path):
    grey = rgb_ramp()[:, :, 0]
    src = write_image(tmp_path / "grey.exr", grey)
    rgb = write_image(tmp_path / "rgb.exr", np.repeat(grey[:, :, None], 3, axis=2))
    for name, path in (("g", src), ("c", rgb)):
        r = run(path, f"--filmgrain:{FAST}", "-o", tmp_path / f"{name}.exr")
        assert r.returncode == 0, r.stderr
    g, c = Exr(tmp_path / "g.exr"), Exr(tmp_path / "c.exr")
    for n in g.names:
        assert (g.channels[n] == c.channels[n]).all()
    # Through a real conversion (sRGB) the grey input is expanded to RGB.
    r = run(src, "--iscolorspace", "sRGB", f"--filmgrain:{FAST}", "-o", tmp_path / "s.exr")
    assert r.returncode == 0, r.stderr


def test_ocio_env_is_used(run, tmp_path, ramp_exr):
    # Only a $OCIO config defines "acescg_test": using it proves $OCIO is read.
    cfg = tmp_path / "env.ocio"
    cfg.write_text(minimal_ocio_config("acescg_test"))
    r = run(ramp_exr, "--iscolorspace", "acescg_test", f"--filmgrain:{FAST}",
            "-o", tmp_path / "o.exr", env=clean_env(OCIO=str(cfg)))
    assert r.returncode == 0, r.stderr
    assert "$OCIO" in r.stderr
    # --colorconfig wins over $OCIO.
    r = run(ramp_exr, "--colorconfig", tmp_path / "nope.ocio", f"--filmgrain:{FAST}",
            "-o", tmp_path / "p.exr", env=clean_env(OCIO=str(cfg)))
    assert r.returncode == 1 and "nope.ocio" in r.stderr


def test_compression_modifier_and_progress(run, tmp_path, ramp_exr):
    out = tmp_path / "o.exr"
    r = run(ramp_exr, f"--filmgrain:{FAST}:tile=8", "-o:compression=zips", out,
            "--progress", "--threads", "1")
    assert r.returncode == 0, r.stderr
    assert Exr(out).attr("compression") == "zips"
    assert "100%" in r.stderr
    # Without --progress (stderr is not a terminal): no progress line.
    r = run(ramp_exr, f"--filmgrain:{FAST}", "-o", tmp_path / "p.exr")
    assert "%" not in r.stderr


def overscan_plate(path, width=72, height=56, margin=8):
    """A plate with overscan: a (width + 2 margin) x (height + 2 margin) data
    window around a width x height display window at (0, 0)."""
    spec = oiio.ImageSpec(width + 2 * margin, height + 2 * margin, 3, "float")
    spec.x, spec.y = -margin, -margin
    spec.full_x, spec.full_y, spec.full_width, spec.full_height = 0, 0, width, height
    pixels = rgb_ramp(width + 2 * margin, height + 2 * margin)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(pixels), out.geterror()
    out.close()
    return pixels


def test_overscan_is_rendered_as_film_and_keeps_both_windows(run, dirs):
    """An EXR whose data window reaches beyond its display window keeps both:
    the overscan is film too (issue: a 288x288 plate with 16 px overscan came
    out 256x256). A roi reaching into it is a crop of the whole render."""
    indir, outdir = dirs
    overscan_plate(indir / "plate.exr")
    r = run(indir / "plate.exr", f"--filmgrain:{FAST}", "-o", outdir / "neg.exr")
    assert r.returncode == 0, r.stderr
    exr = Exr(outdir / "neg.exr")
    s = exr.spec
    assert (s.x, s.y, s.width, s.height) == (-8, -8, 88, 72)
    assert (s.full_x, s.full_y, s.full_width, s.full_height) == (0, 0, 72, 56)
    whole = np.stack([exr.channels[n] for n in ("R", "G", "B")])
    # The overscan holds developed film, not zeros: its densities look like
    # the display window's beside it.
    assert np.all(whole[:, :, :8].mean(axis=(1, 2)) > 0.5 * whole[:, :, 8:16].mean(axis=(1, 2)))
    r = run(indir / "plate.exr", f"--filmgrain:{FAST}:roi=-8,-8,20,12", "-o", outdir / "roi.exr")
    assert r.returncode == 0, r.stderr
    roi = Exr(outdir / "roi.exr")
    assert (roi.spec.x, roi.spec.y, roi.spec.width, roi.spec.height) == (-8, -8, 20, 12)
    part = np.stack([roi.channels[n] for n in ("R", "G", "B")])
    assert np.array_equal(part, whole[:, 0:12, 0:20])
    # Twice the scan: twice the overscan, in whole scan pixels.
    r = run(indir / "plate.exr", f"--filmgrain:{FAST}:scan=144", "-o", outdir / "big.exr")
    assert r.returncode == 0, r.stderr
    s = Exr(outdir / "big.exr").spec
    assert (s.x, s.y, s.width, s.height, s.full_width, s.full_height) == (-16, -16, 176, 144,
                                                                          144, 112)
    # A scan that cuts a scan pixel rounds the overscan outward (MODEL.md
    # 2; tests/cli/test_windows.py), and a roi beyond it is an error.
    r = run(indir / "plate.exr", f"--filmgrain:{FAST}:scan=100", "-o", outdir / "odd.exr")
    assert r.returncode == 0, r.stderr
    s = Exr(outdir / "odd.exr").spec
    assert (s.x, s.y, s.width, s.height) == (-12, -12, 124, 102)
    r = run(indir / "plate.exr", f"--filmgrain:{FAST}:roi=-9,0,4,4", "-o", outdir / "bad.exr")
    assert r.returncode == 1 and "with its overscan" in r.stderr, r.stderr
    assert sorted(os.listdir(outdir)) == ["big.exr", "neg.exr", "odd.exr", "roi.exr"]


def test_tables_kept_on_disk_for_the_next_process(run, tmp_path):
    """The P(develop | N) tables one run builds are read by the next
    (FILMGRAIN_CACHE_DIR): the same bytes out, the same statistics; a
    damaged cache file is ignored and written again; "off" keeps none."""
    def pixel_bytes(path):
        e = Exr(path)
        return b"".join(e.channels[n].tobytes() for n in e.names)

    def files(tables):
        return {t: (t.stat().st_ino, t.stat().st_mtime_ns, t.stat().st_size) for t in tables}

    cache = tmp_path / "cache"
    env = clean_env(FILMGRAIN_CACHE_DIR=str(cache))
    args = ["--wedge", "--filmgrain:stock=paper:kinetics=table:scan=240x24"]
    r = run(*args, "-o", tmp_path / "w0.exr", "--stats", tmp_path / "w0.json", env=env)
    assert r.returncode == 0, r.stderr
    tables = sorted((cache / "tables").glob("table-*.bin"))
    assert tables, sorted(cache.rglob("*"))
    assert not list((cache / "tables").glob("*.tmp-*"))
    written = files(tables)
    originals = {t: t.read_bytes() for t in tables}
    # The next process reads them (a build would write its file again).
    r = run(*args, "-o", tmp_path / "w1.exr", "--stats", tmp_path / "w1.json", env=env)
    assert r.returncode == 0, r.stderr
    assert files(tables) == written
    assert pixel_bytes(tmp_path / "w0.exr") == pixel_bytes(tmp_path / "w1.exr")
    reasons = [[l["reason"] for l in read_json(tmp_path / f"w{i}.json")["layers"]]
               for i in range(2)]
    assert reasons[0] == reasons[1]
    # Damaged (one byte changed, or cut in half): ignored, rebuilt (the same
    # pixels), written whole again.
    damages = (lambda b: b[: len(b) // 2] + bytes([b[len(b) // 2] ^ 1]) + b[len(b) // 2 + 1:],
               lambda b: b[: len(b) // 2])
    for i, damage in enumerate(damages):
        for t in tables:
            t.write_bytes(damage(t.read_bytes()))
        out = tmp_path / f"d{i}.exr"
        r = run(*args, "-o", out, env=env)
        assert r.returncode == 0, r.stderr
        assert pixel_bytes(out) == pixel_bytes(tmp_path / "w0.exr")
        assert {t: t.read_bytes() for t in tables} == originals
    # off: nothing kept.
    off = tmp_path / "off"
    r = run(*args, "-o", tmp_path / "w3.exr",
            env=clean_env(FILMGRAIN_CACHE_DIR="off", XDG_CACHE_HOME=str(off)))
    assert r.returncode == 0, r.stderr
    assert not off.exists()


def test_pixel_models_kept_on_disk_for_the_next_process(run, tmp_path):
    """A layer's pixel model (its pixel statistics, seconds of a frame's
    setup) is read by the next process as the tables are: the same pixels,
    the file untouched; a damaged file is ignored and written again."""
    def pixel_bytes(path):
        e = Exr(path)
        return b"".join(e.channels[n].tobytes() for n in e.names)

    cache = tmp_path / "cache"
    env = clean_env(FILMGRAIN_CACHE_DIR=str(cache))
    args = ["--wedge", "--filmgrain:scale=pixel:scan=240x24"]
    r = run(*args, "-o", tmp_path / "p0.exr", env=env)
    assert r.returncode == 0, r.stderr
    models = sorted((cache / "pixel-models").glob("pixel-model-*.bin"))
    assert len(models) == 3, sorted(cache.rglob("*"))  # one a layer of vision3-500t
    assert not list((cache / "pixel-models").glob("*.tmp-*"))
    originals = {m: m.read_bytes() for m in models}
    stamps = {m: (m.stat().st_ino, m.stat().st_mtime_ns) for m in models}
    r = run(*args, "-o", tmp_path / "p1.exr", env=env)
    assert r.returncode == 0, r.stderr
    assert {m: (m.stat().st_ino, m.stat().st_mtime_ns) for m in models} == stamps
    assert pixel_bytes(tmp_path / "p1.exr") == pixel_bytes(tmp_path / "p0.exr")
    for m in models:
        b = m.read_bytes()
        m.write_bytes(b[: len(b) // 2] + bytes([b[len(b) // 2] ^ 1]) + b[len(b) // 2 + 1:])
    r = run(*args, "-o", tmp_path / "p2.exr", env=env)
    assert r.returncode == 0, r.stderr
    assert pixel_bytes(tmp_path / "p2.exr") == pixel_bytes(tmp_path / "p0.exr")
    assert {m: m.read_bytes() for m in models} == originals
