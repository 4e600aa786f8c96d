"""The viewer benchmark runs in --quick mode and writes the documented JSON (speed not checked)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.gl
def test_bench_viewer_quick_writes_json(tmp_path: Path) -> None:
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    script = str(ROOT / "benchmarks" / "bench_viewer.py")
    res = subprocess.run(
        [sys.executable, script, "--quick", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=600, env=env,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr + res.stdout
    data = json.loads((tmp_path / "viewer.json").read_text())
    assert data["benchmark"] == "viewer" and data["quick"] is True
    assert data["preview_size"] == [120, 68] and data["full_size"] == [320, 180]
    assert set(data["cases"]) == {f"{b}_{m}" for b in ("gl", "cpu") for m in ("paper", "physical")}
    for case in data["cases"].values():
        assert case["preview_fps"] > 0 and case["full_seconds"]["median"] > 0
        assert case["preview_fps_full_march"] > 0 and case["light_seconds"] > 0
        for t in case["targets"].values():
            assert t["reached"] is None and t["met"] is None  # --quick judges nothing
    assert (tmp_path / "viewer.png").stat().st_size > 0
