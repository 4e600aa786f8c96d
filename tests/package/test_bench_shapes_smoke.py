"""The shapes benchmark runs in --quick mode and writes its JSON and plot (speed not checked)."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_bench_shapes_quick(tmp_path: Path, run_bench: Callable[..., str]) -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["MPLBACKEND"] = "Agg"
    stdout = run_bench("bench_shapes.py", tmp_path, timeout=300)
    data = json.loads((tmp_path / "shapes.json").read_text())
    assert (tmp_path / "shapes.png").stat().st_size > 1000
    assert data["benchmark"] == "shapes" and data["quick"] is True
    assert data["gaussian"]["paper_n35"]["wall_s"]["n"] == data["repeats"]
    assert [r["spheres"] for r in data["lsystem"]] == [128, 1024, 8192]
    assert [r["faces"] for r in data["mesh"]["sizes"]] == [560, 2240, 8960]
    for r in data["gaussian"]["sizes"]:
        assert r["containment_cost_ratio"] > 0
        w = r["with_containment"]["wall_s"]
        assert w["min"] <= w["median"] <= w["max"]
    assert "shapes.json" in stdout
