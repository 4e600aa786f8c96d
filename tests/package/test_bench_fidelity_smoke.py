"""The equal-quality benchmark against Mitsuba runs in --quick mode and writes the documented
JSON (one view; speed not checked)."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path


def test_bench_fidelity_quick_writes_json_and_plot(
    tmp_path: Path, run_bench: Callable[..., str]
) -> None:
    stdout = run_bench("bench_fidelity.py", tmp_path, timeout=600)
    data = json.loads((tmp_path / "fidelity.json").read_text())
    assert (tmp_path / "fidelity.png").stat().st_size > 1000
    assert data["benchmark"] == "fidelity" and data["quick"] is True
    assert data["size"] == [160, 120] and len(data["views"]) == 1
    for view in data["views"].values():
        err = view["cumuli_error"]
        assert err["blocks"] >= 100
        assert 0 < err["block_median"] <= err["block_p90"]
        assert 0 < err["pixel_median"]
        times = view["cumuli_s"]
        assert 0 < times["draw"]["median"] < times["whole"]["median"]
        for metric in ("block_median", "block_p90", "pixel_median"):
            eq = view["equal_quality"][metric]
            assert eq["cumuli_error"] == err[metric]
            assert eq["slope"] < 0 and eq["ladder_spp"][:3] == [1, 2, 4]
            assert eq["spp"] > 0 and not math.isnan(eq["spp"])
            if view["mitsuba"]["available"]:
                assert eq["mitsuba_s"] >= view["mitsuba"]["t1_s"] > 0
                assert eq["speedup_whole"] < eq["speedup_draw"]
    for name in ("speedup_whole", "speedup_draw"):
        t = data["targets"][name]
        assert t["met"] is None and t["reached"] is None  # --quick measures no target
    assert "target speedup_whole" in stdout and "Mitsuba needs" in stdout
