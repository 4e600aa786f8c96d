"""The paper-results benchmarks (issue: reproduce §4) run in --quick mode, write the documented
JSON, and report.py turns them into RESULTS.md. Speed is not checked, only the schema."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench_distance  # noqa: E402
import report  # noqa: E402


def quick_json(run_bench: Callable[..., str], name: str, out: Path) -> dict:
    """``bench_<name>.py --quick``'s JSON (its plot must exist too)."""
    run_bench(f"bench_{name}.py", out, timeout=600)
    assert (out / f"{name}.png").stat().st_size > 0
    return json.loads((out / f"{name}.json").read_text())


def assert_frame_entry(entry: dict) -> None:
    frame = entry["frame_s"]
    assert 0 < frame["min"] <= frame["median"] <= frame["max"]
    assert entry["frame_source"] in ("gl_timer", "wall")
    assert entry["fps"] == pytest.approx(1 / frame["median"])
    assert 0 <= entry["coverage"] <= 1


@pytest.mark.gl
def test_paper_benchmarks_quick_and_report(tmp_path: Path, run_bench: Callable[..., str]) -> None:
    out = tmp_path / "out"
    dist = quick_json(run_bench, "distance", out)
    assert dist["benchmark"] == "distance" and dist["quick"] is True
    assert dist["distances"] == bench_distance.QUICK_DISTANCES
    for size in dist["sizes"]:
        for name, curve in dist["curves"][size].items():
            assert [p["distance"] for p in curve] == dist["distances"], name
            for point in curve:
                assert_frame_entry(point)
        assert set(dist["table3_min_distance_30fps"][size]) == set(dist["curves"][size])
    assert [t["limit_ms"] for t in dist["targets"]] == [1.0, 4.0]

    speed = quick_json(run_bench, "speedups", out)
    assert set(speed["summary"]) == {"hollow", "light", "sort", "lod", "march"}
    assert (
        speed["hollow"]["runs"][0]["primitives"]["hollow"]
        < speed["hollow"]["runs"][0]["primitives"]["full"]
    )
    assert set(speed["summary"]["sort"]["value"]) == {"insertion", "quicksort", "oddeven", "none"}
    assert speed["summary"]["sort"]["value"]["insertion"] == 1.0
    for label, row in speed["light"]["threads"].items():
        assert row["naive_over_ndt_median"] > 0 and row["ndt_ms_median"] > 0, label

    scale = quick_json(run_bench, "scaling", out)
    assert [r["clouds"] for r in scale["clouds"]["rows"]] == [1, 4]
    for series in scale["primitives"]["series"].values():
        assert [r["primitives"] for r in series["rows"]] == [6, 48]
        assert set(series["linear_fit"]) == {"intercept_s", "slope_s_per_unit", "r2"}
        for row in series["rows"]:
            assert_frame_entry(row)
    search = scale["primitives"]["series"]["search"]["rows"]
    # Inert primitives leave the image alone: same coverage at 6 and 48 primitives.
    assert search[0]["coverage"] == pytest.approx(search[1]["coverage"], abs=0.01)

    results = tmp_path / "results"
    folder = report.archive(out, results)
    assert folder.name == "llvmpipe" or folder.parent == results
    text = report.write_report(results, tmp_path / "RESULTS.md").read_text()
    for heading in ("Fig. 16 / Table 3", "claimed speed-ups", "Scaling"):
        assert heading in text
    assert "quick mode" in text  # quick runs are flagged as not being results


def test_realtime_from_takes_the_tail_that_stays_real_time() -> None:
    curve = [{"distance": d, "fps": f} for d, f in [(0, 40), (8, 20), (16, 35), (32, 60)]]
    assert bench_distance.realtime_from(curve) == 16  # 0 is fast but 8 is not: from 16 on
    assert bench_distance.realtime_from([{"distance": 0, "fps": 10}]) is None
    assert bench_distance.realtime_from([{"distance": 5, "fps": 30}]) == 5


def test_machine_slug() -> None:
    assert report.machine_slug("llvmpipe (LLVM 15.0.6, 256 bits)") == "llvmpipe"
    assert report.machine_slug("NVIDIA H200/PCIe/SSE2") == "nvidia-h200"
    assert report.machine_slug(None) == "no-gl"


def test_report_without_results(tmp_path: Path) -> None:
    text = report.write_report(tmp_path / "missing", tmp_path / "R.md").read_text()
    assert "No results yet" in text
    with pytest.raises(FileNotFoundError, match="no benchmark JSON"):
        report.archive(tmp_path / "empty")


def test_gpu_goals_are_judged_on_an_h200_only() -> None:
    import _common as common

    def point(distance: float, ms: float) -> dict:
        s = ms / 1e3
        return {"distance": distance, "frame_s": {"median": s, "min": s, "max": s}}

    curves = {"1920x1080": {"cumulus": [point(0, 3.5), point(32, 1.2)]}}
    goals = bench_distance.gpu_targets(curves, "NVIDIA H200/PCIe/SSE2", [(1920, 1080)])
    assert [(g["measured_ms"], g["met"]) for g in goals] == [(1.2, False), (3.5, True)]
    other = bench_distance.gpu_targets(curves, "NVIDIA GeForce GTX 1050", [(1920, 1080)])
    assert [g["met"] for g in other] == [None, None]  # measured, but not on the goal's GPU
    soft = bench_distance.gpu_targets({}, "llvmpipe (LLVM 15)", [(480, 270)])
    assert all(g["measured_ms"] is None and g["met"] is None for g in soft)
    sizes, _ = common.render_sizes("NVIDIA H200/PCIe/SSE2", quick=False)
    assert sizes == [(640, 480), (800, 600), (1920, 1080)]
    sizes, note = common.render_sizes("llvmpipe (LLVM 15.0.6, 256 bits)", quick=False)
    assert sizes == [(160, 120), (200, 150), (480, 270)] and "divided by 4" in note
    assert common.gl_timer_reliable("NVIDIA H200") and not common.gl_timer_reliable("llvmpipe")


def test_report_lists_targets_of_benchmarks_without_a_section(tmp_path: Path) -> None:
    """A benchmark with no section of its own still has its targets in RESULTS.md, found at any
    depth of its JSON; a JSON without targets adds nothing."""
    folder = tmp_path / "results" / "llvmpipe"
    folder.mkdir(parents=True)
    target = {"limit": 1.5, "comparison": "<=", "reached": 2.25, "met": False}
    (folder / "newbench.json").write_text(json.dumps({
        "machine": {"gl_renderer": "llvmpipe (LLVM 15.0.6, 256 bits)", "date": "d"},
        "cases": {"gl": {"targets": {"ratio": target}}},
    }))  # fmt: skip
    (folder / "plain.json").write_text(json.dumps({"machine": {}, "seconds": 1.0}))
    text = report.write_report(tmp_path / "results", tmp_path / "R.md").read_text()
    assert "### Targets of bench_newbench" in text and "bench_plain" not in text
    assert "| cases.gl.ratio | <= 1.5 | 2.25 | **no** |" in text
