"""The CPU-marcher benchmark runs in --quick mode and writes its JSON and plot (speed unchecked)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_bench_render_cpu_quick_writes_json_and_plot(tmp_path: Path) -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["MPLBACKEND"] = "Agg"
    res = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_render_cpu.py"), "--quick", "--out",
         str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr + res.stdout
    data = json.loads((tmp_path / "render_cpu.json").read_text())
    assert (tmp_path / "render_cpu.png").stat().st_size > 1000
    assert data["benchmark"] == "render_cpu" and data["quick"] is True
    assert data["image"] == [96, 72] and data["threads"][0] == 1
    shapes = {"gaussian_cumulus", "metaball_cumulus", "lsystem_cloud", "mesh_cloud"}
    assert set(data["methods"]) == {f"{s}/{m}" for s in shapes for m in ("paper", "union")}
    gl = data["machine"]["gl_renderer"]
    for key, entry in data["methods"].items():
        for t in data["threads"]:
            stat = entry[f"cpu_{t}t_wall_s"]
            assert stat["n"] == data["repeats"] and 0 < stat["min"] <= stat["median"] <= stat["max"]
        assert ("gl_wall_s" in entry) == bool(gl)
        assert data["ratios"][key]["cpu_1t_over_all"] > 0
    for shape in shapes:  # the physical mode against the paper mode, per scene
        t = data["lighting"][shape]["cpu_physical_over_paper"]
        assert t["limit"] == 1.5 and t["reached"] > 0 and t["met"] == (t["reached"] <= 1.5)
    # The 1080p frame on 2 threads, per noise version (quick: a smaller frame, no verdict).
    hd = data["hd"]
    assert hd["image"] == [480, 270] and hd["threads"] == 2
    for version in ("1", "2"):
        v = hd["versions"][version]
        assert v["wall_s"]["median"] > 0 and v["fbm_evaluations"] > 0 and v["fbm_bulk_share"] > 0
    target = data["targets"]["hd_1080p_2_threads_s"]
    assert target["limit"] == 0.6 and target["reached"] is None and target["met"] is None
