"""The billboard benchmark runs in --quick mode and writes the documented JSON and plot (speed is
not checked)."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_bench_billboards_quick(tmp_path: Path, run_bench: Callable[..., str]) -> None:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["MPLBACKEND"] = "Agg"
    run_bench("bench_billboards.py", tmp_path, timeout=300)
    data = json.loads((tmp_path / "billboards.json").read_text())
    assert (tmp_path / "billboards.png").stat().st_size > 1000
    assert data["benchmark"] == "billboards" and data["quick"] is True
    for key in ("cpu_model", "cores", "gl_renderer", "commit", "date"):
        assert key in data["machine"]
    levels = data["generation_vs_levels"]
    boxes = [levels[k]["boxes"] for k in sorted(levels, key=int)]
    assert boxes == sorted(boxes) and boxes[0] < boxes[-1]
    for row in [*levels.values(), *data["generation_vs_boxes_per_level"].values()]:
        assert 0 < row["1_thread"]["min"] <= row["1_thread"]["median"] <= row["1_thread"]["max"]
    for row in data["caf_vs_boxes"].values():
        assert row["sum"]["median"] > 0 and row["union"]["median"] > 0
        assert row["union_over_sum"] == row["union"]["median"] / row["sum"]["median"]
    for n, row in data["weather_step_vs_instances"].items():
        assert row["step_s"]["median"] > 0 and abs(row["instances"] - int(n)) <= max(
            2, int(n) // 20
        )
    spearman = data["caf_vs_ndt"]["cumulus"]["spearman"]
    assert all(-1 <= v["sum"] <= 1 and -1 <= v["union"] <= 1 for v in spearman.values())
    render = data["render"]
    if data["machine"]["gl_renderer"] is None:
        assert render is None  # no GL here: the render parts say so and are skipped
        return
    assert render["size"] == ([160, 120] if render["software_gl"] else [640, 480])
    for row in render["render_vs_clouds"].values():
        assert row["gl"]["median"] > 0 and row["sprites_drawn"] > 0
        assert row["billboards"] >= row["sprites_drawn"]
    per_cloud = [
        r["billboards_per_cloud"] for r in render["render_vs_billboards_per_cloud"].values()
    ]
    assert per_cloud == sorted(per_cloud) and per_cloud[0] < per_cloud[-1]
    imp = render["impostors"]
    assert imp["status"] == "measured" and imp["size"] == render["size"]
    assert {(p["clouds"], p["path"]) for p in imp["points"]} == {
        (n, path) for n in (10, 40) for path in ("orbit", "fly_through")
    }
    for p in imp["points"]:
        for backend in ("gl", "cpu"):
            row = p[backend]
            assert row["ratio"] == row["direct_s"]["median"] / row["impostors_s"]["median"]
            assert 0 <= row["updates_per_frame"] <= row["impostors_per_frame"] + 1e-9
            assert row["mean_abs_error"]["median"] < 0.05  # the impostors show the clouds
    scenes = render["paper_scenes"]
    assert set(scenes) == {"cirrus", "nimbus", "rain", "table1"}
    assert scenes["cirrus"]["seed_boxes"] == 15 and scenes["cirrus"]["billboards"] == 50
    for name, row in scenes.items():
        measured = row["fps_mean"] if name == "table1" else row["fps_median"]
        assert row["reaches_paper_rate"] == (measured >= row["paper_hz"])
        assert row["ratio_to_paper"] == measured / row["paper_hz"]
        runs = ["gl_impostors"] + (
            ["gl_steady_light", "gl_steady_light_impostors"] if name == "table1"
            else ["cpu_twin", "cpu_impostors"]
        )  # fmt: skip
        for label in runs:
            r = row[label]
            fps = r["fps_mean"] if name == "table1" else r["fps_median"]
            assert r["reaches_paper_rate"] == (fps >= row["paper_hz"]) and fps > 0
    for name in ("nimbus", "rain"):
        slow = scenes[name]["slow"]
        assert slow["units_per_frame"] == 1.0
        assert slow["gl_impostors"]["fps_median"] > 0 and slow["cpu_impostors"]["fps_median"] > 0
    paper_rate = scenes["table1"]["paper_rate"]
    assert abs(paper_rate["dt"] - 1 / 27) < 1e-12
    for label in ("gl", "gl_impostors", "gl_steady_light", "gl_steady_light_impostors"):
        assert paper_rate[label]["reaches_paper_rate"] == (paper_rate[label]["fps_mean"] >= 27)
    # Under a steady light nothing is relit: only the wind and the weather's spawns update.
    day = scenes["table1"]
    assert "light" not in day["gl_steady_light_impostors"]["updates_by_reason"]
