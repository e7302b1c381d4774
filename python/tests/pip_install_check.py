"""package.pip_install: `pip install .` works on this machine, the
installed module renders what the CLI renders, and it installs the
`filmgrain` CLI that filmgrain-farm runs.

Steps (each timed and printed):
  1. a fresh venv: python3 -m venv --system-site-packages WORK/venv
     (Debian's numpy and OpenImageIO visible, as python/README.md says);
  2. WORK/venv/bin/pip install SOURCE: scikit-build-core from PyPI (build
     isolation), a full build of the module and the static core;
  3. from WORK (not the source tree, so that nothing but the installed
     package can be imported), the installed module renders a small scene;
     its density must be byte-identical to the CLI's (FILMGRAIN_BIN) on the
     same scene; the extension must not need any libfilmgrain_* library;
  4. the installed CLI (WORK/venv/bin/filmgrain) renders the same scene
     byte-identically and needs no libfilmgrain_* library either;
  5. the installed filmgrain-farm, with no FILMGRAIN_BIN and a PATH without
     the venv, finds that CLI beside itself and renders the wedge.

    pip_install_check.py --source DIR --work DIR [--python PYTHON]

Exit status 0 on success. WORK is removed on success and kept on failure.
"""

import argparse
import os
import shutil
import subprocess
import sys
import time

RENDER_CHECK = r"""
import json, os, subprocess, sys
import numpy as np
import OpenImageIO as oiio
import filmgrain

venv = os.path.realpath(sys.prefix)
assert os.path.realpath(filmgrain.__file__).startswith(venv + os.sep), filmgrain.__file__
assert filmgrain.stocks(), "no presets"

# The scene of python/tests (64x48, structure in x, y and colour).
x = np.linspace(0.0, 1.0, 64)[None, :]
y = np.linspace(0.0, 1.0, 48)[:, None]
pixels = np.stack([0.004 * 500.0 ** x + 0 * y, 0.18 + 0.5 * y * x,
                   0.05 + 1.5 * (1 - y) ** 2 + 0 * x], axis=-1).astype(np.float32)
spec = oiio.ImageSpec(64, 48, 3, oiio.FLOAT)
out = oiio.ImageOutput.create("scene.exr")
assert out.open("scene.exr", spec) and out.write_image(pixels), oiio.geterror()
out.close()
negative = filmgrain.render(pixels, stock="color-negative", seed=12, frame=3, width_mm=0.5,
                            roi=(4, 4, 50, 40))
# The build tree's CLI, then the one pip installed beside this interpreter.
for cli_bin in (os.environ["FILMGRAIN_BIN"], os.path.join(venv, "bin", "filmgrain")):
    r = subprocess.run([cli_bin, "scene.exr", "--iscolorspace", "scene_linear",
                        "--filmgrain:stock=color-negative:seed=12:frame=3:width_mm=0.5:"
                        "roi=4,4,50,40", "-o", "cli.exr", "-q"], capture_output=True, text=True)
    assert r.returncode == 0, (cli_bin, r.stderr)
    inp = oiio.ImageInput.open("cli.exr")
    cli = inp.read_image(oiio.FLOAT)
    names = list(inp.spec().channelnames)
    inp.close()
    cli = np.stack([cli[:, :, names.index(n)] for n in negative.channels], axis=-1)
    assert negative.density.tobytes() == np.ascontiguousarray(cli).tobytes(), \
        f"differs from the CLI {cli_bin}"
print("installed module:", filmgrain.__file__, filmgrain.__version__, negative)
print("extension:", filmgrain._filmgrain.__file__)
"""


def run(cmd, **kw):
    print("+", " ".join(str(c) for c in cmd), flush=True)
    t0 = time.monotonic()
    r = subprocess.run([str(c) for c in cmd], **kw)
    seconds = time.monotonic() - t0
    if r.returncode != 0:
        said = (r.stdout or "") + (r.stderr or "") if kw.get("capture_output") else ""
        raise SystemExit(f"pip_install_check: FAIL: exit status {r.returncode} "
                         f"after {seconds:.1f} s" + (f":\n{said}" if said else ""))
    return r, seconds


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--source", required=True, help="the repository (has pyproject.toml)")
    ap.add_argument("--work", required=True, help="a scratch directory (recreated)")
    ap.add_argument("--python", default="/usr/bin/python3")
    args = ap.parse_args()
    if "FILMGRAIN_BIN" not in os.environ:
        raise SystemExit("pip_install_check: FILMGRAIN_BIN (the built CLI) is not set")

    work = os.path.abspath(args.work)
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    venv = os.path.join(work, "venv")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "OCIO")}
    t_start = time.monotonic()
    try:
        _, t_venv = run([args.python, "-m", "venv", "--system-site-packages", venv], env=env)
        _, t_pip = run([os.path.join(venv, "bin", "pip"), "install", "--no-cache-dir",
                        args.source], env=env, cwd=work)
        py = os.path.join(venv, "bin", "python")
        r, _ = run([py, "-c", RENDER_CHECK], env=env, cwd=work, capture_output=True, text=True)
        print(r.stdout, end="")
        ext = r.stdout.split("extension:", 1)[1].strip()
        needed, _ = run(["ldd", ext], capture_output=True, text=True)
        bad = [line for line in needed.stdout.splitlines()
               if "libfilmgrain" in line or "not found" in line]
        if bad:
            raise SystemExit("pip_install_check: FAIL: the extension needs " + "; ".join(bad))
        cli_bin = os.path.join(venv, "bin", "filmgrain")
        needed, _ = run(["ldd", cli_bin], capture_output=True, text=True)
        bad = [line for line in needed.stdout.splitlines()
               if "libfilmgrain" in line or "not found" in line]
        if bad:
            raise SystemExit("pip_install_check: FAIL: the CLI needs " + "; ".join(bad))
        # The farm as a user runs it after `pip install`: no FILMGRAIN_BIN, the
        # venv not on PATH; it must find the CLI beside itself.
        farm_env = {k: v for k, v in env.items() if k != "FILMGRAIN_BIN"}
        farm_env["PATH"] = "/usr/bin:/bin"
        r, t_farm = run([os.path.join(venv, "bin", "filmgrain-farm"), "--workers", "1",
                         "--wedge", "--filmgrain:stock=paper:width_mm=0.5", "-o",
                         os.path.join(work, "farm_wedge.exr"), "-q"],
                        env=farm_env, cwd=work, capture_output=True, text=True)
        if not os.path.isfile(os.path.join(work, "farm_wedge.exr")):
            raise SystemExit("pip_install_check: FAIL: filmgrain-farm wrote nothing: "
                             + r.stderr)
        print(f"filmgrain-farm with the installed CLI: {t_farm:.1f} s")
    except SystemExit:
        print(f"pip_install_check: work directory kept: {work}", file=sys.stderr)
        raise
    total = time.monotonic() - t_start
    print(f"pip_install_check: PASS: venv {t_venv:.1f} s, pip install {t_pip:.1f} s, "
          f"total {total:.1f} s")
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
