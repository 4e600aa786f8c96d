"""The air benchmark runs in --quick mode and writes the documented JSON (frame times of both
modes on both backends, the air pass, the soft and hard shadow maps, the target; speed not
checked)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path


def test_bench_air_quick_writes_json_and_plot(
    tmp_path: Path, run_bench: Callable[..., str]
) -> None:
    stdout = run_bench("bench_air.py", tmp_path, timeout=600)
    data = json.loads((tmp_path / "air.json").read_text())
    assert (tmp_path / "air.png").stat().st_size > 1000
    assert data["benchmark"] == "air" and data["quick"] is True
    assert list(data["sizes"]) == ["160x120", "320x240"]
    for entry in data["sizes"].values():
        for name in ("gl_paper", "gl_physical", "cpu_paper", "cpu_physical", "air_pass_s"):
            spread = entry[name] if name == "air_pass_s" else entry[name]["wall_s"]
            assert 0 < spread["min"] <= spread["median"] <= spread["max"]
        for b in ("gl", "cpu"):
            assert entry[f"{b}_physical_over_paper"] > 0
            assert 0 < entry[f"air_share_of_{b}_physical"]
    maps = data["shadow_map"]
    assert maps["resolution"] == 64 and maps["soft_over_hard"] > 0
    for b in ("gl", "cpu"):
        t = data["targets"][f"{b}_physical_over_paper"]
        assert t["limit"] == 1.5 and t["reached"] is None and t["met"] is None
    assert "target gl_physical_over_paper" in stdout
