"""The Harris particle light-pass benchmark runs in --quick mode and writes its JSON and plot."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_particles_quick(tmp_path: Path) -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["MPLBACKEND"] = "Agg"
    res = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "bench_particles.py"),
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
