#!/usr/bin/env python3
"""Writes stocks/no-remjet.json: vision3-500t without its rem-jet.

`no-remjet` is the fitted `vision3-500t` (stocks/vision3-500t.json: its
grains, dye clouds, latent-image rates, inhibitors, scatter and
processing, unchanged) on a base whose anti-halation backing has been
removed (CineStill 800T is widely said to be VISION3 500T without its
rem-jet). Only the
halation changes (MODEL.md 9): the base's rear face is bare (`rear_face`
"bare": air behind it), so the light it reflects back is no longer
absorbed, and every layer returns it through the `base` kernel
(docs/model.md, "Halation from the base": Fresnel reflection below the
critical angle, total internal reflection above it, a bright ring at
2 t tan(theta_c) = 229 um in a glow that fades as r^-4; the base is
vision3-500t's, 125 um of index 1.48, our choice). The strengths are a
choice of look, not published figures: red 0.25, green 0.06, blue 0.01 of
the layer's light (the red layer lies nearest the base; the yellow filter
under the blue layer keeps blue light from the base).

The quantum efficiencies stay the fitted emulsion's, so on a uniform patch
each layer gets (1 + its halation) times the light (MODEL.md 9) and
measures faster than 500T's: red by log2(1.25 / 1.02) = 0.29 stop, green
by log2(1.06 / 1.004) = 0.08 stop (vision3-500t's own residual halation
is 0.02 / 0.004 / 0: docs/stocks/README.md).

Usage (from the repository root):
  tools/look/make_no_remjet.py           write stocks/no-remjet.json
  tools/look/make_no_remjet.py --check   exit 1 if the file is not what
                                         this script writes (a test runs it)
"""
import argparse
import json
import os
import sys

HALATION = {"R": 0.25, "G": 0.06, "B": 0.01}
HALATION_KERNEL = "base"
REAR_FACE = "bare"

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def no_remjet(vision3_500t):
    stock = json.loads(json.dumps(vision3_500t))  # a deep copy, keys in order
    stock["name"] = "no-remjet"
    stock["description"] = (
        "vision3-500t (fitted to Kodak's published figures for VISION3 500T 5219: its grains, "
        "dye clouds, rates, inhibitors and scatter) on a base without its anti-halation "
        "rem-jet backing, which is what CineStill 800T is widely said to be: strong red halation, weaker green, "
        "almost no blue (the red layer lies nearest the base), returned by the bare base: a bright "
        "ring at its critical angle in a soft glow (MODEL.md 9; docs/model.md, 'Halation from the "
        "base'). "
        "The halation strengths are a choice of look, not published figures; with them the "
        "red layer measures 0.29 stop faster than 500T's, the green 0.08. Written by "
        "tools/look/make_no_remjet.py.")
    stock["rear_face"] = REAR_FACE  # the base's thickness and index stay vision3-500t's
    for layer in stock["layers"]:
        layer["halation"] = HALATION[layer["name"]]
        layer["halation_radius_um"] = 0.0  # the base kernel's size is the base's
        layer["halation_kernel"] = HALATION_KERNEL
    return stock


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--check", action="store_true",
                    help="compare with stocks/no-remjet.json instead of writing it")
    a = ap.parse_args()
    with open(os.path.join(ROOT, "stocks", "vision3-500t.json")) as f:
        text = json.dumps(no_remjet(json.load(f)), indent=2) + "\n"
    path = os.path.join(ROOT, "stocks", "no-remjet.json")
    if a.check:
        with open(path) as f:
            if f.read() != text:
                print(f"{path} is not what {sys.argv[0]} writes from stocks/vision3-500t.json: "
                      "run it", file=sys.stderr)
                return 1
        print(f"{path}: as derived from stocks/vision3-500t.json")
        return 0
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)
    print("wrote", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
