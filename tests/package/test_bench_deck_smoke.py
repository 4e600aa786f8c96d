"""The deck benchmark runs in --quick mode and writes the documented JSON (speed not checked)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.gl
def test_bench_deck_quick_writes_json(tmp_path: Path) -> None:
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    script = str(ROOT / "benchmarks" / "bench_deck.py")
    res = subprocess.run(
        [sys.executable, script, "--quick", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=600, env=env,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr + res.stdout
    data = json.loads((tmp_path / "deck.json").read_text())
    assert data["benchmark"] == "deck" and data["quick"] is True
    assert data["lattice"] == [64, 12, 64] and data["machine"]["gl_renderer"]
    stages = {"bake", "light_paper", "light_physical", "shadow_own_step", "shadow_light_step",
              "wind_first_frame", "wind_next_frame"}  # fmt: skip
    draws = {f"draw_{m}_{b}" for m in ("paper", "physical") for b in ("gl", "cpu")}
    assert set(data["seconds"]) == stages | draws
    for entry in data["seconds"].values():
        assert entry["median"] > 0 and entry["n"] >= 1
    assert data["ratios"]["shadow_light_step_over_own_step"] > 0
    assert data["ratios"]["wind_first_frame_over_next_frame"] > 0
    assert (tmp_path / "deck.png").stat().st_size > 0
