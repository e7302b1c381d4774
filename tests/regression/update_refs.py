#!/usr/bin/python3
"""Regenerates the regression references in ref/ from the current build.

Usage (from the repository root, after building):
    /usr/bin/python3 tests/regression/update_refs.py build/plugin/filmgrain [SCENE...]

Only after an *intended* change of the model, the stocks in stocks/ or the
scenes in scenes.py: look at the differences first (ctest -R regression
--output-on-failure; idiff writes <scene>_diff.exr into pytest's temporary
directory), and commit the new references with the change that explains
them. The references are small (<= 48x36, 168x16) half-float EXRs with zip compression:
a few KB each.
"""

import os
import shutil
import sys
import tempfile

from scenes import REF, SCENES, render


def main(argv):
    if len(argv) < 2 or argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(argv) >= 2 else 1
    fg_bin = argv[1]
    scenes = argv[2:] or sorted(SCENES)
    unknown = [s for s in scenes if s not in SCENES]
    if unknown:
        print(f"unknown scene(s): {', '.join(unknown)}; known: {', '.join(sorted(SCENES))}")
        return 1
    os.makedirs(REF, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            out = os.path.join(tmp, scene + ".exr")
            r = render(fg_bin, scene, tmp, out)
            if r.returncode != 0:
                print(f"{scene}: render failed:\n{r.stderr}")
                return 1
            dst = os.path.join(REF, scene + ".exr")
            shutil.copyfile(out, dst)
            print(f"{scene}: wrote {dst} ({os.path.getsize(dst)} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
