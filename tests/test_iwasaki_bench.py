"""The animation benchmark runs in --quick mode and writes its JSON and plot (speed not checked)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_bench_animation_quick(tmp_path: Path) -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["MPLBACKEND"] = "Agg"
    res = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_animation.py"), "--quick", "--out",
         str(tmp_path)],
        capture_output=True, text=True, timeout=300, env=env,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr + res.stdout
    data = json.loads((tmp_path / "animation.json").read_text())
    assert (tmp_path / "animation.png").stat().st_size > 1000
    assert data["benchmark"] == "animation" and data["quick"] is True
    sizes = data["similarity"]["sizes"]
    assert {(r["n"], r["resolution"]) for r in sizes} == {
        (n, r) for n in (8, 16, 32) for r in (16, 24)
    }
    for r in sizes:
        w = r["threads_1"]["wall_s"]
        assert w["min"] <= w["median"] <= w["max"] and w["n"] == data["repeats"]
    assert data["similarity"]["numpy_reference"]["numpy_over_cpp"] > 0
    assert [r["resolution"] for r in data["optical_depth"]] == [12, 16, 24]
    acc = data["sky_accuracy"]
    assert {(r["sh_order"], r["shexp"]) for r in acc} == {
        (o, m) for o in (2, 3, 4) for m in ("fit", "squaring")
    }
    assert all(r["median_rel_error"] >= 0 for r in acc)
    frame = data["frame"]
    assert frame["frame_total_s"] > 0
    assert ("render_gl" in frame) == (data["machine"]["gl_renderer"] is not None)
    assert "animation.json" in res.stdout
