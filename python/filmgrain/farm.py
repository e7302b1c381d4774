"""filmgrain-farm: render filmgrain sequences (or one large frame in tiles)
on a Dask distributed cluster.

The farm knows no sequence rules of its own: one ``filmgrain ... --dry-run``
on the client, with the user's arguments, lists every image the CLI would
render (frame, files, input_exists, settings_hash, up_to_date), or rejects
the arguments with the CLI's message. Frames that --skip-existing or
--skip-missing would skip are counted, not submitted. Every other frame is a
task that runs the real ``filmgrain`` CLI on a worker: the user's arguments
with ``--frames LIST`` replaced by ``--frames F`` and INPUT by the dry run's
input file of frame F. The CLI renders frame F with frame F's grain, exactly
as in a whole sequence, and writes its outputs all-or-nothing (created
unnamed, linked into place when complete), so the outputs are the CLI's by
construction and a task lost with its worker (and run again elsewhere by the
scheduler) leaves no partial file.

``--tiles N`` renders one frame as N strips of rows (``--filmgrain:roi=``),
each by a CLI task into a temporary EXR beside the output, and stitches them
into the output: the pixels are bit-identical to a whole-frame render (the
core keys every random draw on absolute scan coordinates, never on the ROI),
and the header is the whole frame's, its settings hash the dry run's.

Cluster: a local one by default (one worker process per core, one thread
each), or a running scheduler (``--scheduler tcp://host:8786``); see
python/FARM.md. This module does not import the compiled extension; it needs
only dask, distributed (and OpenImageIO and numpy on the client for
``--tiles``). Tasks are shipped to workers by value (cloudpickle), so the
workers need distributed and the CLI, not this package.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import uuid

PROG = "filmgrain-farm"

# Seconds a task waits between checks of the run's stop event (a stopped or
# failed run terminates the CLI processes still running within this time).
STOP_POLL_S = 0.5

DEFAULT_SCHEDULER_TIMEOUT_S = 20.0

# The CLI's options come from the CLI itself (cli_options: its
# --list-options table), so that the farm tells INPUT from an option's value
# for every option the CLI has, and none it does not: an option in neither
# the farm's nor the CLI's table is an error, not a guess. Whether the
# arguments make sense is the CLI's to say (its --dry-run).
# The CLI's options the farm runs itself instead of passing them on.
CLI_OPTIONS_THE_FARM_RUNS = {
    "--dry-run": "the farm runs the CLI's dry run itself: run the filmgrain CLI with "
                 "--dry-run to see it",
    "--report-json": "the farm reads each task's report itself and prints what became of "
                     "the frames in its summary",
}

# What the CLI's --report-json says of each image (one JSON line on stdout
# per image it ended): the farm counts the outcomes from these.
REPORT_OUTCOMES = ("rendered", "up_to_date", "missing_input")

# The keys of each line of the CLI's --dry-run (filmgrain --help).
DRY_RUN_KEYS = ("frame", "input", "output", "stats", "preview", "input_exists", "error",
                "settings_hash", "up_to_date")

HELP = f"""\
{PROG} -- render filmgrain sequences on a Dask distributed cluster

Usage: {PROG} [farm options] CLI-ARGUMENTS...
       {PROG} PLATE.####.exr --frames 1001-1100 --filmgrain[:...] -o NEG.####.exr
       {PROG} --scheduler tcp://host:8786 PLATE.####.exr --frames LIST ...
       {PROG} --tiles 8 BIG.exr --filmgrain[:...] -o BIG_NEG.exr

The frames and their files are the CLI's: 'filmgrain ... --dry-run' lists
them on this machine first (its errors are printed, exit 1), and frames it
finds up to date (--skip-existing) or without input (--skip-missing) are
skipped here. Each other frame is one task that runs the filmgrain CLI with
the same arguments, --frames F and --report-json (what became of the frame):
the outputs are the CLI's, bit for bit.
A task whose worker is lost is run again on another worker (the scheduler's
distributed.scheduler.allowed-failures, default 3 losses); an error of the
CLI (a missing input, a bad setting) is not retried: the run stops, the CLI
processes still running are terminated, and the frame's error is printed.

Farm options:
    --scheduler ADDRESS     Use a running Dask scheduler (tcp://host:8786);
                            paths (inputs, outputs, --filmgrain-bin) must be
                            valid on every worker (python/FARM.md).
                            Default: none (a local cluster)
    --workers N             Local cluster: worker processes, one thread each.
                            Default: the cores of this machine, divided by
                            --threads when given
    --scheduler-timeout SECONDS
                            Give up connecting to --scheduler after this
                            long. Default: {DEFAULT_SCHEDULER_TIMEOUT_S:g}
    --tiles N               Render one frame (no --frames, or one frame) as N
                            strips of rows on the workers and stitch them:
                            pixels, windows, channels, pixel type,
                            compression and metadata (settings hash
                            included) as a whole-frame render, so
                            --skip-existing and --skip-missing apply. Not
                            with --stats or --preview. Default: 1 (whole
                            frames)
    --filmgrain-bin PATH    The filmgrain CLI the tasks run. Default:
                            $FILMGRAIN_BIN, else 'filmgrain' next to this
                            program, else 'filmgrain' on PATH
    --progress              Show progress (frames done, elapsed, time left)
                            even when stderr is not a terminal. Default: only
                            on a terminal
    -q, --quiet             Print nothing but errors (no progress, summary or
                            relayed CLI warnings)
    -h, --help              Print this help and exit

Every other argument is the CLI's (filmgrain --help) and goes to each task
unchanged: INPUT, --wedge or --chart, --filmgrain[:...], -d, -o[:compression=...],
--colorconfig, --iscolorspace, --frames (one frame per task, INPUT the
frame's file), --stats and --preview (frame patterns), --skip-existing,
--skip-missing. --threads N is
passed to each task (default: --threads 1, one core per task: start remote
workers with one thread per core). $OCIO of this program is the tasks' $OCIO.

Progress and messages go to stderr; the CLI's warnings are relayed, prefixed
with their frame. Exit status: 0 success; 1 error (usage errors, a failed
frame, a lost scheduler); 130 or 143 when stopped by SIGINT or SIGTERM.
"""


class UsageError(Exception):
    """A bad command line: printed as 'filmgrain-farm: error: ...', exit 1."""


class FarmError(Exception):
    """A failed run (a frame's CLI error, a lost cluster), exit 1."""


class Stopped(Exception):
    """SIGINT or SIGTERM: the run stops; exit 128 + signal."""

    def __init__(self, signum):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


# ---------------------------------------------------------------------------
# Command line.

class FarmArgs:
    """The farm's options, and the CLI's arguments with what the farm needs
    to know about them."""

    def __init__(self):
        self.scheduler = None
        self.workers = None
        self.scheduler_timeout_s = DEFAULT_SCHEDULER_TIMEOUT_S
        self.tiles = 1
        self.filmgrain_bin = None
        self.progress = False
        self.quiet = False
        self.help = False
        self.cli = []            # CLI arguments, without -q, --progress
        self.frames_indices = []  # indices of --frames and its list in cli
        self.input_index = None  # index of INPUT in cli
        self.output_index = None  # index of -o's value in cli
        self.filmgrain_index = None  # index of the --filmgrain word in cli
        self.threads = None      # --threads as given, or None
        self.given = set()       # CLI options given (base names)


def _positive_int(flag, value, upper=None):
    try:
        n = int(value, 10)
    except ValueError:
        n = 0
    if n < 1 or (upper is not None and n > upper):
        limit = f" in [1, {upper}]" if upper else " >= 1"
        raise UsageError(f"{flag} {value}: expected a whole number{limit}")
    return n


def cli_options(fg_bin):
    """The CLI's options by every spelling (`filmgrain --list-options`):
    {name: {"value": takes a value, "modifiers": takes :key=value,
    "exits": prints and exits}}. Raises UsageError if the CLI cannot say."""
    try:
        r = subprocess.run([fg_bin, "--list-options"], capture_output=True, text=True,
                           timeout=60)
        doc = json.loads(r.stdout) if r.returncode == 0 else None
    except (OSError, subprocess.SubprocessError, ValueError) as e:
        raise UsageError(f"'{fg_bin} --list-options' failed: {e}") from e
    if doc is None:
        raise UsageError(f"'{fg_bin} --list-options' failed (exit {r.returncode}): "
                         f"{r.stderr.strip()} (is it the filmgrain CLI of this release?)")
    table = {}
    for o in doc["options"]:
        spec = {"value": bool(o["value"]), "modifiers": bool(o["modifiers"]),
                "exits": bool(o["prints_and_exits"])}
        for name in [o["name"], *o["aliases"]]:
            table[name] = spec
    return table


def farm_bin_argument(argv):
    """--filmgrain-bin's value in argv, if given (read before the rest of
    the command line, which needs the CLI's options)."""
    for i, word in enumerate(argv[:-1]):
        if word == "--filmgrain-bin":
            return argv[i + 1]
    return None


def parse_args(argv, options):
    """Parses the farm's command line (see HELP); `options` is the CLI's
    table (cli_options). Raises UsageError."""
    a = FarmArgs()
    i = 0

    def value(flag):
        nonlocal i
        if i + 1 >= len(argv):
            raise UsageError(f"{flag} needs a value")
        i += 1
        return argv[i]

    while i < len(argv):
        word = argv[i]
        base = word.split(":", 1)[0] if word.startswith("-") else word
        if word in ("-h", "--help"):
            a.help = True
        elif word == "--scheduler":
            a.scheduler = value(word)
            if not a.scheduler:
                raise UsageError("--scheduler: empty address")
        elif word == "--workers":
            a.workers = _positive_int(word, value(word), 4096)
        elif word == "--scheduler-timeout":
            v = value(word)
            try:
                a.scheduler_timeout_s = float(v)
            except ValueError:
                a.scheduler_timeout_s = -1.0
            if not a.scheduler_timeout_s > 0:
                raise UsageError(f"--scheduler-timeout {v}: expected seconds > 0")
        elif word == "--tiles":
            a.tiles = _positive_int(word, value(word), 65536)
        elif word == "--filmgrain-bin":
            a.filmgrain_bin = value(word)
            if not a.filmgrain_bin:
                raise UsageError("--filmgrain-bin: empty path")
        elif word == "--progress":
            a.progress = True
        elif word in ("-q", "--quiet"):
            a.quiet = True
        elif base in options and options[base]["exits"]:
            raise UsageError(f"{word}: run the filmgrain CLI itself to print and exit")
        elif base in CLI_OPTIONS_THE_FARM_RUNS:
            raise UsageError(f"{word}: {CLI_OPTIONS_THE_FARM_RUNS[base]}")
        elif base in options:
            if ":" in word and not options[base]["modifiers"]:
                raise UsageError(f"{word}: {base} takes no :modifiers")
            a.given.add(base)
            if base == "--filmgrain":
                a.filmgrain_index = len(a.cli)
            a.cli.append(word)
            if options[base]["value"]:
                v = value(word)
                if base == "-o":
                    a.output_index = len(a.cli)
                elif base == "--threads":
                    a.threads = v
                elif base == "--frames":
                    a.frames_indices += [len(a.cli) - 1, len(a.cli)]
                a.cli.append(v)
        elif word.startswith("-") and word != "-":
            raise UsageError(f"unknown option '{word}' (the farm's options: {PROG} --help; "
                             "the CLI's: filmgrain --help)")
        else:
            a.input_index = len(a.cli)  # a second INPUT: the dry run says so
            a.cli.append(word)
        i += 1
    if a.help:
        return a

    if a.tiles > 1:
        for flag, why in (("--stats", "the tiles' statistics are not the frame's"),
                          ("--preview", "the preview's scale is the whole frame's")):
            if flag in a.given:
                raise UsageError(f"--tiles does not combine with {flag} ({why}): render "
                                 "without --tiles")
    if a.scheduler is not None and a.workers is not None:
        raise UsageError("--workers sizes the local cluster: not with --scheduler (start "
                         "workers with 'dask worker', python/FARM.md)")
    return a


def resolve_filmgrain_bin(given):
    """The CLI's path: --filmgrain-bin, $FILMGRAIN_BIN, 'filmgrain' next to
    this program, else on PATH. Absolute, so that the workers run this one."""
    candidates = []
    if given:
        candidates = [given]
    elif os.environ.get("FILMGRAIN_BIN"):
        candidates = [os.environ["FILMGRAIN_BIN"]]
    else:
        here = os.path.dirname(os.path.abspath(sys.argv[0] or "."))
        candidates = [os.path.join(here, "filmgrain"), shutil.which("filmgrain")]
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return os.path.abspath(c)
    if given or os.environ.get("FILMGRAIN_BIN"):
        raise UsageError(f"filmgrain CLI '{candidates[0]}' not found or not executable")
    raise UsageError("filmgrain CLI not found next to this program nor on PATH: give "
                     "--filmgrain-bin PATH or set $FILMGRAIN_BIN")


# ---------------------------------------------------------------------------
# What to render: the CLI's own plan (--dry-run).

def dry_run(fg_bin, cli):
    """The images the CLI would render with arguments `cli`: its --dry-run
    lines as dicts (DRY_RUN_KEYS; "frame" None for a single image), in the
    CLI's order. Raises UsageError with the CLI's message when it rejects
    the arguments (usage, frame list, frame pattern)."""
    try:
        r = subprocess.run([fg_bin, *cli, "--dry-run"], stdin=subprocess.DEVNULL,
                           capture_output=True, text=True, errors="replace")
    except OSError as e:
        raise FarmError(f"cannot run the filmgrain CLI '{fg_bin}': {e}")
    if r.returncode != 0:
        raise UsageError(_cli_error(r.stderr))
    jobs = []
    for line in r.stdout.splitlines():
        try:
            job = json.loads(line)
        except ValueError:
            job = None
        if not isinstance(job, dict) or any(k not in job for k in DRY_RUN_KEYS):
            raise FarmError(f"'{fg_bin} --dry-run' printed '{line}', not a line of the "
                            f"shape {{{', '.join(DRY_RUN_KEYS)}}}: a CLI older than this farm?")
        jobs.append(job)
    if not jobs:
        raise FarmError(f"'{fg_bin} --dry-run' listed no image to render")
    return jobs


def plan(a, jobs):
    """(to render, up to date, missing input): the jobs that --skip-missing
    and --skip-existing skip, judged as the CLI judges them (its dry run's
    input_exists and up_to_date, in the CLI's order: missing first)."""
    todo, up_to_date, missing = [], [], []
    for job in jobs:
        if "--skip-missing" in a.given and not job["input_exists"]:
            missing.append(job)
        elif "--skip-existing" in a.given and job["up_to_date"]:
            up_to_date.append(job)
        else:
            todo.append(job)
    return todo, up_to_date, missing


def task_argv(fg_bin, a, job, cli=None):
    """The command of one image's task: `cli` (default: the user's CLI
    arguments) for a single image; for frame F of a sequence, with --frames
    LIST replaced by --frames F and INPUT by F's input file from the dry run
    (a list in INPUT, plate.1-10#.exr, would contradict --frames F; the file
    is the one the CLI reads for F, so output and settings hash are the
    same)."""
    cli = list(a.cli if cli is None else cli) + ["--report-json"]
    if job["frame"] is None:
        return [fg_bin] + cli
    if a.input_index is not None:
        cli[a.input_index] = job["input"]
    cli = [w for i, w in enumerate(cli) if i not in a.frames_indices]
    return [fg_bin] + cli + ["--frames", str(job["frame"])]


def with_modifier(word, key, value):
    """An option word (--filmgrain:a=1:roi=...) with :key=value set."""
    parts = [p for p in word.split(":") if not p.startswith(key + "=")]
    return ":".join(parts + [f"{key}={value}"])


def modifier(word, key):
    """The value of :key= in an option word, or None."""
    for p in word.split(":")[1:]:
        if p.startswith(key + "="):
            return p[len(key) + 1:]
    return None


# ---------------------------------------------------------------------------
# The task: runs on a worker.

def run_cli_task(argv, env_overrides, stop_event_name):
    """Runs the CLI (argv[0]) to completion on this worker and returns
    {"rc", "stdout", "stderr", "host", "seconds"}. Terminates it (SIGTERM: it leaves
    no output) when the run's stop event is set, and it dies with this worker
    process (PR_SET_PDEATHSIG). Never raises for a CLI failure (no retry)."""
    import ctypes
    import socket
    host = socket.gethostname()
    t0 = time.monotonic()
    if not (os.path.isfile(argv[0]) and os.access(argv[0], os.X_OK)):
        return {"rc": 127, "host": host, "seconds": 0.0, "stdout": "",
                "stderr": f"filmgrain: error: the filmgrain CLI '{argv[0]}' is not an "
                          f"executable file on worker {host} (install it there, or give "
                          "--filmgrain-bin)\n"}
    env = dict(os.environ)
    for k, v in env_overrides.items():
        if v is None:
            env.pop(k, None)
        else:
            env[k] = v
    parent = os.getpid()
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        prctl = None

    def die_with_worker():
        if prctl is not None:
            prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
        if os.getppid() != parent:
            os._exit(143)

    proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=env, preexec_fn=die_with_worker,
                            text=True, errors="replace")
    stop = None
    try:
        from distributed import Event
        stop = Event(stop_event_name)
    except Exception:  # no scheduler to ask: the run cannot be stopped early
        stop = None
    stopping = False
    try:
        while True:
            try:
                out, err = proc.communicate(timeout=STOP_POLL_S)
                break
            except subprocess.TimeoutExpired:
                if not stopping and stop is not None:
                    try:
                        stopping = stop.is_set()
                    except Exception:
                        stopping = False
                    if stopping:
                        proc.terminate()
    finally:
        if proc.poll() is None:  # this thread is being torn down
            proc.terminate()
            proc.wait()
    return {"rc": proc.returncode, "stdout": out or "", "stderr": err or "", "host": host,
            "seconds": time.monotonic() - t0}


# ---------------------------------------------------------------------------
# The client.

class Console:
    """Progress and messages on stderr."""

    def __init__(self, quiet, force_progress):
        self.quiet = quiet
        self.terminal = sys.stderr.isatty()
        self.show_progress = not quiet and (self.terminal or force_progress)
        self.line_open = False
        self.last_done = None

    def _end_line(self):
        if self.line_open:
            sys.stderr.write("\n")
            self.line_open = False

    def info(self, msg):
        if not self.quiet:
            self._end_line()
            print(f"{PROG}: {msg}", file=sys.stderr, flush=True)

    def error(self, msg):
        self._end_line()
        print(f"{PROG}: error: {msg}", file=sys.stderr, flush=True)

    def progress(self, done, total, noun, t_start, final=False):
        if not self.show_progress:
            return
        elapsed = time.monotonic() - t_start
        text = f"{PROG}: {done}/{total} {noun}, {elapsed:.0f} s elapsed"
        if 0 < done < total:
            text += f", about {elapsed / done * (total - done):.0f} s left"
        if self.terminal:
            sys.stderr.write("\r" + text + "\033[K")
            self.line_open = True
            if final:
                self._end_line()
        elif done and done != self.last_done:
            # Not a terminal: a line per frame done, not per tick.
            sys.stderr.write(text + "\n")
            self.last_done = done
        sys.stderr.flush()


def _cli_error(stderr):
    """The CLI's error lines (or its whole output when it printed none)."""
    lines = [l for l in stderr.splitlines() if "error:" in l]
    text = "\n".join(lines or stderr.strip().splitlines()[-5:])
    return text.replace("filmgrain: error: ", "") or "(no message)"


def _describe_exit(rc):
    if rc < 0:
        return f"killed by {signal.Signals(-rc).name}"
    if rc > 128 and rc - 128 in (signal.SIGINT, signal.SIGTERM, signal.SIGKILL):
        return f"stopped by {signal.Signals(rc - 128).name}"
    return f"exit status {rc}"


class Farm:
    """Runs CLI tasks on a client's cluster, with progress and stopping."""

    def __init__(self, client, console, env_overrides):
        self.client = client
        self.con = console
        self.env = env_overrides
        from distributed import Event
        self.stop_name = f"filmgrain-farm-stop-{uuid.uuid4().hex}"
        self.stop_event = Event(self.stop_name, client=client)

    def run(self, tasks, noun):
        """Runs `tasks` [(label, argv)], returns their results in order.
        Raises FarmError on the first failure (after terminating the others)."""
        from distributed import wait
        from distributed.scheduler import KilledWorker
        t_start = time.monotonic()
        futures = [self.client.submit(run_cli_task, argv, self.env, self.stop_name,
                                      key=f"filmgrain-{noun}-{label}-{uuid.uuid4().hex[:8]}",
                                      pure=False, retries=0)
                   for label, argv in tasks]
        label_of = {f.key: label for f, (label, _) in zip(futures, tasks)}
        results = {}
        pending = set(futures)
        self.con.progress(0, len(tasks), noun, t_start)
        try:
            while pending:
                try:
                    done, _ = wait(list(pending), timeout=1.0, return_when="FIRST_COMPLETED")
                except TimeoutError:
                    self.con.progress(len(results), len(tasks), noun, t_start)
                    continue
                for f in done:
                    pending.discard(f)
                    label = label_of[f.key]
                    if f.status == "error":
                        exc = f.exception()
                        if isinstance(exc, KilledWorker):
                            raise FarmError(f"{label}: its worker was lost "
                                            "distributed.scheduler.allowed-failures times "
                                            f"in a row; giving up ({exc})")
                        raise FarmError(f"{label}: the task failed: {exc!r}")
                    if f.status != "finished":
                        raise FarmError(f"{label}: the task was {f.status} (scheduler lost?)")
                    r = f.result()
                    if r["rc"] != 0:
                        raise FarmError(f"{label} (on {r['host']}, {_describe_exit(r['rc'])}): "
                                        f"{_cli_error(r['stderr'])}")
                    for line in r["stderr"].splitlines():
                        if "warning:" in line:
                            self.con.info(f"{label}: {line.replace('filmgrain: ', '', 1)}")
                    results[f.key] = r
                self.con.progress(len(results), len(tasks), noun, t_start)
        except BaseException:
            self.stop(futures)
            raise
        self.con.progress(len(results), len(tasks), noun, t_start, final=True)
        return [results[f.key] for f in futures]

    def stop(self, futures):
        """Cancels what has not started and terminates the running CLIs."""
        try:
            self.stop_event.set()
            self.client.cancel(futures)
            # The running tasks see the event within STOP_POLL_S and return.
            deadline = time.monotonic() + 3 * STOP_POLL_S + 2
            for f in futures:
                while f.status == "pending" and time.monotonic() < deadline:
                    time.sleep(0.05)
        except Exception:
            pass


def _count_outcomes(results):
    """(rendered, up to date, missing input) from the tasks' --report-json
    lines: each task ends one image, or says why not."""
    counts = dict.fromkeys(REPORT_OUTCOMES, 0)
    for r in results:
        reports = [json.loads(line) for line in r["stdout"].splitlines()
                   if line.startswith("{")]
        if not reports:
            raise FarmError(f"the task on {r['host']} ended well but its CLI reported no "
                            f"image (stdout: {r['stdout'][-200:]!r})")
        for report in reports:
            if report.get("outcome") not in counts:
                raise FarmError(f"the CLI on {r['host']} reported an unknown outcome: {report}")
            counts[report["outcome"]] += 1
    return tuple(counts[o] for o in REPORT_OUTCOMES)


def render_frames(farm, a, fg_bin, jobs):
    """One task per job (dry-run line); returns (rendered, up to date,
    missing input) as the tasks' CLIs report them."""
    sequence = jobs[0]["frame"] is not None
    tasks = [(f"frame {j['frame']}" if sequence else "image", task_argv(fg_bin, a, j))
             for j in jobs]
    return _count_outcomes(farm.run(tasks, "frames" if sequence else "image"))


def _strips(roi, n):
    """n strips of rows covering roi (x, y, w, h), sizes differing by <= 1."""
    x, y, w, h = roi
    if n > h:
        raise UsageError(f"--tiles {n}: more tiles than the {h} rows to render")
    edges = [y + (h * i) // n for i in range(n + 1)]
    return [(x, edges[i], w, edges[i + 1] - edges[i]) for i in range(n)]


def _read_spec(path):
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(path)
    if not inp:
        raise FarmError(f"cannot read '{path}': {oiio.geterror()}")
    spec = inp.spec()
    inp.close()
    return spec


def render_tiled(farm, a, fg_bin, con, nworkers, job, t0):
    """--tiles N of the image of `job` (the whole-frame dry run's line): a
    1-pixel probe render gives the scan (its EXR's full window) and the
    header; N strip tasks render into a temporary directory beside the
    output; the client stitches them, gives the result the whole frame's
    settings hash and renames it into place."""
    import numpy as np
    import OpenImageIO as oiio
    frame = job["frame"]
    output = job["output"]
    out_dir = os.path.dirname(os.path.abspath(output))
    if not os.path.isdir(out_dir):
        raise FarmError(f"-o {output}: directory '{out_dir}' does not exist")
    fg_word = a.cli[a.filmgrain_index]
    user_roi = modifier(fg_word, "roi")
    if user_roi is not None:
        try:
            rx, ry, rw, rh = (int(v, 10) for v in user_roi.split(","))
        except ValueError:
            raise UsageError(f"--filmgrain:roi={user_roi}: expected X,Y,W,H (whole numbers)")
    else:
        rx, ry = 0, 0

    tmp_dir = tempfile.mkdtemp(prefix=f".{os.path.basename(output)}.farm-", dir=out_dir)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp_dir, 0o777 & ~umask)  # workers may run as another user of the group
    tmp_out = None
    try:
        def task_args(name, roi, compression):
            cli = list(a.cli)
            cli[a.filmgrain_index] = with_modifier(fg_word, "roi", ",".join(map(str, roi)))
            if compression:
                cli[a.output_index - 1] = with_modifier(cli[a.output_index - 1], "compression",
                                                        compression)
            # A frame's tile: the pattern NAME.%d.exr, whose frame F is NAME.F.exr.
            cli[a.output_index] = os.path.join(tmp_dir, name + (".%d.exr" if frame is not None
                                                                  else ".exr"))
            path = os.path.join(tmp_dir, name + (f".{frame}.exr" if frame is not None
                                                 else ".exr"))
            return task_argv(fg_bin, a, job, cli), path

        # Probe: the header (compression, metadata) and the scan as the CLI
        # makes them, from a 1-pixel render with the user's -o modifiers.
        probe_argv, probe_path = task_args("probe", (rx, ry, 1, 1), None)
        farm.run([("probe", probe_argv)], "probe")
        probe = _read_spec(probe_path)
        roi = (rx, ry, rw, rh) if user_roi is not None else (
            probe.full_x, probe.full_y, probe.full_width, probe.full_height)
        strips = _strips(roi, a.tiles)
        # Tiles are written losslessly (piz); the user's compression (maybe
        # lossy) is applied once, to the stitched pixels, as a whole render.
        tiles = [task_args(f"tile{i:04d}", s, "piz") for i, s in enumerate(strips)]
        label = f"frame {frame} " if frame is not None else ""
        farm.run([(f"{label}tile {i} (rows {s[1]}-{s[1] + s[3] - 1})", argv)
                  for i, ((argv, _), s) in enumerate(zip(tiles, strips))], "tiles")

        x, y, w, h = roi
        pixels = None
        for (argv, path), (tx, ty, tw, th) in zip(tiles, strips):
            inp = oiio.ImageInput.open(path)
            if not inp:
                raise FarmError(f"cannot read tile '{path}': {oiio.geterror()}")
            s = inp.spec()
            if ((s.x, s.y, s.width, s.height) != (tx, ty, tw, th)
                    or (s.full_x, s.full_y, s.full_width, s.full_height)
                    != (probe.full_x, probe.full_y, probe.full_width, probe.full_height)
                    or tuple(s.channelnames) != tuple(probe.channelnames)
                    or s.format != probe.format):
                raise FarmError(f"tile '{path}' does not match the frame (windows, channels "
                                "or pixel type)")
            data = inp.read_image(s.format)
            inp.close()
            if data is None:
                raise FarmError(f"cannot read tile '{path}': {oiio.geterror()}")
            if pixels is None:
                pixels = np.empty((h, w, s.nchannels), dtype=data.dtype)
            pixels[ty - y:ty - y + th] = data.reshape(th, tw, s.nchannels)

        spec = oiio.ImageSpec(probe)
        spec.x, spec.y, spec.width, spec.height = x, y, w, h
        # The settings hash covers the roi: the probe's is not the frame's;
        # the whole-frame dry run's is (--skip-existing then skips it).
        spec.attribute("filmgrain:settings_hash", job["settings_hash"])
        fd, tmp_out = tempfile.mkstemp(prefix=f".{os.path.basename(output)}.", suffix=".exr",
                                       dir=out_dir)
        os.close(fd)
        out = oiio.ImageOutput.create(tmp_out)
        if not out or not out.open(tmp_out, spec) or not out.write_image(pixels):
            msg = out.geterror() if out else oiio.geterror()
            raise FarmError(f"cannot write '{output}': {msg}")
        if not out.close():
            raise FarmError(f"cannot write '{output}': {out.geterror()}")
        os.chmod(tmp_out, 0o666 & ~umask)
        os.replace(tmp_out, output)
        tmp_out = None
        con.info(f"wrote {output} ({w}x{h}"
                 + ("" if (w, h) == (probe.full_width, probe.full_height)
                    else f" of the {probe.full_width}x{probe.full_height} scan")
                 + f", {a.tiles} tiles) in {time.monotonic() - t0:.1f} s on {nworkers} workers")
    finally:
        if tmp_out is not None and os.path.exists(tmp_out):
            os.unlink(tmp_out)
        shutil.rmtree(tmp_dir, ignore_errors=True)


def _raise_stopped(signum, frame):
    raise Stopped(signum)


def _quiet_distributed_logs(quiet):
    """Dask's own log lines: warnings (a lost worker) unless -q."""
    level = "error" if quiet else "warning"
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", level)


def main(argv=None):
    """Entry point: returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    con = Console(quiet=False, force_progress=False)
    try:
        if "-h" in argv or "--help" in argv:
            sys.stdout.write(HELP)
            return 0
        fg_bin = resolve_filmgrain_bin(farm_bin_argument(argv))
        a = parse_args(argv, cli_options(fg_bin))
        con = Console(a.quiet, a.progress)
    except UsageError as e:
        con.error(e)
        return 1
    if a.threads is None:
        a.cli += ["--threads", "1"]
    _quiet_distributed_logs(a.quiet)

    previous = {s: signal.signal(s, _raise_stopped) for s in (signal.SIGINT, signal.SIGTERM)}
    client = cluster = None
    try:
        t0 = time.monotonic()
        jobs = dry_run(fg_bin, a.cli)
        sequence = jobs[0]["frame"] is not None
        if a.tiles > 1 and len(jobs) > 1:
            raise UsageError(f"--tiles {a.tiles} renders one frame: give no --frames or one "
                             f"frame (the frame list has {len(jobs)})")
        todo, up_to_date, missing = plan(a, jobs)
        for job in missing:
            con.info(f"warning: frame {job['frame']}: input '{job['input']}' does not exist: "
                     "skipped (--skip-missing)")
        if len(jobs) == 1 and up_to_date:
            con.info(f"'{up_to_date[0]['output']}' is up to date (same settings): skipped")
        # What the CLI would refuse from an input's header: said before any
        # worker starts, as the CLI's own sequence run stops at it.
        refused = [job for job in todo if job["error"]]
        if refused:
            job = refused[0]
            where = f"frame {job['frame']}: " if sequence else ""
            raise FarmError(f"{where}{job['error']}"
                            + (f" ({len(refused)} frames refused)" if len(refused) > 1 else ""))
        if not todo:
            if sequence and a.tiles == 1:
                con.info(f"sequence of {len(jobs)} frames: 0 rendered, {len(up_to_date)} up to "
                         f"date (skipped), {len(missing)} missing input (skipped) in "
                         f"{time.monotonic() - t0:.1f} s")
            return 0

        import cloudpickle
        from distributed import Client, LocalCluster
        if __name__ != "__main__":
            # Ship the task by value: workers need not import this module.
            cloudpickle.register_pickle_by_value(sys.modules[__name__])
        if a.scheduler:
            try:
                client = Client(a.scheduler, timeout=a.scheduler_timeout_s)
            except (OSError, TimeoutError) as e:
                raise FarmError(f"cannot connect to the scheduler {a.scheduler} within "
                                f"{a.scheduler_timeout_s:g} s: {e}")
            nworkers = len(client.scheduler_info().get("workers", {}))
            if nworkers == 0:
                con.info(f"no workers at {a.scheduler} yet: waiting for some to join")
        else:
            cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") \
                else (os.cpu_count() or 1)
            threads = int(a.threads) if a.threads and a.threads.isdigit() and int(a.threads) > 0 \
                else 1
            nworkers = a.workers or max(1, cores // threads)
            import logging
            cluster = LocalCluster(n_workers=nworkers, threads_per_worker=1, processes=True,
                                   dashboard_address=None,
                                   silence_logs=logging.ERROR if a.quiet else logging.WARNING)
            client = Client(cluster)
        env = {"OCIO": os.environ.get("OCIO")}
        farm = Farm(client, con, env)
        if a.tiles > 1:
            render_tiled(farm, a, fg_bin, con, nworkers, todo[0], t0)
            return 0
        rendered, skipped, lost_input = render_frames(farm, a, fg_bin, todo)
        if sequence:
            con.info(f"sequence of {len(jobs)} frames: {rendered} rendered, "
                     f"{len(up_to_date) + skipped} up to date (skipped), "
                     f"{len(missing) + lost_input} missing input (skipped) in "
                     f"{time.monotonic() - t0:.1f} s on {nworkers} workers")
        else:
            con.info(f"wrote {todo[0]['output']} in {time.monotonic() - t0:.1f} s on "
                     f"{nworkers} workers")
        return 0
    except UsageError as e:
        con.error(e)
        return 1
    except FarmError as e:
        con.error(e)
        return 1
    except (Stopped, KeyboardInterrupt) as e:
        signum = e.signum if isinstance(e, Stopped) else signal.SIGINT
        con.error(f"stopped by {signal.Signals(signum).name}: frames complete so far are "
                  "kept, nothing of the others is written")
        return 128 + signum
    finally:
        for s, h in previous.items():
            signal.signal(s, signal.SIG_IGN)
        try:
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
        except Exception:
            pass
        for s, h in previous.items():
            signal.signal(s, h)


if __name__ == "__main__":
    sys.exit(main())
