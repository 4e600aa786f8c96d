"""The equal-quality benchmark against Mitsuba runs in --quick mode and writes the documented
JSON (one view; speed not checked)."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests" / "references"))

import bench_fidelity  # noqa: E402


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
            ladder = eq["ladder_spp"]  # every power of two from 1 to at least 64
            assert eq["slope"] < 0 and ladder == [2**k for k in range(len(ladder))]
            assert ladder[-1] >= 64
            assert eq["spp"] > 0 and not math.isnan(eq["spp"])
            if view["mitsuba"]["available"]:
                assert eq["mitsuba_s"] >= view["mitsuba"]["t1_s"] > 0
                assert eq["speedup_whole"] < eq["speedup_draw"]
    for name in ("speedup_whole", "speedup_draw"):
        t = data["targets"][name]
        assert t["met"] is None and t["reached"] is None  # --quick measures no target
    assert "target speedup_whole" in stdout and "Mitsuba needs" in stdout


def _ladder(errors: dict[int, float]) -> dict[str, dict[str, float]]:
    return {str(n): {"block_median": e} for n, e in errors.items()}


def test_spp_needed_interpolates_within_the_ladder_and_extrapolates_beyond_it() -> None:
    power = _ladder({n: 0.2 * n**-0.5 for n in (1, 2, 4, 8, 16, 32)})
    # On a power law the log-log interpolation is exact, at the counts and between them.
    for n in (1.0, 3.0, 16.0, 24.0):
        got = bench_fidelity.spp_needed(power, "block_median", 0.2 * n**-0.5)
        assert got["spp"] == pytest.approx(n, rel=1e-9) and got["extrapolated"] is False
    assert bench_fidelity.spp_needed(power, "block_median", 0.2)["spp"] == pytest.approx(1.0)
    # Beyond the ladder: the fitted line (slope −½ here), said to be extrapolated.
    far = bench_fidelity.spp_needed(power, "block_median", 0.2 * 128**-0.5)
    assert far["extrapolated"] is True and far["spp"] == pytest.approx(128.0, rel=1e-6)
    assert far["slope"] == pytest.approx(-0.5)
    # A count whose error is noisier than the one before counts as that one (running minimum).
    bumpy = _ladder({1: 0.2, 2: 0.1, 4: 0.12, 8: 0.05})
    assert bench_fidelity.spp_needed(bumpy, "block_median", 0.1)["spp"] == pytest.approx(2.0)
    assert bench_fidelity.spp_needed(bumpy, "block_median", 0.075)["spp"] == pytest.approx(
        2.0 * 4.0 ** (math.log(0.1 / 0.075) / math.log(0.1 / 0.05))
    )
