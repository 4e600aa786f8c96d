"""Shared pytest fixtures of every test folder (model/, light/, rendering/, anim/, io/, package/):
a GL context when EGL works here (tests marked `gl` skip otherwise), a renderer on it, a runner
for the benchmark smoke tests, and the GL-against-C++ check of exact-mode impostors.

The golden images (``data/``) and the Mitsuba references (``references/``) stay in this folder:
a test file one level down finds them as ``Path(__file__).resolve().parents[1] / "data"``."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
import cumuli.gl as cgl

_GL_OK, _GL_INFO = cgl.available()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if _GL_OK:
        return
    skip = pytest.mark.skip(reason=f"no headless OpenGL here: {_GL_INFO}")
    for item in items:
        if "gl" in item.keywords:
            item.add_marker(skip)


def pytest_report_header(config: pytest.Config) -> str:
    return f"cumuli GL: {_GL_INFO if _GL_OK else 'unavailable — ' + _GL_INFO}"


@pytest.fixture(scope="session")
def gl_context() -> Iterator[cgl.GLContext]:
    """One GL context for the whole session (tests needing it are marked `gl`)."""
    with cgl.GLContext() as ctx:
        yield ctx


@pytest.fixture(scope="module")
def renderer(gl_context: cgl.GLContext) -> Iterator[cu.Renderer]:
    """A `Renderer` on the session's GL context, one per test module (tests needing it are
    marked `gl`)."""
    with cu.Renderer(context=gl_context) as r:
        yield r


@pytest.fixture(scope="session")
def regen_references() -> bool:
    """True when reference images should be rewritten (CUMULI_REGEN=1)."""
    return os.environ.get("CUMULI_REGEN", "") == "1"


def _run_bench(script: str, out: Path, timeout: float = 600) -> str:
    """Run ``benchmarks/<script> --quick --out <out>`` in a fresh interpreter (plots to Agg);
    fail with its output unless it exits 0. Returns what it printed."""
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    cmd = [sys.executable, str(root / "benchmarks" / script), "--quick", "--out", str(out)]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert res.returncode == 0, res.stderr + res.stdout
    return res.stdout


@pytest.fixture(scope="session")
def run_bench() -> Callable[..., str]:
    """``run_bench(script, out, timeout=600)``: a benchmark's quick run, asserted to succeed;
    returns its stdout."""
    return _run_bench


def _exact_impostors_agree(
    renderer: cu.Renderer, scene: cu.Scene, cameras: list[cu.Camera], w: int, h: int
) -> tuple[np.ndarray, cu.ImpostorCache, cu.ImpostorCache]:
    """Render ``scene`` (exact impostor mode) from each camera in turn on GL and on the C++ twin,
    each backend keeping its own impostor cache, and assert that the frames agree: mean per
    channel ≤ 1e−5, max ≤ 1e−4. Returns the last GL frame and the two caches."""
    gl_cache, cpu_cache = cu.ImpostorCache(), cu.ImpostorCache()
    gl = np.zeros((h, w, 4), dtype=np.float32)
    for cam in cameras:
        gl = renderer.render(scene, cam, w, h, impostors=gl_cache)
        cpu = cu.render_cpu(scene, cam, w, h, impostors=cpu_cache)
        assert np.abs(gl - cpu).mean(axis=(0, 1)).max() <= 1e-5
        assert np.abs(gl - cpu).max() <= 1e-4
    return gl, gl_cache, cpu_cache


@pytest.fixture(scope="session")
def exact_impostors_agree() -> Callable[..., tuple[np.ndarray, cu.ImpostorCache, cu.ImpostorCache]]:
    """``exact_impostors_agree(renderer, scene, cameras, w, h)``: GL and C++ frames through
    impostor caches asserted to agree; returns ``(last GL frame, GL cache, C++ cache)``."""
    return _exact_impostors_agree
