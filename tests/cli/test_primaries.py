"""Colour primaries: an OpenEXR file's `chromaticities` attribute says what
its RGB means, and the input is converted from it to the config's
scene_linear (issue 45, part 2).

A plate of four colour patches in linear Rec.709 is written as it is, and
as the same colours in XYZ (white E), in ACES AP0 and in made-up
primaries, each file with its chromaticities. The pixels of those files
are computed here, with NumPy, from published matrices (the Rec.709 and
ST 2065-1 NPMs) and the Bradford adaptation, independently of the C++
code."""

import numpy as np
import OpenImageIO as oiio
import pytest

from conftest import Exr, assert_nothing_written, minimal_ocio_config, read_json

# A three-layer stock that renders 64x48 pixels in about half a second.
PATCH_FAST = "width_mm=0.5:stock=color-negative"
W, H = 64, 48
# Linear Rec.709 colours of the 2x2 patches (32x24 pixels each, 250 um x
# 190 um of film at width_mm=0.5: some 10^4 of color-negative's 3-3.5 um
# grains per patch).
PATCHES = [(0.40, 0.12, 0.06), (0.08, 0.30, 0.10), (0.06, 0.10, 0.35), (0.18, 0.18, 0.18)]
MARGIN = 3  # pixels left out at each patch's edge

REC709_XY = [0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290]
XYZ_XY = [1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1 / 3, 1 / 3]
AP0_XY = [0.7347, 0.2653, 0.0, 1.0, 0.0001, -0.0770, 0.32168, 0.33767]
MADE_UP_XY = [0.70, 0.29, 0.17, 0.78, 0.13, 0.03, 0.3324, 0.3474]

# Linear Rec.709 -> XYZ (D65), the published derivation from BT.709's
# primaries and D65 (IEC 61966-2-1 rounds it to 4 digits).
REC709_TO_XYZ = np.array([[0.4123907993, 0.3575843394, 0.1804807884],
                          [0.2126390059, 0.7151686788, 0.0721923154],
                          [0.0193308187, 0.1191947798, 0.9505321522]])
# ACES AP0 -> XYZ as published in SMPTE ST 2065-1.
AP0_TO_XYZ = np.array([[0.9525523959, 0.0, 0.0000936786],
                       [0.3439664498, 0.7281660966, -0.0721325464],
                       [0.0, 0.0, 1.0088251844]])
# Bradford's cone response matrix (Lam 1985).
BRADFORD = np.array([[0.8951, 0.2664, -0.1614],
                     [-0.7502, 1.7135, 0.0367],
                     [0.0389, -0.0685, 1.0296]])


def npm(xy):
    """RGB -> XYZ of chromaticities (SMPTE RP 177)."""
    p = np.array([[xy[0], xy[2], xy[4]],
                  [xy[1], xy[3], xy[5]],
                  [1 - xy[0] - xy[1], 1 - xy[2] - xy[3], 1 - xy[4] - xy[5]]])
    white = np.array([xy[6] / xy[7], 1.0, (1 - xy[6] - xy[7]) / xy[7]])
    return p * np.linalg.solve(p, white)


def bradford(white_from, white_to):
    a, b = BRADFORD @ white_from, BRADFORD @ white_to
    return np.linalg.inv(BRADFORD) @ np.diag(b / a) @ BRADFORD


def rec709_to(to_xyz):
    """Linear Rec.709 -> the RGB whose RGB -> XYZ is `to_xyz`, D65 adapted to
    its white."""
    return np.linalg.inv(to_xyz) @ bradford(REC709_TO_XYZ.sum(1), to_xyz.sum(1)) @ REC709_TO_XYZ


SPACES = {
    "xyz": (XYZ_XY, npm(XYZ_XY)),
    "ap0": (AP0_XY, AP0_TO_XYZ),
    "made_up": (MADE_UP_XY, npm(MADE_UP_XY)),
}


def plate():
    img = np.zeros((H, W, 3))
    for i, c in enumerate(PATCHES):
        row, col = divmod(i, 2)
        img[row * 24:(row + 1) * 24, col * 32:(col + 1) * 32] = c
    return img


def write_exr(path, pixels, chromaticities=None):
    spec = oiio.ImageSpec(W, H, 3, "float")
    if chromaticities is not None:
        spec.attribute("chromaticities", oiio.TypeDesc("float[8]"), list(chromaticities))
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(np.ascontiguousarray(pixels, dtype=np.float32)), out.geterror()
    out.close()
    return path


def patch_means(exr):
    """{layer: [mean density of each patch's interior]}."""
    out = {}
    for name, px in exr.channels.items():
        means = []
        for i in range(len(PATCHES)):
            row, col = divmod(i, 2)
            sub = px[row * 24 + MARGIN:(row + 1) * 24 - MARGIN,
                     col * 32 + MARGIN:(col + 1) * 32 - MARGIN]
            means.append(float(sub.mean()))
        out[name] = means
    return out


def render(run, src, out, *extra):
    stats = out.with_suffix(".json")
    r = run(src, *extra, f"--filmgrain:{PATCH_FAST}", "-o", out, "--stats", stats)
    assert r.returncode == 0, r.stderr
    return r, Exr(out), read_json(stats)


@pytest.fixture
def rec709(run, tmp_path):
    """The Rec.709 plate (with its chromaticities) and its render."""
    src = write_exr(tmp_path / "rec709.exr", plate(), REC709_XY)
    r, exr, stats = render(run, src, tmp_path / "rec709_out.exr")
    return src, exr, stats


# The tolerance, 0.005 D: every render here has the same seed, so it draws
# the same grains with the same uniforms; the grain noise of a patch mean
# (0.02-0.03 D for color-negative's 18x26-pixel interiors, measured) is
# common to the renders and cancels in their difference. What is left
# comes from the exposures differing: by ~1e-6 (float) for a correct
# conversion, which moved no grain when measured (differences exactly 0).
# At color-negative's gamma of ~0.6, 0.005 D is a 2% error in one layer's
# exposure (0.6 * log10(1.02) = 0.0052): any conversion error above ~2%
# fails, and a plate read in the wrong primaries is off by 0.1 D or more
# (checked below, so the tolerance is seen to matter).
TOLERANCE_D = 0.005


@pytest.mark.parametrize("space", sorted(SPACES))
def test_primaries_render_the_same_patches(run, tmp_path, rec709, space):
    _, ref, _ = rec709
    xy, to_xyz = SPACES[space]
    pixels = plate() @ rec709_to(to_xyz).T
    src = write_exr(tmp_path / f"{space}.exr", pixels, xy)
    r, exr, stats = render(run, src, tmp_path / f"{space}_out.exr")
    assert "input colour space: the file's chromaticities (" in r.stderr, r.stderr
    assert "converted to scene_linear 'lin_rec709' through 'ACES2065-1'" in r.stderr
    assert stats["input"]["colorspace"] == "chromaticities"
    assert stats["input"]["chromaticities"] == pytest.approx(xy, abs=1e-7)

    want, got = patch_means(ref), patch_means(exr)
    worst = max(abs(g - w) for n in want for g, w in zip(got[n], want[n]))
    assert worst <= TOLERANCE_D, (space, want, got)

    # The same pixels read as Rec.709 (the chromaticities ignored) are far
    # off: the tolerance can tell.
    _, wrong, _ = render(run, src, tmp_path / f"{space}_wrong.exr",
                         "--iscolorspace", "scene_linear")
    off = patch_means(wrong)
    assert max(abs(g - w) for n in want for g, w in zip(off[n], want[n])) > 0.1


@pytest.mark.parametrize("white", [(0.3127, 0.3290), (0.31271, 0.32902)],
                         ids=["d65", "d65_5_digits"])
def test_rec709_chromaticities_change_nothing(run, tmp_path, rec709, white):
    src709, exr709, stats709 = rec709
    xy = REC709_XY[:6] + list(white)
    tagged = write_exr(tmp_path / "tagged.exr", plate(), xy)
    plain = write_exr(tmp_path / "plain.exr", plate())
    r_tagged, tagged_out, s_tagged = render(run, tagged, tmp_path / "tagged_out.exr")
    r_plain, plain_out, s_plain = render(run, plain, tmp_path / "plain_out.exr")
    for n in plain_out.names:
        assert np.array_equal(tagged_out.channels[n], plain_out.channels[n]), n
    assert "input colour space: scene_linear (the file's chromaticities (" in r_tagged.stderr
    assert "are those of scene_linear 'lin_rec709': nothing to convert" in r_tagged.stderr
    assert s_tagged["input"]["colorspace"] == "scene_linear"
    assert s_tagged["input"]["chromaticities"] == pytest.approx(xy, abs=1e-7)
    # Without the attribute: as before, OIIO's "Linear" for an EXR.
    assert "input colour space: Linear (the file's oiio:ColorSpace" in r_plain.stderr
    assert s_plain["input"]["colorspace"] == "Linear"
    assert s_plain["input"]["chromaticities"] is None


def test_iscolorspace_wins_over_chromaticities(run, tmp_path, rec709):
    _, ref, _ = rec709
    pixels = plate() @ rec709_to(npm(XYZ_XY)).T
    tagged = write_exr(tmp_path / "xyz.exr", pixels, XYZ_XY)
    untagged = write_exr(tmp_path / "xyz_untagged.exr", pixels)
    r, forced, stats = render(run, tagged, tmp_path / "forced.exr",
                              "--iscolorspace", "scene_linear")
    assert "input colour space: scene_linear (--iscolorspace; the file's chromaticities " \
           "(red 1 0, green 0 1, blue 0 0, white 0.3333333 0.3333333) differ from " \
           "scene_linear's and are not used" in r.stderr, r.stderr
    assert stats["input"]["colorspace"] == "scene_linear"
    assert stats["input"]["chromaticities"] is None
    _, plain, _ = render(run, untagged, tmp_path / "plain.exr")
    for n in plain.names:
        assert np.array_equal(forced.channels[n], plain.channels[n]), n
    # ... and it is not what the chromaticities give.
    want, got = patch_means(ref), patch_means(forced)
    assert max(abs(g - w) for n in want for g, w in zip(got[n], want[n])) > 0.1

    # A colour space whose primaries the file's are: nothing to say.
    src = write_exr(tmp_path / "ap0.exr", plate() @ rec709_to(AP0_TO_XYZ).T, AP0_XY)
    r, _, stats = render(run, src, tmp_path / "ap0_named.exr", "--iscolorspace", "ACES2065-1")
    assert "input colour space: ACES2065-1 (--iscolorspace; OCIO config" in r.stderr, r.stderr
    assert stats["input"]["chromaticities"] is None


def test_config_without_aces_interchange(run, tmp_path):
    cfg = tmp_path / "no_aces.ocio"
    cfg.write_text(minimal_ocio_config("linear"))  # no aces_interchange, no ACES2065-1
    src = write_exr(tmp_path / "ap0.exr", plate() @ rec709_to(AP0_TO_XYZ).T, AP0_XY)
    outdir = tmp_path / "out"
    outdir.mkdir()
    r = run(src, "--colorconfig", cfg, f"--filmgrain:{PATCH_FAST}", "-o", outdir / "o.exr",
            "--stats", outdir / "s.json")
    assert r.returncode == 1, r.stderr
    for words in ("error: input '", "ap0.exr' gives its RGB by chromaticities (red 0.7347",
                  "has neither an 'aces_interchange' role nor a colour space named "
                  "'ACES2065-1'", str(cfg), "--iscolorspace NAME"):
        assert words in r.stderr, r.stderr
    assert_nothing_written(outdir)
    # As it says: naming the colour space renders.
    r = run(src, "--colorconfig", cfg, "--iscolorspace", "linear", f"--filmgrain:{PATCH_FAST}",
            "-o", outdir / "o.exr")
    assert r.returncode == 0, r.stderr
    assert "the file's chromaticities (red 0.7347 0.2653, green 0 1, blue 0.0001 -0.077, " \
           "white 0.32168 0.33767) are not used" in r.stderr, r.stderr
    # A file without chromaticities is read as before with that config.
    plain = write_exr(tmp_path / "plain.exr", plate())
    r = run(plain, "--colorconfig", cfg, f"--filmgrain:{PATCH_FAST}", "-o", outdir / "p.exr")
    assert r.returncode == 0, r.stderr
