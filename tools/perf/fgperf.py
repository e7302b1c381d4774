"""Shared helpers of the performance tools (tools/perf/): run the filmgrain
CLI and measure it, read its EXR and --stats output.

Run with Debian's /usr/bin/python3 (OpenImageIO's Python module and numpy);
a pyenv python3 on PATH cannot import OpenImageIO.

Timing: every run is one child process run under GNU time (/usr/bin/time),
which reports that child's own resource usage: CPU seconds (user + system,
all threads) and peak resident memory (KiB); wall seconds are
time.perf_counter around it. On a machine shared with other
jobs the wall time depends on the load; the CPU time much less so. Neither
is ever asserted on in CI.

Tables: the CLI keeps its P(develop|N) tables on disk for the next
process (kinetics_table.h). Measured runs do not: cli_env() sets
FILMGRAIN_CACHE_DIR=off unless the caller's environment sets it, so every
run pays its table builds, as a machine's first render of a stock does,
and a run's time does not depend on which runs came before it.
"""

import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field

import numpy as np

try:
    import OpenImageIO as oiio
except ImportError:  # pragma: no cover - explained to the user
    sys.exit("tools/perf needs the OpenImageIO Python module: run it with /usr/bin/python3 "
             "(Debian's python3-openimageio), not " + sys.executable)


@dataclass
class RunResult:
    """One CLI run: what was run, how long it took, what it said."""
    argv: list
    wall_s: float
    cpu_s: float
    maxrss_kib: int
    returncode: int
    stderr: str = ""
    stats: dict = field(default_factory=dict)

    @property
    def ok(self):
        return self.returncode == 0

    @property
    def peak_rss_mib(self):
        return self.maxrss_kib / 1024.0


TIME = "/usr/bin/time"  # GNU time (Debian package `time`)


def cli_env(cache_dir=None):
    """The environment of a measured CLI run: no table cache on disk unless
    FILMGRAIN_CACHE_DIR is set (see the module's docstring), or the tables
    kept in `cache_dir` when given (a warm cache)."""
    env = dict(os.environ)
    if cache_dir is not None:
        env["FILMGRAIN_CACHE_DIR"] = cache_dir
    env.setdefault("FILMGRAIN_CACHE_DIR", "off")
    return env


def run_cli(argv, timeout_s=None, stats_path=None, cache_dir=None):
    """Runs argv (the CLI and its arguments) as one child and measures it.

    The child runs under GNU time, which reports its CPU seconds and peak
    resident memory: the rusage Python itself gets from wait4 would not do,
    since Linux carries the peak RSS of the forked Python (numpy, OIIO:
    ~200 MiB) across exec into the child's ru_maxrss. Returns a RunResult;
    never raises on a non-zero exit (the caller reports it). On timeout the
    CLI is killed (SIGKILL, so time still reports its peak memory so far)
    and returncode is -9. stats_path: a --stats file to load into .stats.
    cache_dir: FILMGRAIN_CACHE_DIR for the run (cli_env).
    """
    if not os.access(TIME, os.X_OK):
        sys.exit(f"tools/perf needs GNU time at {TIME} (apt install time)")
    with tempfile.TemporaryFile() as err, tempfile.NamedTemporaryFile("r") as tf:
        t0 = time.perf_counter()
        proc = subprocess.Popen([TIME, "-f", "%e %U %S %M %x", "-o", tf.name, *argv],
                                stdout=subprocess.DEVNULL, stderr=err, start_new_session=True,
                                env=cli_env(cache_dir))
        deadline = None if timeout_s is None else t0 + timeout_s
        killed = False
        while True:
            try:
                proc.wait(timeout=0.05)
                break
            except subprocess.TimeoutExpired:
                pass
            if deadline is not None and time.perf_counter() > deadline and not killed:
                killed = True
                for child in _children(proc.pid):
                    os.kill(child, signal.SIGKILL)
                try:
                    proc.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    os.killpg(proc.pid, signal.SIGKILL)
                    proc.wait()
                break
        wall = time.perf_counter() - t0
        err.seek(0)
        stderr = err.read().decode(errors="replace")
        fields = tf.read().split()
    # time's line is the last; "Command exited with non-zero status" may precede it.
    try:
        _, user, system, maxrss, code = fields[-5:]
        cpu, maxrss_kib, code = float(user) + float(system), int(maxrss), int(code)
    except ValueError:
        cpu, maxrss_kib, code = float("nan"), 0, proc.returncode
    # A child killed by a signal exits with status 0 for time's %x: time says
    # "Command terminated by signal N" on a line of its own instead.
    m = re.search(r"Command terminated by signal (\d+)", " ".join(fields))
    if m and code == 0:
        code = -int(m.group(1))
    returncode = -9 if killed else code
    res = RunResult(argv=list(argv), wall_s=wall, cpu_s=cpu, maxrss_kib=maxrss_kib,
                    returncode=returncode, stderr=stderr)
    if res.ok and stats_path and os.path.exists(stats_path):
        with open(stats_path) as f:
            res.stats = json.load(f)
    return res


def run_logged(label, argv, timeout_s=None, stats_path=None, cache_dir=None):
    """run_cli, with a line for the run printed (label, wall and CPU
    seconds, peak memory, the load average at its start, its status); the
    RunResult gets .load (that load) and .status."""
    load = os.getloadavg()[0]
    r = run_cli(argv, timeout_s=timeout_s, stats_path=stats_path, cache_dir=cache_dir)
    r.load = load
    r.status = "ok" if r.ok else ("TIMEOUT" if r.returncode == -9 else f"exit {r.returncode}")
    print(f"  {label}: wall {fmt_s(r.wall_s):>9s} CPU {fmt_s(r.cpu_s):>9s} peak "
          f"{r.peak_rss_mib:7.0f} MiB load {load:.1f} {r.status}", flush=True)
    return r


def _children(pid):
    """Pids of the direct children of pid (Linux /proc)."""
    out = []
    try:
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/children") as f:
                out += [int(v) for v in f.read().split()]
    except OSError:
        pass
    return out


def read_exr(path):
    """The image as float32 numpy (height, width, channels), the channel
    names, and the data window origin (x, y) within the full window."""
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise RuntimeError(f"cannot open {path}: {oiio.geterror()}")
    spec = inp.spec()
    pixels = inp.read_image(0, 0, 0, spec.nchannels, "float")
    inp.close()
    if pixels is None:
        raise RuntimeError(f"cannot read {path}")
    pixels = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    return pixels, list(spec.channelnames), (spec.x, spec.y)


def write_image(path, array):
    """Writes a float32 numpy (h, w) or (h, w, c) image (EXR: float)."""
    a = np.ascontiguousarray(array, dtype=np.float32)
    if a.ndim == 2:
        a = a[:, :, None]
    spec = oiio.ImageSpec(a.shape[1], a.shape[0], a.shape[2], "float")
    out = oiio.ImageOutput.create(path)
    if out is None or not out.open(path, spec):
        raise RuntimeError(f"cannot write {path}: {oiio.geterror()}")
    out.write_image(a)
    out.close()


# Octave bands of spatial frequency, as fractions of the scan's Nyquist
# frequency, in which the reports compare noise power.
NPS_BANDS = ((0.125, 0.25), (0.25, 0.5), (0.5, 1.0))


def nps_octave_bands(t):
    """Noise power (Wiener spectrum) of a patch of transmittance t (rows x
    columns) in each of NPS_BANDS: the 2-D periodogram of the patch less its
    mean, |FFT|^2 / pixels, averaged over the frequencies (radial, in units
    of Nyquist) inside the band."""
    tc = np.asarray(t, dtype=np.float64)
    tc = tc - tc.mean()
    h, w = tc.shape
    power = np.abs(np.fft.fft2(tc)) ** 2 / tc.size
    fy = np.abs(np.fft.fftfreq(h))[:, None] * 2  # 1 = Nyquist
    fx = np.abs(np.fft.fftfreq(w))[None, :] * 2
    f = np.sqrt(fx ** 2 + fy ** 2)
    return [float(power[(f >= lo) & (f < hi)].mean()) for lo, hi in NPS_BANDS]


def stock_json(binary, stock):
    """The stock (preset name or file) as complete JSON, from the CLI."""
    out = subprocess.run([binary, "--print-stock", stock], check=True, capture_output=True,
                         text=True).stdout
    return json.loads(out)


def fmt_s(seconds):
    """Seconds, readable."""
    if seconds is None or seconds != seconds:
        return "n/a"
    if seconds < 1:
        return f"{seconds * 1000:.0f} ms"
    if seconds < 100:
        return f"{seconds:.2f} s"
    return f"{seconds:.0f} s"


def machine_note():
    """One line about the machine and its load, for the reports."""
    try:
        load = os.getloadavg()
    except OSError:
        load = (float("nan"),) * 3
    cpu = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return (f"{os.cpu_count()} hardware threads ({cpu}); load average "
            f"{load[0]:.1f}/{load[1]:.1f}/{load[2]:.1f} (1/5/15 min) when the run ended")


def git_describe(repo_dir):
    """HEAD's short hash, and the files of core/ and plugin/ (what the
    binary is built from) that differ from it in the working tree."""
    try:
        head = subprocess.run(["git", "-C", repo_dir, "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", repo_dir, "status", "--porcelain", "--",
                                "core", "plugin"], capture_output=True, text=True).stdout.split("\n")
        files = [line[3:] for line in dirty if line.strip()]
        return head + (f" (working tree: {', '.join(files)} modified)" if files else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
