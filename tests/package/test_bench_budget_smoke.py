"""The budget benchmark runs in --quick mode and writes the documented JSON (speed not checked)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path


def test_bench_budget_quick_writes_json_and_plot(
    tmp_path: Path, run_bench: Callable[..., str]
) -> None:
    stdout = run_bench("bench_budget.py", tmp_path, timeout=300)
    data = json.loads((tmp_path / "budget.json").read_text())
    assert (tmp_path / "budget.png").stat().st_size > 1000
    assert data["benchmark"] == "budget" and data["quick"] is True
    assert set(data["cases"]) == {
        "scene_three_atlases", "field_2_20_instances", "physical_resolution_256",
        "density_volume_1024",
    }  # fmt: skip
    assert data["all_refused"] is True
    for name, case in data["cases"].items():
        assert case["refused"] and case["message"], name
        assert case["seconds"] >= 0 and case["rss_growth_bytes"] >= 0
        assert case["before"]["seconds"] > 0
    scene = data["cases"]["scene_three_atlases"]
    assert scene["estimate_bytes"] >= 3 << 30 and scene["file_bytes"] < 1 << 16
    assert data["limits"]["memory"] == 1 << 32
    accepted = data["accepted_scene"]
    assert accepted["estimate_bytes"] > 0 and accepted["seconds"] > 0
    for target in data["targets"].values():
        assert set(target) >= {"limit", "reached", "met"} and target["met"] in (True, False)
    assert "target" in stdout and "budget.json" in stdout
