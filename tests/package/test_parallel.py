"""The core's parallel loops and the worker pool they borrow (cpp/include/cumuli/parallel.hpp).

Loops reuse one pool of threads per process instead of starting threads each time. What must hold:
results never depend on which or how many threads ran them; a loop started while the pool is busy
(from another Python thread) still runs and gives the same result; a child made by fork() after
the parent used the pool does not wait for threads it does not have; Ctrl-C stops a long C++
render between its chunks, not when it ends.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np

import cumuli as cu

SUN = (0.3, 0.8, 0.2)


def _grid(threads: int, method: str = "shared") -> np.ndarray:
    cloud = cu.gaussian_cumulus(n=12, seed=3)
    noise = cu.Noise(seed=5, size=32)
    return np.asarray(
        cu.light_grid(cloud, SUN, noise, resolution=12, method=method, threads=threads)
    )


def _points() -> np.ndarray:
    return np.random.default_rng(1).uniform(-40.0, 40.0, (20000, 3)).astype(np.float32)


def test_more_threads_than_cores_and_repeated_loops_give_the_same_bits() -> None:
    noise = cu.Noise(seed=5, size=32)
    one = noise.fbm(_points(), threads=1)
    for threads in (2, 7, 3, 2):  # the pool grows to 6 helpers, then lends fewer of them
        assert np.array_equal(noise.fbm(_points(), threads=threads), one)
        assert np.array_equal(_grid(threads), _grid(1))


def test_loops_started_from_several_python_threads_at_once_match_the_serial_results() -> None:
    expected = {m: _grid(1, m) for m in ("shared", "ndt")}
    fbm_expected = cu.Noise(seed=5, size=32).fbm(_points(), threads=1)
    failures: list[str] = []
    start = threading.Barrier(4)

    def run(index: int) -> None:
        start.wait()
        for round_ in range(5):
            method = ("shared", "ndt")[(index + round_) % 2]
            if not np.array_equal(_grid(2, method), expected[method]):
                failures.append(f"thread {index}, round {round_}: {method} grid differs")
            if not np.array_equal(
                cu.Noise(seed=5, size=32).fbm(_points(), threads=2), fbm_expected
            ):
                failures.append(f"thread {index}, round {round_}: fbm differs")

    workers = [threading.Thread(target=run, args=(i,)) for i in range(4)]
    for w in workers:
        w.start()
    for w in workers:
        w.join(timeout=120)
    assert not any(w.is_alive() for w in workers), "a loop never finished"
    assert failures == []


_FORK_SCRIPT = """
import os, sys
import numpy as np
import cumuli as cu

noise = cu.Noise(seed=5, size=32)
points = np.random.default_rng(1).uniform(-40, 40, (20000, 3)).astype(np.float32)
parent = noise.fbm(points, threads=2)  # the parent's pool has its threads now
pid = os.fork()
if pid == 0:
    child = noise.fbm(points, threads=2)
    again = noise.fbm(points, threads=3)
    os._exit(0 if np.array_equal(child, parent) and np.array_equal(again, parent) else 3)
_, status = os.waitpid(pid, 0)
print("CHILD", os.waitstatus_to_exitcode(status))
print("PARENT", int(np.array_equal(noise.fbm(points, threads=2), parent)))
"""


def test_a_forked_child_runs_parallel_loops_without_its_parents_threads(tmp_path: Path) -> None:
    script = tmp_path / "fork_pool.py"
    script.write_text(textwrap.dedent(_FORK_SCRIPT))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=60, cwd=tmp_path
    )
    assert done.returncode == 0, done.stderr
    assert "CHILD 0" in done.stdout, done.stdout + done.stderr
    assert "PARENT 1" in done.stdout, done.stdout + done.stderr


# --- Ctrl-C in a long C++ call ----------------------------------------------------------------
_SIGINT_SCRIPT = """
import os, signal, sys, threading, time
import cumuli as cu
from cumuli.demo import default_scene

# Python's own Ctrl-C handler, whatever this process inherited: a shell that starts a job in the
# background (`cmd &` without job control) starts it with SIGINT ignored.
signal.signal(signal.SIGINT, signal.default_int_handler)
scene = default_scene()
lit = cu.prepare_light(scene)
camera = scene.default_camera()
start = time.perf_counter()
cu.render(lit, camera, 320, 240, backend="cpu")
full = (time.perf_counter() - start) * 64  # the interrupted render is 64 times larger
threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
start = time.perf_counter()
try:
    cu.render(lit, camera, 2560, 1920, backend="cpu")
    print("FINISHED", time.perf_counter() - start, full)
except KeyboardInterrupt:
    print("INTERRUPTED", time.perf_counter() - start, full)
"""


def test_ctrl_c_stops_a_long_cpu_render_early(tmp_path: Path) -> None:
    script = tmp_path / "interrupt.py"
    script.write_text(textwrap.dedent(_SIGINT_SCRIPT))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    word, took, full = done.stdout.split()
    assert word == "INTERRUPTED"
    # Honoured between chunks of rows, not when the render ends: well before the estimate of
    # the whole render (measured in the same run on an image 64 times smaller). The image is
    # large enough that the signal (sent after 0.2 s) lands early in it on a fast machine too.
    assert float(took) < 0.5 * float(full), (took, full)
