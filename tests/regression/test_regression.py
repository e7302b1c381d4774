"""Regression: render each scene of scenes.py and compare it with its
reference in ref/ using idiff.

Thresholds (idiff exits 0 pass, 1 warn, 2 fail, 4 file error):
  The renders are deterministic (every random value is a hash of the seed
  and a grain's identity; independent of threads and tiles), so on the
  machine that made the references they match bit for bit. The thresholds
  only absorb what may legitimately differ elsewhere (another compiler, libm
  or CPU):
  -fail 0.004      one half-float step at densities in [4, 8) is 2^-8 =
                   0.0039 (finer below 4); a last-bit float difference can
                   round to the neighbouring half. Anything larger is a real
                   change of at least one grain.
  -failpercent 0.1 grain outcomes are discrete (photon counts, development):
                   a last-bit difference in a rate can, very rarely, flip one
                   grain and move the few pixels it covers. 0.1% is 1 pixel
                   of a 40x30 image; a changed model, seed mapping or
                   geometry moves far more.
  -hardfail 1.0    even a flipped grain seldom moves a pixel by a full unit
                   of density; a larger jump in any pixel means something
                   structural (tile seams, ROI or scan mapping) broke.
  -warn 0          report any difference at all (warnings still pass).

To regenerate the references after an intended change of the model, see
update_refs.py.
"""

import os
import subprocess

import pytest

from scenes import REF, SCENES, render

IDIFF_THRESHOLDS = ["-fail", "0.004", "-failpercent", "0.1", "-hardfail", "1.0",
                    "-warn", "0"]


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_scene(scene, tmp_path):
    fg_bin = os.environ.get("FILMGRAIN_BIN")
    assert fg_bin, "FILMGRAIN_BIN is not set (run through ctest)"
    idiff = os.environ.get("FILMGRAIN_IDIFF", "idiff")
    ref = os.path.join(REF, scene + ".exr")
    assert os.path.exists(ref), f"no reference {ref}: run update_refs.py"
    out = tmp_path / (scene + ".exr")
    r = render(fg_bin, scene, str(tmp_path), str(out))
    assert r.returncode == 0, r.stderr
    d = subprocess.run([idiff, *IDIFF_THRESHOLDS, "-abs", "-od", "-o",
                        str(tmp_path / (scene + "_diff.exr")), str(out), ref],
                       capture_output=True, text=True)
    assert d.returncode in (0, 1), \
        f"{scene}: differs from {ref} (idiff exit {d.returncode}):\n{d.stdout}{d.stderr}"
