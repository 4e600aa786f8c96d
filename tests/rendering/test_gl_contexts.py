"""GL after fork, GL from several threads, several contexts in one thread, context reuse and the
first render's GPU time.

Mesa keeps its EGL display (and llvmpipe's rasteriser threads) per process: a child forked from a
process that made a GL context cannot draw (it waits forever for threads that were not copied),
so cumuli refuses GL there with `GLForkError`, which says to use the ``spawn`` start method. EGL
contexts are current in one thread at a time: every thread gets its own default context, and an
explicit context used from another thread raises `GLThreadError`.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import moderngl
import numpy as np
import pytest

import cumuli as cu
import cumuli.gl.context as cgl

pytestmark = pytest.mark.gl

ROOT = Path(__file__).resolve().parents[2]


def _scene() -> cu.Scene:
    return cu.Scene(
        [cu.gaussian_cumulus(n=6, seed=1)],
        noise=cu.Noise(seed=2, size=16),
        settings=cu.RenderSettings(lighting="paper"),
    )


# --- fork (item 1) ------------------------------------------------------------------------------
_POOL_SCRIPT = """
import concurrent.futures as cf, json, multiprocessing as mp, sys
import numpy as np
import cumuli as cu

scene = cu.Scene([cu.gaussian_cumulus(n=6, seed=1)], noise=cu.Noise(seed=2, size=16))
camera = scene.default_camera()


def render_one(backend):
    return cu.render(scene, camera, 24, 16, backend=backend)


def run(kind, method, backend):
    ctx = mp.get_context(method)
    try:
        if kind == "pool":
            with ctx.Pool(2) as pool:
                images = pool.map(render_one, [backend] * 3)
        else:
            with cf.ProcessPoolExecutor(2, mp_context=ctx) as ex:
                images = list(ex.map(render_one, [backend] * 3))
    except Exception as exc:
        return {"error": type(exc).__name__, "message": str(exc),
                "is_gl_error": isinstance(exc, cu.gl.GLUnavailableError)}
    return {"diff": max(float(np.abs(im - parent[backend]).max()) for im in images)}


if __name__ == "__main__":
    kind = sys.argv[1]
    parent = {b: render_one(b) for b in ("gl", "cpu")}  # GL is initialised in the parent
    out = {m + "-" + b: run(kind, m, b) for m, b in (("fork", "gl"), ("fork", "cpu"),
                                                      ("spawn", "gl"))}
    print("RESULT " + json.dumps(out))
"""


@pytest.mark.parametrize("kind", ["pool", "futures"])
def test_gl_in_a_forked_worker_raises_a_clear_error_instead_of_hanging(
    kind: str, tmp_path: Path
) -> None:
    script = tmp_path / "pools.py"
    script.write_text(textwrap.dedent(_POOL_SCRIPT))
    try:
        done = subprocess.run(
            [sys.executable, str(script), kind], capture_output=True, text=True, timeout=120,
            cwd=tmp_path,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        pytest.fail(f"a {kind} of forked GL workers hung")
    assert done.returncode == 0, done.stderr[-3000:]
    line = [x for x in done.stdout.splitlines() if x.startswith("RESULT ")][-1]
    out = json.loads(line.removeprefix("RESULT "))
    fork = out["fork-gl"]
    assert fork.get("error") == "GLForkError", fork
    assert fork["is_gl_error"]  # a GLUnavailableError: code that falls back to the CPU still does
    for hint in ("spawn", "fork", "backend='cpu'"):
        assert hint in fork["message"]
    assert out["fork-cpu"] == {"diff": 0.0}  # the C++ twin needs no GL: fork is fine
    assert out["spawn-gl"] == {"diff": 0.0}  # spawned workers make their own context


def test_a_context_used_after_fork_is_refused_not_touched(monkeypatch: pytest.MonkeyPatch) -> None:
    ctx = cgl.default_context()
    monkeypatch.setattr(cgl.os, "getpid", lambda: -12345)  # as a forked child sees it
    with pytest.raises(cgl.GLForkError, match="spawn"):
        cgl.fbm(cu.Noise(seed=1, size=8), np.zeros((4, 3), np.float32), context=ctx)
    with pytest.raises(cgl.GLForkError):
        cgl.GLContext()
    ok, reason = cgl.available()
    assert not ok and "spawn" in reason
    monkeypatch.undo()
    assert not ctx.closed  # the parent's context was not released by the child


# --- threads (item 3) ---------------------------------------------------------------------------
def test_every_thread_gets_its_own_default_context() -> None:
    scene = _scene()
    camera = scene.default_camera()
    noise = cu.Noise(seed=3, size=8)
    pts = np.random.default_rng(0).uniform(-2, 2, (64, 3)).astype(np.float32)
    main_img = cu.render(scene, camera, 24, 16)
    main_fbm = cgl.fbm(noise, pts)
    results: dict[int, tuple] = {}
    errors: list[BaseException] = []

    def work(k: int) -> None:
        try:
            results[k] = (
                cu.render(scene, camera, 24, 16),
                cgl.fbm(noise, pts),
                cu.render_volume(
                    np.ones((4, 4, 4), np.float32), np.ones((4, 4, 4, 4), np.float32),
                    ((0, 0, 0), (1, 1, 1)), cu.Camera((0.5, 0.5, -3), (0.5, 0.5, 0.5)), 8, 6,
                    backend="gl",
                ),
                cgl.default_context(),
            )  # fmt: skip
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    contexts = {id(r[3]) for r in results.values()} | {id(cgl.default_context())}
    assert len(contexts) == 4  # one per thread
    for img, fbm, vol, _ in results.values():
        np.testing.assert_array_equal(img, main_img)
        np.testing.assert_array_equal(fbm, main_fbm)
        assert vol.shape == (6, 8, 4) and np.isfinite(vol).all()


def test_an_explicit_context_used_from_another_thread_says_what_to_do() -> None:
    scene = _scene()
    camera = scene.default_camera()
    renderer = cu.Renderer()
    caught: list[BaseException] = []

    def work() -> None:
        try:
            renderer.render(scene, camera, 8, 8)
        except BaseException as exc:  # noqa: BLE001
            caught.append(exc)

    t = threading.Thread(target=work)
    t.start()
    t.join()
    renderer.close()
    assert len(caught) == 1 and isinstance(caught[0], cgl.GLThreadError), caught
    assert "cu.render" in str(caught[0]) and "thread" in str(caught[0])


# --- several contexts in one thread --------------------------------------------------------------
def test_a_second_context_in_the_same_thread_does_not_corrupt_the_first() -> None:
    scene = _scene()
    camera = scene.default_camera()
    with cu.Renderer(context=cgl.GLContext()) as first:
        before = first.render(scene, camera, 24, 16)
        with cgl.GLContext() as other:  # made current by EGL on creation
            cgl.fbm(cu.Noise(seed=5, size=8), np.zeros((3, 3), np.float32), context=other)
            after = first.render(scene, camera, 24, 16)
        first.gl.close()
    np.testing.assert_array_equal(after, before)


def test_rendering_on_a_closed_context_raises_a_cumuli_error() -> None:
    ctx = cgl.GLContext()
    renderer = cu.Renderer(context=ctx)
    ctx.close()
    with pytest.raises(RuntimeError, match="closed"):
        renderer.render(_scene(), _scene().default_camera(), 8, 8)
    renderer.close()


# --- context reuse (item 9) and the first render's GPU time -------------------------------------
def test_the_common_paths_reuse_one_context_per_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    scene = _scene()
    camera = scene.default_camera()
    cu.render(scene, camera, 8, 8)
    made: list[int] = []
    real = moderngl.create_context

    def counting(*args, **kwargs):
        made.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(moderngl, "create_context", counting)
    noise = cu.Noise(seed=1, size=8)
    for _ in range(5):
        with cu.Renderer() as r:
            r.render(scene, camera, 8, 8)
        assert cgl.available()[0]
        cgl.fbm(noise, np.zeros((2, 3), np.float32))
        cu.render(scene, camera, 8, 8)
    assert len(made) == 0


def test_last_gpu_ns_is_measured_from_the_first_render() -> None:
    scene = _scene()
    with cgl.GLContext() as ctx, cu.Renderer(context=ctx) as r:  # a fresh context
        r.render(scene, scene.default_camera(), 24, 16)
        assert isinstance(r.last_gpu_ns, int) and r.last_gpu_ns > 0
