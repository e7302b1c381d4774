"""--filmgrain:output=: ADX code values and the regrain positive, end to end
through the CLI (the transforms' own tests: plugin/src/output_transform_test.cpp)."""

import json

import numpy as np

from conftest import FAST, Exr, read_json, write_image


def layers(exr, names=("R", "G", "B")):
    return np.stack([exr.channels[n] for n in names], axis=-1)


def test_adx_is_the_density_above_dmin_in_code_values(run, tmp_path):
    """The same render as density and as ADX10/ADX16 (MODEL.md 11): code value
    = offset + scale k (M (D - D-min)), stored / max code; M the stock's
    Annex C map (vision3-500t: 5219's), k ADX's gains, D-min per layer
    (Status M), all in the metadata."""
    plate = write_image(tmp_path / "plate.exr",
                        np.full((24, 32, 3), 0.18, np.float32) * np.linspace(0.05, 8, 32)[None, :, None])
    base = f"--filmgrain:{FAST}:seed=5"
    assert run(plate, base, "-o", tmp_path / "d.exr").returncode == 0
    density = layers(Exr(tmp_path / "d.exr")).astype(np.float64)
    stock = json.loads(run("--print-stock", "vision3-500t").stdout)
    m = np.array(stock["printing_density"]["status_m_to_apd"]["matrix"])
    for kind, offset, scale, top in (("adx10", 95, 500, 1023), ("adx16", 1520, 8000, 65535)):
        out = tmp_path / f"{kind}.exr"
        r = run(plate, f"{base}:output={kind}", "-o", out, "--stats", tmp_path / f"{kind}.json")
        assert r.returncode == 0, r.stderr
        exr = Exr(out)
        assert exr.attr("filmgrain:output") == kind
        assert exr.attr("filmgrain:colorspace") == kind.upper()
        assert exr.attr("filmgrain:printing_density") == "annex_c"
        assert exr.attr("filmgrain:adx_timing") == "off"
        assert read_json(tmp_path / f"{kind}.json")["output"] == kind
        def rgb(attr):
            parts = dict(part.split() for part in exr.attr(attr).split(", "))
            return np.array([float(parts[c]) for c in "RGB"])
        dmin, k = rgb("filmgrain:adx_dmin"), rgb("filmgrain:adx_gains")
        assert k.tolist() == [1.0, 0.92, 0.95]
        # APD D-min is the map applied to the Status M one.
        offset_apd = np.array(stock["printing_density"]["status_m_to_apd"]["offset"])
        assert np.allclose(rgb("filmgrain:apd_dmin"), m @ dmin + offset_apd, atol=2e-6)
        cdd = k * ((density - dmin) @ m.T)
        expect = np.clip(np.round(offset + scale * cdd), 0, top) / top
        # dmin is printed to 6 digits: a code value may round the other way.
        assert np.abs(layers(exr) - expect).max() <= 1.0 / top + 1e-7
        assert np.mean(layers(exr) == expect.astype(np.float32)) > 0.95


def test_regrain_keeps_the_input_mean(run, tmp_path):
    """A uniform grey patch through output=regrain: the mean is the input's
    within 4 standard errors of the mean (the per-pixel sd over sqrt(n),
    neighbouring pixels being correlated: n counted as pixels / 9)."""
    grey = np.full((128, 128, 3), 0.18, np.float32)
    plate = write_image(tmp_path / "grey.exr", grey)
    out = tmp_path / "rg.exr"
    r = run(plate, "--filmgrain:width_mm=6:seed=2:output=regrain", "-o", out)
    assert r.returncode == 0, r.stderr
    exr = Exr(out)
    assert exr.attr("filmgrain:output") == "regrain"
    v = layers(exr).reshape(-1, 3)
    assert np.all(np.isfinite(v))
    se = v.std(axis=0) / np.sqrt(v.shape[0] / 9)
    assert np.all(np.abs(v.mean(axis=0) - 0.18) < 4 * se + 1e-6), (v.mean(axis=0), se)
    assert np.all(v.std(axis=0) > 0)  # grain, not the input back


def test_output_errors(run, tmp_path):
    plate = write_image(tmp_path / "p.exr", np.full((24, 32, 3), 0.18, np.float32))
    r = run(plate, f"--filmgrain:{FAST}:output=adx10", "--ocolorspace", "ACEScg", "-o",
            tmp_path / "o.exr")
    assert r.returncode == 1 and "--ocolorspace ACEScg applies to output=regrain" in r.stderr
    r = run(plate, f"--filmgrain:{FAST}:output=regrain:scan=64", "-o", tmp_path / "o.exr")
    assert r.returncode == 1 and "needs the scan at the input's size" in r.stderr, r.stderr
    r = run(plate, f"--filmgrain:{FAST}:output=regrain", "--ocolorspace", "nonesuch", "-o",
            tmp_path / "o.exr")
    assert r.returncode == 1 and "nonesuch" in r.stderr, r.stderr
    r = run(plate, f"--filmgrain:{FAST}:output=print", "-o", tmp_path / "o.exr")
    assert r.returncode == 1 and "output=print" in r.stderr, r.stderr


def test_regrain_sequence_reuses_its_curves_and_equals_single_frames(run, tmp_path):
    """The expected curves are built once per run (they do not depend on the
    frame); every frame still equals the same frame rendered alone."""
    plate = write_image(tmp_path / "still.exr", np.full((24, 32, 3), 0.18, np.float32))
    mods = f"--filmgrain:{FAST}:seed=3:output=regrain"
    r = run(plate, "--frames", "1-2", mods, "-o", tmp_path / "rg.#.exr")
    assert r.returncode == 0, r.stderr
    for f in (1, 2):
        r = run(plate, f"{mods}:frame={f}", "-o", tmp_path / f"alone{f}.exr")
        assert r.returncode == 0, r.stderr
        assert np.array_equal(layers(Exr(tmp_path / f"rg.{f:04d}.exr")),
                              layers(Exr(tmp_path / f"alone{f}.exr")))
