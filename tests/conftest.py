"""Shared pytest fixtures of every test folder (model/, light/, rendering/, anim/, io/, package/):
a renderer on the session's GL context, a runner for the benchmark smoke tests, and the
GL-against-C++ check of exact-mode impostors. The GL context itself (``gl_context``), the `gl`
marker's skip and the image assertions come from the package's pytest plugin, ``cumuli.testing``,
the same one users get.

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

# Loaded by its entry point once cumuli is installed; named here for in-tree runs
# (PYTHONPATH=python). pytest registers a plugin once per name, so both ways give one copy.
pytest_plugins = ["cumuli.testing"]


@pytest.fixture(scope="module")
def renderer(gl_context: cgl.GLContext) -> Iterator[cu.Renderer]:
    """A `Renderer` on the session's GL context, one per test module (tests needing it are
    marked `gl`)."""
    with cu.Renderer(context=gl_context) as r:
        yield r


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
    # Imported here: a module-level import would load the plugin before `pytest_plugins` does.
    from cumuli.testing import assert_image_close, only

    gl_cache, cpu_cache = cu.ImpostorCache(), cu.ImpostorCache()
    gl = np.zeros((h, w, 4), dtype=np.float32)
    for cam in cameras:
        gl = renderer.render(scene, cam, w, h, impostors=gl_cache)
        cpu = cu.render_cpu(scene, cam, w, h, impostors=cpu_cache)
        assert_image_close(gl, cpu, **only(channel_mean_abs=1e-5, max_abs=1e-4))
    return gl, gl_cache, cpu_cache


@pytest.fixture(scope="session")
def exact_impostors_agree() -> Callable[..., tuple[np.ndarray, cu.ImpostorCache, cu.ImpostorCache]]:
    """``exact_impostors_agree(renderer, scene, cameras, w, h)``: GL and C++ frames through
    impostor caches asserted to agree; returns ``(last GL frame, GL cache, C++ cache)``."""
    return _exact_impostors_agree


@pytest.fixture
def counted(monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, int]]:
    """Calls of the physical light step's own stages (extinction lattice, sun lattice, sky
    visibility), from an empty memo: what a light step computed rather than reused."""
    from cumuli import _core
    from cumuli.light import memo
    from cumuli.light import physical as phys

    calls = {"extinction": 0, "sun": 0, "visibility": 0}
    originals = (phys.extinction_grid, _core.light_space_depth, _core.sky_visibility)

    def counter(name: str, fn: Callable) -> Callable:
        def wrapped(*a, **k):
            calls[name] += 1
            return fn(*a, **k)

        return wrapped

    monkeypatch.setattr(phys, "extinction_grid", counter("extinction", originals[0]))
    monkeypatch.setattr(_core, "light_space_depth", counter("sun", originals[1]))
    monkeypatch.setattr(_core, "sky_visibility", counter("visibility", originals[2]))
    memo.clear()
    yield calls
    memo.clear()
