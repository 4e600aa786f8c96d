"""Shared pytest fixtures: a GL context when EGL works here (tests marked `gl` skip otherwise),
and a runner for the benchmark smoke tests."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

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
