"""The physical light step's benchmark runs in --quick mode and writes the documented JSON
(per stage, per cloud count, the growth exponents and the targets; speed not checked)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

from cumuli.light.physical import STAGES


def test_bench_physical_light_quick_writes_json_and_plot(
    tmp_path: Path, run_bench: Callable[..., str]
) -> None:
    stdout = run_bench("bench_physical_light.py", tmp_path, timeout=300)
    data = json.loads((tmp_path / "physical_light.json").read_text())
    assert (tmp_path / "physical_light.png").stat().st_size > 1000
    assert data["benchmark"] == "physical_light" and data["quick"] is True
    assert data["threads"] == 2 and data["counts"] == [1, 2, 4]
    assert data["stages"] == list(STAGES)
    for series in ("copies", "seeds"):
        rows = data["series"][series]
        for count in data["counts"]:
            row = rows[str(count)]
            wall = row["light_step_s"]
            assert wall["min"] <= wall["median"] <= wall["max"] and wall["n"] == data["repeats"]
            assert set(row["stages_s"]) == set(STAGES)
            # Every cloud extincts, marches its own sun lattice and solves its diffusion.
            for stage in ("extinction", "sun_depth", "sky", "diffusion"):
                assert row["stages_s"][stage] > 0
            assert sum(row["stages_share"].values()) == pytest.approx(1.0)
            assert row["per_cloud_ms"] == pytest.approx(1e3 * wall["median"] / count)
        # One cloud has no other upstream.
        assert rows["1"]["stages_s"]["upstream"] == 0.0
        growth = data["growth"][series]
        assert growth["exponent"] is not None and growth["last_over_one"] > 0
        assert growth["last_over_first_cpu"] > 0
        assert growth["last_over_first"] == pytest.approx(
            rows[str(data["counts"][-1])]["light_step_s"]["median"]
            / rows["1"]["light_step_s"]["median"]
        )
        assert set(growth["stage_exponents"]) == set(STAGES)
    # "One cloud" of the seeds series is the mean of each seed alone; the targets' ratios come
    # from one interleaved run of one and all (linearity), not from the series' rows.
    alone = data["seeds_alone_s"]
    assert len(alone) == data["counts"][-1] and min(alone) > 0
    assert data["growth"]["seeds"]["one_s"] == pytest.approx(sum(alone) / len(alone))
    linear = data["linearity"]
    assert linear["seeds"]["alone_s"] == alone
    for series in ("copies", "seeds"):
        row = linear[series]
        assert row["one_s"] > 0 and row["all_s"] > row["one_s"]
        assert row["ratio"] == pytest.approx(row["all_s"] / row["one_s"])
        assert data["growth"][series]["one_s"] == row["one_s"]
        assert data["growth"][series]["last_over_one"] == row["ratio"]
        assert data["growth"][series]["series_last_over_one"] > 0
    for name in ("per_default_cloud_ms", "sixteen_over_one_copies", "sixteen_over_one_seeds"):
        t = data["targets"][name]
        assert t["met"] is None and t["reached"] is None  # --quick measures no target
        assert t["limit"] > 0
    # The one-cloud scene with either noise version, each with its stage profile.
    versions = data["noise_versions"]
    assert sorted(versions) == ["v1", "v2"]
    for name, row in versions.items():
        assert row["version"] == int(name[1:])
        assert row["light_step_s"]["n"] == data["repeats"] and row["light_step_cpu_s"]["median"] > 0
        assert set(row["stages_ms"]) == set(STAGES) and row["stages_ms"]["sun_depth"] > 0
        assert sum(row["stages_share"].values()) == pytest.approx(1.0)
        assert row["slowest_stage"] in STAGES
        assert row["stages_ms"][row["slowest_stage"]] == max(row["stages_ms"].values())
    assert "noise v2" in stdout
    # The error against Mitsuba 3 beside the times, within the reference test's limits.
    err = data["mitsuba"]
    assert err["blocks"] > 200
    assert 0 < err["block_rel_median"] <= err["block_rel_p90"] <= 0.40
    assert abs(err["mean_ratio_minus_one"]) <= 0.10 and err["transmittance_mean_abs"] <= 0.01
    assert "against Mitsuba 3" in stdout
    assert "growth exponent" in stdout and "target per_default_cloud_ms" in stdout
    # A drifting sky: the first frame and the next (its light reused), for one cloud and the
    # largest field; the largest count of copies drifted with their noise against one.
    drift = data["wind"]
    for count in (1, data["counts"][-1]):
        row = drift[str(count)]
        assert row["first_frame_ms"] > 0 and row["next_frame_ms"] > 0
        assert row["ratio"] == pytest.approx(row["first_frame_ms"] / row["next_frame_ms"])
    copies = drift["drifted_copies"]
    assert copies["count"] == data["counts"][-1]
    assert copies["ratio"] == pytest.approx(copies["all_ms"] / copies["one_ms"])
    assert "copies drifted with their noise" in stdout
    # Translated copies of one volume (one light step, moved to each) against one of them.
    volumes = drift["volume_copies"]
    assert volumes["count"] == data["counts"][-1] and volumes["size"] > 0
    assert volumes["ratio"] == pytest.approx(volumes["all_ms"] / volumes["one_ms"])
    assert "translated copies of a" in stdout
