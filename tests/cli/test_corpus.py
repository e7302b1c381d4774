"""A corpus of OpenEXR layouts as pipelines write them, and damaged
(fuzzed) copies of them (issue 45, tests): every file renders or fails with
a clear error, never a crash or a hang, and leaves no file behind on
failure. The corpus is made here (the public OpenEXR sample images are not
reachable from CI): scanline and tiled, mipmapped, every compression,
multi-part and multi-view, luminance and luminance/chroma, grey with alpha,
display windows larger and smaller than the data window, odd origins and
pixel types; the damaged copies flip, drop or repeat bytes of them with a
fixed seed."""

import os
import random

import numpy as np
import OpenImageIO as oiio
import pytest

from conftest import listing

QUICK = "--filmgrain:stock=paper:width_mm=0.3:scan=32"
W, H = 40, 30


def spec_of(channels, fmt="float", **attrs):
    spec = oiio.ImageSpec(W, H, len(channels), fmt)
    spec.channelnames = tuple(channels)
    for k, v in attrs.items():
        if isinstance(v, tuple) and k == "multiView":
            spec.attribute(k, oiio.TypeDesc(f"string[{len(v)}]"), v)
        else:
            spec.attribute(k, v)
    return spec


def pixels(spec, value=0.18):
    rng = np.random.default_rng(7)
    return (value * (1 + 0.2 * rng.random((spec.height, spec.width, spec.nchannels)))).astype(
        np.float32)


def write(path, spec, mip=False):
    if mip:  # a tiled MIP-mapped texture, as maketx writes it
        buf = oiio.ImageBuf(spec)
        buf.set_pixels(oiio.ROI(), pixels(spec))
        config = oiio.ImageSpec(spec)
        assert oiio.ImageBufAlgo.make_texture(oiio.MakeTxTexture, buf, str(path), config), \
            oiio.geterror()
        return
    out = oiio.ImageOutput.create(str(path))
    assert out, oiio.geterror()
    assert out.open(str(path), spec, "Create"), out.geterror()
    assert out.write_image(pixels(spec)), out.geterror()
    out.close()


def write_parts(path, specs):
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), tuple(specs)), out.geterror()
    for i, spec in enumerate(specs):
        if i:
            assert out.open(str(path), spec, "AppendSubimage"), out.geterror()
        assert out.write_image(pixels(spec)), out.geterror()
    out.close()


def layouts(d):
    """(file, should render) for every layout of the corpus."""
    files = []

    def add(name, spec, ok=True, mip=False):
        write(d / name, spec, mip)
        files.append((d / name, ok))

    add("scanline_float.exr", spec_of(["R", "G", "B"]))
    add("scanline_half_rgba.exr", spec_of(["R", "G", "B", "A"], "half"))
    for c in ("none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab"):
        add(f"compression_{c}.exr", spec_of(["R", "G", "B"], "half", compression=c))
    tiled = spec_of(["R", "G", "B"])
    tiled.tile_width, tiled.tile_height = 16, 16
    add("tiled.exr", tiled)
    mip = spec_of(["R", "G", "B"], "half")
    mip.tile_width, mip.tile_height = 16, 16
    add("mipmapped.exr", mip, mip=True)
    add("luminance.exr", spec_of(["Y"]))
    add("grey_alpha.exr", spec_of(["Y", "A"]))
    add("luminance_chroma.exr", spec_of(["Y", "RY", "BY"]), ok=False)
    add("two_channels.exr", spec_of(["R", "G"]), ok=False)
    add("views.exr", spec_of(["R", "G", "B", "right.R", "right.G", "right.B"],
                             multiView=("left", "right")))
    add("aov_only.exr", spec_of(["Z", "N.x", "N.y", "N.z"]), ok=False)
    ids = spec_of(["R", "G", "B", "id"], "float")
    ids.channelformats = (oiio.FLOAT, oiio.FLOAT, oiio.FLOAT, oiio.UINT)
    add("uint_id_and_rgb.exr", ids)
    crop = spec_of(["R", "G", "B"])
    crop.x, crop.y, crop.full_x, crop.full_y, crop.full_width, crop.full_height = 5, 4, 0, 0, 64, 48
    add("data_inside_display.exr", crop)
    over = spec_of(["R", "G", "B"])
    over.x, over.y, over.full_x, over.full_y, over.full_width, over.full_height = -3, -2, 0, 0, 34, 26
    add("overscan.exr", over)
    odd = spec_of(["R", "G", "B"])
    odd.x, odd.y, odd.full_x, odd.full_y, odd.full_width, odd.full_height = -1000, 77, -1000, 77, W, H
    add("odd_origin.exr", odd)
    one = oiio.ImageSpec(1, 1, 3, "float")
    add("one_pixel.exr", one)
    wide = spec_of(["R", "G", "B"], "half")
    wide.full_width, wide.full_height = 2101364, H
    add("huge_display_window.exr", wide, ok=False)
    write_parts(d / "multipart_depth_first.exr",
                [spec_of(["Z"], name="depth"), spec_of(["R", "G", "B"], name="beauty")])
    files.append((d / "multipart_depth_first.exr", True))
    return files


def run_one(run, path, outdir):
    """Renders `path`; returns the exit status after checking that it did
    not crash or hang and left either exactly the output or nothing."""
    out = outdir / "o.exr"
    r = run(path, QUICK, "-o", out, timeout=60)
    assert r.returncode in (0, 1), f"{path.name}: exit {r.returncode}: {r.stderr[-500:]}"
    if r.returncode == 0:
        assert listing(outdir) == ["o.exr"], path.name
        os.remove(out)
    else:
        assert r.stderr.strip().splitlines()[-1].startswith("filmgrain: error:"), r.stderr
        assert listing(outdir) == [], path.name
    return r.returncode


def test_every_layout_renders_or_fails_clearly(run, dirs):
    indir, outdir = dirs
    for path, ok in layouts(indir):
        assert (run_one(run, path, outdir) == 0) == ok, path.name


def test_damaged_files_never_crash_hang_or_leave_files(run, dirs):
    """96 damaged copies of eight layouts: bytes flipped (1 to 16 at random
    places), the file cut short, a block of it repeated. Fixed seed."""
    indir, outdir = dirs
    sources = [p for p, _ in layouts(indir)]
    rng = random.Random(45)
    picks = [s for s in sources if s.name in (
        "scanline_float.exr", "compression_piz.exr", "compression_dwaa.exr", "tiled.exr",
        "mipmapped.exr", "views.exr", "overscan.exr", "multipart_depth_first.exr")]
    assert len(picks) == 8
    damaged = indir / "damaged"
    damaged.mkdir()
    n = 0
    for src in picks:
        data = src.read_bytes()
        for k in range(12):
            b = bytearray(data)
            kind = k % 3
            if kind == 0:
                for _ in range(rng.randint(1, 16)):
                    i = rng.randrange(len(b))
                    b[i] ^= 1 << rng.randrange(8)
            elif kind == 1:
                b = b[:rng.randrange(8, len(b))]
            else:
                i = rng.randrange(len(b))
                j = min(len(b), i + rng.randint(1, 256))
                b[i:i] = b[i:j]
            path = damaged / f"{src.stem}_{k}.exr"
            path.write_bytes(bytes(b))
            run_one(run, path, outdir)
            n += 1
    assert n == 96
