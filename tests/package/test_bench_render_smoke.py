"""The render benchmark runs in --quick mode and writes the documented JSON (speed not checked)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.gl
def test_bench_render_quick_writes_json(tmp_path: Path) -> None:
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    res = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "bench_render.py"),
            "--quick",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )
    assert res.returncode == 0, res.stderr + res.stdout
    data = json.loads((tmp_path / "render.json").read_text())
    assert data["benchmark"] == "render" and data["quick"] is True
    assert data["sizes"] == ["160x120", "320x240"]
    assert data["machine"]["gl_renderer"]
    for size in data["sizes"]:
        methods = data["methods"][size]
        assert set(methods) == {"gl_paper", "gl_union", "cpu_paper", "cpu_union"}
        for entry in methods.values():
            wall = entry["wall_s"]
            assert 0 < wall["min"] <= wall["median"] <= wall["max"]
        ratios = data["ratios"][size]
        for key in ("gl_union_over_paper", "cpu_union_over_paper", "gl_wall_over_cpu_wall_paper"):
            assert ratios[key] > 0
        # The physical mode against the paper mode, as the target (speed not checked).
        light = data["lighting"][size]
        for key in ("gl_physical_over_paper", "cpu_physical_over_paper"):
            t = light[key]
            assert t["limit"] == 1.5 and t["reached"] > 0 and t["met"] == (t["reached"] <= 1.5)
