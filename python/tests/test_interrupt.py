"""Ctrl-C stops a render (KeyboardInterrupt), and the GIL is released while
a render runs. ctest runs this file serially (RUN_SERIAL): it measures
times."""

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import filmgrain
from conftest import scene_pixels
from fgtest import reaped

# A render that takes minutes: the exact engine over a whole Super 35 frame.
LONG_RENDER = textwrap.dedent("""
    import sys
    import numpy as np
    import filmgrain
    pixels = np.full((480, 640, 3), 0.18, np.float32)
    print("rendering", flush=True)
    try:
        filmgrain.render(pixels, engine="exact", width_mm=24.89)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
        sys.exit(3)
    print("finished", flush=True)
""")

# Ctrl-C is checked about ten times a second (the operator's progress
# callback); a stop within this many seconds leaves room for a loaded machine.
STOP_WITHIN_S = 5.0


def test_ctrl_c_stops_a_render():
    with reaped(subprocess.Popen([sys.executable, "-c", LONG_RENDER], stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE, text=True, env=dict(os.environ))) as proc:
        assert proc.stdout.readline().strip() == "rendering"
        time.sleep(1.0)  # well into the render
        assert proc.poll() is None, "the render ended before it was interrupted"
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
        took = time.monotonic() - sent
    assert "interrupted" in out, (out, err)
    assert proc.returncode == 3, (proc.returncode, err)
    assert took < STOP_WITHIN_S, f"stopped {took:.2f} s after SIGINT"


def test_the_gil_is_released_while_rendering():
    """Another Python thread keeps running during a render: counted from
    the render's first progress report (it is then inside the operator)
    until it returns. With the GIL held, the count would stay near zero."""
    pixels = scene_pixels()
    started = threading.Event()
    result = {}

    def work():
        # The paper-scale stock: a second or two grain by grain (the
        # default's 50 grains/um^2 a layer would take minutes).
        result["negative"] = filmgrain.render(pixels, stock="color-negative", width_mm=1.0,
                                              engine="exact", progress=lambda f: started.set())

    thread = threading.Thread(target=work)
    thread.start()
    assert started.wait(60)
    count, t0 = 0, time.monotonic()
    while thread.is_alive():
        count += 1
        time.sleep(0.001)
    elapsed = time.monotonic() - t0
    thread.join()
    assert "negative" in result
    assert elapsed > 0.2, f"the render left too little time ({elapsed:.2f} s) to measure"
    # ~1 ms sleeps: a free main thread counts about elapsed / 1 ms; require
    # one count per 20 ms (a loaded machine's scheduling), at least 10.
    assert count >= max(10, 0.05 * elapsed / 0.001), (count, elapsed)
