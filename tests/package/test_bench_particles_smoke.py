"""The Harris particle benchmark runs in --quick mode and writes its JSON and plots: the light
pass (part a) and the frame times with and without impostors (parts b–d), which report.py reads."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_bench_particles_quick(tmp_path: Path, run_bench: Callable[..., str]) -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["MPLBACKEND"] = "Agg"
    run_bench("bench_particles.py", tmp_path, timeout=600)
    data = json.loads((tmp_path / "particles.json").read_text())
    assert (tmp_path / "particles.png").stat().st_size > 1000
    assert data["benchmark"] == "particles" and data["quick"] is True
    assert data["settings"]["particles"] == [1000]
    assert {c["light_resolution"] for c in data["cases"]} == {32, 64}
    for case in data["cases"]:
        methods = case["methods"]
        assert {"cpp_1_thread", "cpp_2_threads"} <= set(methods)
        for m in methods.values():
            spread = m.get("pass_s", m["call_s"])
            assert spread["min"] <= spread["median"] <= spread["max"]
            assert m["per_light_s"] > 0 and m["us_per_particle_light"] > 0
        assert case["ratios"]["cpp_1_over_cpp_2"] > 0
        if data["machine"]["gl_renderer"]:
            assert {"glsl_compute", "readback"} <= set(methods)
            assert methods["glsl_compute"]["max_abs_vs_cpp"] <= 1e-6
            assert methods["readback"]["max_abs_vs_cpp"] <= 1e-6
            assert case["ratios"]["readback_over_cpp_1"] > 0
    assert data["claims"]["few_thousand_under_1_s"]["readback_per_light_s_1e4"] is None
    frames = json.loads((tmp_path / "particle_frames.json").read_text())
    assert frames["benchmark"] == "particle_frames" and frames["quick"] is True
    if frames["machine"]["gl_renderer"]:
        assert (tmp_path / "particle_frames.png").stat().st_size > 1000
        sweep = frames["sweep"]
        assert {p["path"] for p in sweep["points"]} == {"orbit", "fly_through"}
        for p in sweep["points"]:
            assert p["direct_s"]["median"] > 0 and p["impostors_s"]["median"] > 0
            assert p["ratio"] == p["direct_s"]["median"] / p["impostors_s"]["median"]
            assert p["updates_per_frame"] >= 0 and p["updates_by_reason"]["missing"] > 0
        assert frames["big_clouds"]["runs"][0]["ratio"] > 0
        pop = frames["popping"]
        assert [t["tolerance_deg"] for t in pop["tolerances"]] == [0.15, 0.25, 0.5, 1.0]
        assert [f["factor"] for f in pop["inside"]["factors"]] == [1, 2, 4, 8]
    # report.py turns both files into the Harris section of RESULTS.md.
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import report

    lines = report.harris_lines({"particles": data, "particle_frames": frames})
    text = "\n".join(lines)
    assert "Harris 2002" in text and "read-back" in text
    if frames["machine"]["gl_renderer"]:
        assert "Fig. 8 sweep" in text and "7.5" in text and "tolerance" in text
