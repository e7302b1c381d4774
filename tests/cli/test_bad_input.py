"""Bad input that must never lose data (issue 5): truncated, corrupt,
empty and absurdly large images; special pixel values; broken colour
configs, stock files and modifiers; outputs that cannot or must not be
written. test_errors.py covers the first cases of each kind; this file adds
the rest. Every failing case must:
  - exit with status 1 and print exactly one "filmgrain: error:" line that
    names the problem (checked by key words), no crash, no hang;
  - write nothing: no output, no --stats, no --preview, no temporary file;
  - leave every input byte for byte as it was (hashed before and after).
"""

import hashlib
import json
import os
import struct
import subprocess
import threading
import zlib

import numpy as np
import pytest

from conftest import FAST, assert_nothing_written, clean_env, listing, read_json, write_image

# ---------------------------------------------------------------------------
# Running the CLI with its peak memory measured (os.wait4 gives the child's
# own rusage), under a deadline.

TIMEOUT_S = 120


class Result:
    def __init__(self, returncode, stdout, stderr, max_rss_kb):
        self.returncode, self.stdout, self.stderr = returncode, stdout, stderr
        self.max_rss_mb = max_rss_kb / 1024.0


def run_measured(fg_bin, *args, env=None, cwd=None):
    with open(os.devnull, "rb") as devnull:
        p = subprocess.Popen([fg_bin, *[str(a) for a in args]], stdin=devnull,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             env=env if env is not None else clean_env(), cwd=cwd)
    out = {}
    readers = [threading.Thread(target=lambda k=k, f=f: out.__setitem__(k, f.read()))
               for k, f in (("stdout", p.stdout), ("stderr", p.stderr))]
    for t in readers:
        t.start()
    timer = threading.Timer(TIMEOUT_S, p.kill)
    timer.start()
    try:
        _, status, usage = os.wait4(p.pid, 0)
    finally:
        timer.cancel()
    for t in readers:
        t.join()
    p.returncode = os.waitstatus_to_exitcode(status)
    return Result(p.returncode, out["stdout"].decode(errors="replace"),
                  out["stderr"].decode(errors="replace"), usage.ru_maxrss)


def tree_hashes(directory):
    """{relative path: sha256} of every file under directory."""
    hashes = {}
    for root, _, files in os.walk(directory):
        for name in files:
            path = os.path.join(root, name)
            if os.path.islink(path):
                hashes[os.path.relpath(path, directory)] = "link:" + os.readlink(path)
                continue
            with open(path, "rb") as f:
                hashes[os.path.relpath(path, directory)] = hashlib.sha256(f.read()).hexdigest()
    return hashes


def expect_refused(fg_bin, indir, outdir, args, words, max_rss_mb=None):
    """Runs the CLI with -o, --stats and --preview in outdir (unless args
    already name outputs) and checks the contract of this file."""
    before = tree_hashes(indir)
    if "-o" not in [str(a) for a in args]:
        args = [*args, "-o", outdir / "o.exr", "--stats", outdir / "s.json",
                "--preview", outdir / "p.png"]
    r = run_measured(fg_bin, *args)
    assert r.returncode == 1, (r.returncode, r.stderr)
    errors = [line for line in r.stderr.splitlines() if line.startswith("filmgrain: error:")]
    assert len(errors) == 1, r.stderr
    for w in words:
        assert w in errors[0], (w, r.stderr)
    for bad in ("Traceback", "terminate called", "Segmentation", "AddressSanitizer",
                "runtime error", "Aborted"):
        assert bad not in r.stderr, r.stderr
    if max_rss_mb is not None:
        assert r.max_rss_mb < max_rss_mb, f"peak memory {r.max_rss_mb:.0f} MB: it allocated"
    assert tree_hashes(indir) == before, "an input file was changed"
    assert_nothing_written(outdir)
    return r


def grey(value=0.18, width=16, height=12):
    return np.full((height, width, 3), value, np.float32)


# ---------------------------------------------------------------------------
# Crafting broken files.

def cut(path, nbytes):
    path.write_bytes(path.read_bytes()[:nbytes])
    return path


def overwrite(path, offset, data):
    b = bytearray(path.read_bytes())
    b[offset:offset + len(data)] = data
    path.write_bytes(bytes(b))
    return path


def tiff_set_size(path, width, height):
    """Rewrites the ImageWidth (256) and ImageLength (257) tags of a
    little-endian TIFF as LONGs."""
    data = bytearray(path.read_bytes())
    assert data[:2] == b"II"
    ifd = struct.unpack_from("<I", data, 4)[0]
    for i in range(struct.unpack_from("<H", data, ifd)[0]):
        off = ifd + 2 + 12 * i
        tag = struct.unpack_from("<H", data, off)[0]
        if tag in (256, 257):
            struct.pack_into("<HHII", data, off, tag, 4, 1, width if tag == 256 else height)
    path.write_bytes(bytes(data))
    return path


def png_set_size(path, width, height):
    """Rewrites the IHDR size of a PNG, with a correct CRC."""
    data = bytearray(path.read_bytes())
    i = data.index(b"IHDR")
    struct.pack_into(">II", data, i + 4, width, height)
    struct.pack_into(">I", data, i + 17, zlib.crc32(bytes(data[i:i + 17])) & 0xffffffff)
    path.write_bytes(bytes(data))
    return path


def exr_header_end(data):
    """Offset just past the header of a single-part scanline EXR."""
    i = 8  # magic and version
    while data[i] != 0:
        name_end = data.index(b"\0", i)
        type_end = data.index(b"\0", name_end + 1)
        size = struct.unpack_from("<i", data, type_end + 1)[0]
        i = type_end + 1 + 4 + size
    return i + 1


def exr_declaring(path, width, height):
    """Rewrites a small ZIP-compressed scanline EXR so that its header
    declares width x height pixels, with a complete line offset table whose
    entries all point at the one real chunk: OpenEXR opens it, and only a
    size check stops a reader from allocating width x height pixels."""
    data = bytearray(path.read_bytes())
    end = exr_header_end(data)
    for name in (b"dataWindow", b"displayWindow"):
        i = data.index(name + b"\0box2i\0") + len(name) + len(b"\0box2i\0") + 4
        struct.pack_into("<iiii", data, i, 0, 0, width - 1, height - 1)
    chunks = data[struct.unpack_from("<Q", data, end)[0]:]
    n = (height + 15) // 16  # ZIP: 16 scanlines per chunk
    table = struct.pack("<%dQ" % n, *([end + 8 * n] * n))
    path.write_bytes(bytes(data[:end]) + table + bytes(chunks))
    return path


def exr_corrupt_first_chunk(path):
    """Overwrites the compressed bytes of the first chunk of a ZIP EXR (a
    smooth image: its chunks really are compressed; incompressible ones are
    stored raw, where corruption is just other pixel values)."""
    data = bytearray(path.read_bytes())
    first = struct.unpack_from("<Q", data, exr_header_end(data))[0]
    size = struct.unpack_from("<i", data, first + 4)[0]
    data[first + 8:first + 8 + min(size, 16)] = b"\xff" * min(size, 16)
    path.write_bytes(bytes(data))
    return path


def exr_empty_window(path):
    data = bytearray(path.read_bytes())
    for name in (b"dataWindow", b"displayWindow"):
        i = data.index(name + b"\0box2i\0") + len(name) + len(b"\0box2i\0") + 4
        struct.pack_into("<iiii", data, i, 0, 0, -1, -1)
    path.write_bytes(bytes(data))
    return path


def text(path, content):
    path.write_text(content)
    return path


def noise(width=64, height=48):
    """Incompressible pixels: corrupting or cutting the middle of a
    compressed file then hits pixel data, not padding."""
    return np.random.default_rng(5).random((height, width, 3), dtype=np.float32)


def exr(d, name="in.exr", compression="zip", pixels=None):
    return write_image(d / name, grey() if pixels is None else pixels,
                       attrs={"compression": compression})


def png(d, name="in.png"):
    return write_image(d / name, (grey() * 255).astype(np.uint8), fmt="uint8")


def tif(d, name="in.tif", compression="none", pixels=None):
    return write_image(d / name, grey() if pixels is None else pixels,
                       attrs={"compression": compression})


def middle(path):
    return len(path.read_bytes()) // 2


# (name, make(indir) -> input path, words expected in the error)
IMAGE_CASES = [
    ("truncated_tiff", lambda d: cut(tif(d), middle(tif(d))), ["cannot read", "in.tif"]),
    ("truncated_tiff_zip",
     lambda d: cut(tif(d, compression="zip", pixels=noise()),
                   middle(tif(d, compression="zip", pixels=noise()))),
     ["cannot read", "in.tif"]),
    ("exr_cut_in_header", lambda d: cut(exr(d), 40), ["cannot read", "in.exr"]),
    ("png_cut_in_header", lambda d: cut(png(d), 20), ["cannot read", "in.png"]),
    ("tiff_cut_in_header", lambda d: cut(tif(d), 6), ["cannot read", "in.tif"]),
    ("empty_file", lambda d: cut(exr(d), 0), ["cannot read", "in.exr"]),
    ("text_named_exr", lambda d: text(d / "in.exr", "not an image\n"),
     ["cannot read", "in.exr"]),
    ("exr_bad_magic", lambda d: overwrite(exr(d), 0, b"\0\0\0\0"), ["cannot read", "in.exr"]),
    ("png_bad_magic", lambda d: overwrite(png(d), 1, b"XYZ"), ["cannot read", "in.png"]),
    ("exr_corrupt_data", lambda d: exr_corrupt_first_chunk(exr(d)),
     ["cannot read", "in.exr"]),
    ("png_corrupt_data", lambda d: overwrite(png(d), middle(png(d)), b"\xa5" * 16),
     ["cannot read", "in.png"]),
    ("tiff_corrupt_ifd", lambda d: overwrite(tif(d), 4, struct.pack("<I", 0x7ffffff0)),
     ["cannot read", "in.tif"]),
    ("tiff_zip_corrupt_data",
     lambda d: overwrite(tif(d, compression="zip"), 8, b"\x13\x37" * 40),
     ["cannot read", "in.tif"]),
    ("png_zero_width", lambda d: png_set_size(png(d), 0, 12), ["cannot read", "in.png"]),
    ("tiff_zero_width", lambda d: tiff_set_size(tif(d), 0, 12), ["in.tif"]),
    ("exr_empty_window", lambda d: exr_empty_window(exr(d)), ["in.exr"]),
]


@pytest.mark.parametrize("name,make,words", IMAGE_CASES, ids=[c[0] for c in IMAGE_CASES])
def test_broken_image(fg_bin, dirs, name, make, words):
    indir, outdir = dirs
    src = make(indir)
    expect_refused(fg_bin, indir, outdir, [src, f"--filmgrain:{FAST}"], words)


# Headers that declare absurd sizes: refused before anything is allocated
# (peak memory of the whole process well under what one float plane of the
# declared image would take). The CLI checks the header against its limits
# (docs/reference.md "Limits and guarantees"): 2^20 pixels a side, 2^28 pixels.
HUGE_CASES = [
    ("exr_1e6_square", lambda d: exr_declaring(exr(d), 1000000, 1000000)),
    ("exr_30000_square", lambda d: exr_declaring(exr(d), 30000, 30000)),
    ("tiff_1e6_square", lambda d: tiff_set_size(tif(d), 1000000, 1000000)),
    ("tiff_30000_square", lambda d: tiff_set_size(tif(d), 30000, 30000)),
    ("tiff_too_wide", lambda d: tiff_set_size(tif(d), 2000000, 1)),
    ("png_999999_square", lambda d: png_set_size(png(d), 999999, 999999)),
]


@pytest.mark.parametrize("name,make", HUGE_CASES, ids=[c[0] for c in HUGE_CASES])
def test_absurd_size_is_refused_before_allocating(fg_bin, dirs, name, make):
    indir, outdir = dirs
    src = make(indir)
    # The process itself (OIIO, OCIO, libraries) peaks near 150 MB here.
    r = expect_refused(fg_bin, indir, outdir, [src, f"--filmgrain:{FAST}"], [src.name],
                       max_rss_mb=1000)
    assert ("larger than filmgrain reads" in r.stderr
            or "exceeds \"limits:imagesize_MB\"" in r.stderr), r.stderr


def test_size_limit_names_the_limit(fg_bin, dirs):
    indir, outdir = dirs
    src = exr_declaring(exr(indir), 30000, 30000)
    r = expect_refused(fg_bin, indir, outdir, [src, f"--filmgrain:{FAST}"],
                       ["30000x30000", "1048576 pixels a side", "268435456 pixels",
                        "before reading"])
    assert r.max_rss_mb < 1000


def test_largest_side_within_limit_is_read(fg_bin, dirs):
    # A 2^20 x 1 image is within every limit: it is read and rendered (the
    # limit is not off by one; a 1-pixel-high 5 mm scan keeps it quick).
    # color-negative: a stock without development inhibitors.
    indir, outdir = dirs
    src = write_image(indir / "wide.exr", np.full((1, 1 << 20), 0.18, np.float32))
    before = tree_hashes(indir)
    r = run_measured(fg_bin, src, "--filmgrain:stock=color-negative:width_mm=5:scan=64x1",
                     "-o", outdir / "o.exr")
    assert r.returncode == 0, r.stderr
    assert tree_hashes(indir) == before
    # The default stock's inhibitors diffuse 20 um: on 4.8 nm input pixels
    # that blur reaches ~25000 pixels each way, a transform of 2.7e10
    # values: refused with the limit and the remedies named, nothing written.
    r = run_measured(fg_bin, src, "--filmgrain:width_mm=5:scan=64x1", "-o", outdir / "d.exr")
    assert r.returncode == 1
    for words in ("above the limit of", "inhibitor_diffusion_um", "coarser input"):
        assert words in r.stderr, r.stderr
    assert not (outdir / "d.exr").exists()


# ---------------------------------------------------------------------------
# Special pixel values (documented behaviour, not errors; MODEL.md 2): NaN
# and -Inf expose nothing, +Inf and values past the largest exposure the
# kinetics represent saturate (clamped to it), a negative layer value
# exposes nothing, a subnormal value is used as is. All are counted in
# --stats input.*_pixels.

def test_special_pixels_are_documented_and_counted(run, dirs):
    indir, outdir = dirs
    img = np.full((12, 16), 0.18, np.float32)
    specials = {(1, 1): np.nan, (2, 3): np.inf, (3, 5): -np.inf, (4, 7): -0.5,
                (5, 9): np.float32(1e-40), (6, 11): -np.float32(1e-40),
                (8, 13): np.float32(1e37)}
    for (y, x), v in specials.items():
        img[y, x] = v
    assert np.isclose(img[5, 9], 1e-40, rtol=1e-3, atol=0)  # a float32 subnormal
    # The same image with NaN, -Inf and the negatives at 0 and +Inf at
    # 1e30: it must render the same pixels (NaN, -Inf, negative: zero
    # exposure; +Inf, 1e30 and 1e37 all clamped to the same saturated
    # exposure; a subnormal is used as is, and exposes ~1e-40 of a grey: no
    # photon in practice).
    zeroed = img.copy()
    for (y, x) in specials:
        zeroed[y, x] = 0.0
    zeroed[2, 3] = np.float32(1e30)
    zeroed[8, 13] = np.float32(1e37)
    src = write_image(indir / "special.exr", img)
    ref = write_image(indir / "zeroed.exr", zeroed)
    before = tree_hashes(indir)
    r = run(src, "--filmgrain:stock=paper:" + FAST, "-o", outdir / "s.exr", "--stats",
            outdir / "s.json")
    assert r.returncode == 0, r.stderr
    assert "warning" in r.stderr and "NaN values" in r.stderr and "saturate" in r.stderr
    r = run(ref, "--filmgrain:stock=paper:" + FAST, "-o", outdir / "z.exr")
    assert r.returncode == 0, r.stderr
    stats = read_json(outdir / "s.json")["input"]
    assert stats["nonfinite_pixels"] == 3
    assert stats["nan_pixels"] == 1
    assert stats["saturated_pixels"] == 2  # +Inf and 1e37
    assert stats["negative_pixels"] == 2  # -0.5 and the negative subnormal
    assert stats["denormal_pixels"] == 2
    import OpenImageIO as oiio
    a = oiio.ImageBuf(str(outdir / "s.exr")).get_pixels(oiio.FLOAT)
    b = oiio.ImageBuf(str(outdir / "z.exr")).get_pixels(oiio.FLOAT)
    assert np.isfinite(a).all()
    assert (a == b).all()
    assert tree_hashes(indir) == before


def test_only_special_pixels(run, dirs):
    # A frame of nothing but NaN: a valid, all-fog negative, every pixel
    # counted, no crash.
    indir, outdir = dirs
    src = write_image(indir / "nan.exr", np.full((4, 4, 3), np.nan, np.float32))
    r = run(src, "--filmgrain:" + FAST, "-o", outdir / "o.exr", "--stats", outdir / "s.json")
    assert r.returncode == 0, r.stderr
    assert read_json(outdir / "s.json")["input"]["nonfinite_pixels"] == 16


# ---------------------------------------------------------------------------
# Colour configs.

CONFIG_CASES = [
    ("garbage_config", lambda d: text(d / "bad.ocio", "{{{ not: [yaml\n"),
     ["bad.ocio"]),
    ("empty_config", lambda d: text(d / "empty.ocio", ""),
     ["empty.ocio"]),
    ("config_is_a_directory", lambda d: (d / "cfg.ocio").mkdir() or d / "cfg.ocio",
     ["cfg.ocio"]),
]


@pytest.mark.parametrize("name,make,words", CONFIG_CASES, ids=[c[0] for c in CONFIG_CASES])
def test_broken_colour_config(fg_bin, dirs, name, make, words):
    indir, outdir = dirs
    cfg = make(indir)
    expect_refused(fg_bin, indir, outdir,
                   [exr(indir), "--colorconfig", cfg, f"--filmgrain:{FAST}"], words)


def test_broken_ocio_env(fg_bin, dirs):
    indir, outdir = dirs
    cfg = indir / "env.ocio"
    cfg.write_text("ocio_profile_version: 2\nroles: [\n")
    before = tree_hashes(indir)
    r = run_measured(fg_bin, exr(indir, "x.exr"), f"--filmgrain:{FAST}", "-o", outdir / "o.exr",
                     env=clean_env(OCIO=str(cfg)))
    assert r.returncode == 1 and "env.ocio" in r.stderr, r.stderr
    assert_nothing_written(outdir)
    assert tree_hashes(indir) == {**before, "x.exr": tree_hashes(indir)["x.exr"]}


# ---------------------------------------------------------------------------
# Stock files: malformed, unknown keys, wrong types, out of range,
# contradictory. Each message names the key (as a JSON path) or the file.

def population(**kw):
    return {"layers": [{"name": "Y", "populations": [kw]}]}


STOCK_CASES = [
    ("empty_file", "", ["stock.json", "not valid JSON"]),
    ("top_level_array", "[1, 2]", ["must be a JSON object", "array"]),
    ("top_level_null", "null", ["must be a JSON object"]),
    ("trailing_garbage", '{"name": "x"} xyz', ["not valid JSON"]),
    ("not_utf8", b'{"name": "\xff\xfe"}', ["stock.json"]),
    ("deeply_nested", "[" * 100000 + "]" * 100000, ["stock.json"]),
    ("deeply_nested_object", '{"layers": ' + "[" * 100000 + "]" * 100000 + "}",
     ["layers"]),
    ("unknown_population_key", population(diameter=3), ["unknown key", "populations[0].diameter"]),
    ("unknown_layer_key", {"layers": [{"name": "Y", "colour": 1}]},
     ["unknown key", "layers[0].colour"]),
    ("layers_not_array", {"layers": {"name": "Y"}}, ["layers must be an array"]),
    ("population_not_object", {"layers": [{"name": "Y", "populations": [3]}]},
     ["populations[0]", "object"]),
    ("sensitivity_two_numbers", {"layers": [{"name": "Y", "sensitivity": [1, 2]}]},
     ["sensitivity", "3 numbers"]),
    ("sensitivity_string", {"layers": [{"name": "Y", "sensitivity": [1, "2", 3]}]},
     ["sensitivity[1]", "number"]),
    ("name_not_string", {"name": 7}, ["name", "string"]),
    ("number_as_string", population(k_pair_per_s="1e7"), ["k_pair_per_s", "number"]),
    ("number_as_bool", {"max_density": True}, ["max_density", "number"]),
    ("grains_zero", population(grains_per_um2=0), ["grains_per_um2 = 0", "(0, 100]"]),
    ("grains_too_many", population(grains_per_um2=1000), ["grains_per_um2", "(0, 100]"]),
    ("diameter_overflow", '{"layers": [{"name": "Y", "populations": [{"diameter_um": 1e400}]}]}',
     ["stock.json"]),
    ("qe_above_one", population(quantum_efficiency=1.5), ["quantum_efficiency", "[0, 1]"]),
    ("rate_too_fast", population(k_loss_per_s=1e16), ["k_loss_per_s = 10000000000000000", "[0, 1000000000000000]"]),
    ("rate_negative", population(k_join_per_s=-1), ["k_join_per_s", "-1"]),
    ("sigma_too_wide", population(diameter_log_sigma=2), ["diameter_log_sigma", "1.5"]),
    ("exposure_zero", {"exposure_at_grey_lxs": 0}, ["exposure_at_grey_lxs = 0", "(0, 1000000]"]),
    ("max_density_too_high", {"max_density": 25}, ["max_density", "20"]),
    ("fog_tau_zero", {"fog_tau_s": 0}, ["fog_tau_s"]),
    # Contradictory: valid values that cannot go together.
    ("sensitivity_all_zero", {"layers": [{"name": "Y", "sensitivity": [0, 0, 0]}]},
     ["sensitivity is all zero"]),
    ("duplicate_layer_names", {"layers": [{"name": "Y"}, {"name": "Y"}]},
     ["layers[1].name", "repeats"]),
    ("no_layers", {"layers": []}, ["layers has 0 entries"]),
    ("too_many_layers", {"layers": [{"name": f"L{i}"} for i in range(17)]},
     ["layers has 17 entries"]),
    ("no_populations", {"layers": [{"name": "Y", "populations": []}]},
     ["populations has 0 entries"]),
    ("empty_layer_name", {"layers": [{"name": ""}]}, ["layers[0].name", "empty"]),
    ("layer_name_with_colon", {"layers": [{"name": "a:b"}]}, ["layers[0].name", "':'"]),
]


@pytest.mark.parametrize("name,text,words", STOCK_CASES, ids=[c[0] for c in STOCK_CASES])
def test_bad_stock(fg_bin, dirs, name, text, words):
    indir, outdir = dirs
    p = indir / "stock.json"
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text if isinstance(text, str) else json.dumps(text))
    expect_refused(fg_bin, indir, outdir, [exr(indir), f"--filmgrain:stock={p}:{FAST}"], words)


def test_stock_is_a_directory(fg_bin, dirs):
    indir, outdir = dirs
    (indir / "stockdir").mkdir()
    expect_refused(fg_bin, indir, outdir,
                   [exr(indir), f"--filmgrain:stock={indir / 'stockdir'}:{FAST}"],
                   ["stockdir"])


# ---------------------------------------------------------------------------
# Modifiers with bad values (beyond test_errors.py's exposure_stops=abc, seed=-1,
# scan=0x0 ...). Each names the modifier.

MODIFIER_CASES = [
    ("shutter_zero", "shutter_s=0", ["shutter", "(0, 1e7]"]),
    ("shutter_negative", "shutter_s=-1", ["shutter", "(0, 1e7]"]),
    ("shutter_divide_by_zero", "shutter_s=1/0", ["shutter_s=1/0", "division by zero"]),
    ("shutter_fraction_garbage", "shutter_s=1/x", ["shutter_s=1/x"]),
    ("shutter_too_long", "shutter_s=1e8", ["shutter", "(0, 1e7]"]),
    ("exposure_overflow", "exposure_stops=1e999", ["exposure_stops=1e999", "range"]),
    ("exposure_inf", "exposure_stops=inf", ["exposure_stops=inf"]),
    ("exposure_hex", "exposure_stops=0x10", ["exposure_stops=0x10"]),
    ("exposure_spaces", "exposure_stops= 1", ["exposure_stops= 1"]),
    ("width_zero", "width_mm=0", ["width_mm", "(0, 1e9]"]),
    ("width_huge", "width_mm=1e10", ["width_mm", "(0, 1e9]"]),
    ("seed_too_big", "seed=18446744073709551616", ["seed=18446744073709551616", "too large"]),
    ("seed_hex", "seed=0x10", ["seed=0x10"]),
    ("scan_too_wide", "scan=3000000000x1", ["scan=3000000000x1", "too large"]),
    ("scan_negative", "scan=-5", ["scan=-5"]),
    ("scan_no_width", "scan=x5", ["scan=x5", "width"]),
    ("roi_three_numbers", "roi=1,2,3", ["roi=1,2,3", "four numbers"]),
    ("roi_overflow", "roi=2147483647,0,2,2", ["roi=2147483647,0,2,2"]),
    ("tile_zero", "tile=0", ["tile=0", "at least 1"]),
    ("tile_huge", "tile=5000", ["tile=5000", "too large"]),
    ("engine_unknown", "engine=warp", ["engine=warp", "unknown engine"]),
    ("empty_modifier", ":", ["empty modifier"]),
    ("no_key", "=3", ["=3"]),
    ("control_bytes", "stock=\x01\x02", ["stock"]),
]


@pytest.mark.parametrize("name,mod,words", MODIFIER_CASES, ids=[c[0] for c in MODIFIER_CASES])
def test_bad_modifier(fg_bin, dirs, name, mod, words):
    indir, outdir = dirs
    # The frame width modifiers replace FAST's width_mm (a repeat is an error).
    mods = mod if mod.startswith("width_mm") else f"{FAST}:{mod}"
    expect_refused(fg_bin, indir, outdir, [exr(indir), f"--filmgrain:{mods}"], words)


def test_absurd_scan_is_refused_before_rendering(fg_bin, dirs):
    # A legal-looking but absurd output (2^31-1 pixels square: ~5e19 bytes
    # of floats) fails with a message, not an allocation crash.
    indir, outdir = dirs
    expect_refused(fg_bin, indir, outdir,
                   [exr(indir), f"--filmgrain:{FAST}:scan=2147483647x2147483647"], ["scan"],
                   max_rss_mb=2000)


# ---------------------------------------------------------------------------
# Outputs that cannot or must not be written.

def test_output_is_a_directory(fg_bin, dirs):
    indir, outdir = dirs
    (outdir / "o.exr").mkdir()
    before = tree_hashes(indir)
    r = run_measured(fg_bin, exr(indir), f"--filmgrain:{FAST}", "-o", outdir / "o.exr",
                     "--stats", outdir / "s.json")
    assert r.returncode == 1, r.stderr
    assert "o.exr" in r.stderr
    assert listing(outdir) == ["o.exr"] and listing(outdir / "o.exr") == []
    assert tree_hashes(indir) == {**before, "in.exr": tree_hashes(indir)["in.exr"]}


def test_output_on_a_read_only_filesystem(fg_bin, dirs):
    # /proc refuses new files even to root (the temp-dir permission test in
    # test_errors.py is skipped as root).
    indir, outdir = dirs
    expect_refused(fg_bin, indir, outdir,
                   [exr(indir), f"--filmgrain:{FAST}", "-o", "/proc/filmgrain-test.exr",
                    "--stats", outdir / "s.json"], ["cannot write", "/proc/filmgrain-test.exr"])


@pytest.mark.parametrize("make_link", [os.link, os.symlink], ids=["hard_link", "symlink"])
def test_output_link_to_input(fg_bin, dirs, make_link):
    indir, outdir = dirs
    src = exr(indir)
    make_link(src, indir / "link.exr")
    expect_refused(fg_bin, indir, outdir,
                   [src, f"--filmgrain:{FAST}", "-o", indir / "link.exr"], ["same file"])


@pytest.mark.parametrize("option", ["--stats", "--preview"])
def test_side_output_is_the_input(fg_bin, dirs, option):
    indir, outdir = dirs
    src = exr(indir) if option == "--stats" else png(indir)
    expect_refused(fg_bin, indir, outdir,
                   [src, f"--filmgrain:{FAST}", "-o", outdir / "o.exr", option, src],
                   ["same file"])


def test_stock_file_is_the_output(fg_bin, dirs):
    # The stock JSON is an input too: naming it as --stats must not
    # overwrite it.
    indir, outdir = dirs
    stock = indir / "stock.json"
    stock.write_text(json.dumps({"name": "mine"}))
    before = stock.read_bytes()
    r = run_measured(fg_bin, exr(indir), f"--filmgrain:stock={stock}:{FAST}", "-o",
                     outdir / "o.exr", "--stats", stock)
    assert stock.read_bytes() == before, "the stock file was overwritten"
    assert r.returncode == 1, r.stderr
    assert_nothing_written(outdir)


@pytest.mark.parametrize("via_env", [False, True], ids=["colorconfig", "OCIO_env"])
def test_ocio_config_is_the_output(fg_bin, dirs, via_env):
    # The OCIO config is an input too (--colorconfig, else $OCIO).
    from conftest import minimal_ocio_config
    indir, outdir = dirs
    cfg = text(indir / "cfg.ocio", minimal_ocio_config("scene_linear_test"))
    src = exr(indir)
    before = tree_hashes(indir)
    args = [src, "--iscolorspace", "scene_linear_test", f"--filmgrain:{FAST}",
            "-o", outdir / "o.exr", "--stats", cfg]
    if via_env:
        r = run_measured(fg_bin, *args, env=clean_env(OCIO=str(cfg)))
    else:
        r = run_measured(fg_bin, *args[:1], "--colorconfig", cfg, *args[1:])
    assert r.returncode == 1, r.stderr
    assert "same file" in r.stderr, r.stderr
    assert tree_hashes(indir) == before
    assert_nothing_written(outdir)
