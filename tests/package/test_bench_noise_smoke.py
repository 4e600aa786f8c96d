"""The noise benchmark runs in --quick mode and writes the documented JSON (speed not checked)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from cumuli.noise import DEFAULT_VERSION

ROOT = Path(__file__).resolve().parents[2]


def simd_level_now() -> str:
    from cumuli.noise import simd_level

    return simd_level()


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    env["MPLBACKEND"] = "Agg"
    return env


def test_bench_noise_quick_writes_json_and_plot(
    tmp_path: Path, run_bench: Callable[..., str]
) -> None:
    stdout = run_bench("bench_noise.py", tmp_path, timeout=300)
    data = json.loads((tmp_path / "noise.json").read_text())
    assert (tmp_path / "noise.png").stat().st_size > 1000

    assert data["benchmark"] == "noise" and data["quick"] is True
    assert data["points"] == 100_000 and data["octaves"] == 5
    machine = data["machine"]
    for key in ("cpu_model", "cores", "gl_renderer", "commit", "date", "python", "numpy"):
        assert key in machine
    assert machine["cores"] >= 1 and len(machine["commit"]) >= 7

    methods = data["methods"]
    assert {"cpp_1_thread", "cpp_2_threads"} <= set(methods)
    assert methods["cpp_1_thread"]["noise_version"] == DEFAULT_VERSION == 2
    for m in methods.values():
        for stat in ("median", "min", "max", "iqr", "n"):
            assert stat in m["wall_s"]
        assert m["wall_s"]["n"] == data["repeats"]
        assert m["wall_s"]["min"] <= m["wall_s"]["median"] <= m["wall_s"]["max"]
        assert m["samples_per_s"]["median"] > 0
    if machine["gl_renderer"]:
        for key in ("glsl_texture", "glsl_exact"):
            assert key in methods
            assert "gpu_query_s" in methods[key] and "dispatch_wall_s" in methods[key]
            assert methods[key]["renderer"] == machine["gl_renderer"]
        if "llvmpipe" in machine["gl_renderer"].lower():
            # Timed again in child processes with LP_NUM_THREADS=1 and 2.
            assert data["llvmpipe_threads"] == [1, 2], data["skipped"]
            for key in ("glsl_texture", "glsl_exact"):
                for n, suffix in ((1, "1_thread"), (2, "2_threads")):
                    m = methods[f"{key}_{suffix}"]
                    assert m["llvmpipe_threads"] == n
                    assert m["renderer"] == machine["gl_renderer"]
                    assert m["gpu_samples_per_s"]["median"] > 0
                    # The child counted the driver's threads: the variable took effect.
                    assert m["llvmpipe_threads_running"] in (n, None)
                ratio = data["ratios"][f"{key}_2_threads_over_1"]
                one = methods[f"{key}_1_thread"]["gpu_samples_per_s"]["median"]
                two = methods[f"{key}_2_threads"]["gpu_samples_per_s"]["median"]
                assert ratio == pytest.approx(two / one)
                assert data["ratios"][f"{key}_2_threads_over_1_wall"] > 0
        else:
            assert "glsl_llvmpipe_threads" in data["skipped"]
    else:
        assert "glsl" in data["skipped"]
    if "pyfastnoiselite" in methods:
        assert "cpp_1_thread_over_fastnoise" in data["ratios"]
        assert data["targets"]["cpp_per_thread_vs_fastnoise"]["met"] in (True, False)
    if "pyfastnoisesimd" in methods:
        assert methods["pyfastnoisesimd"]["samples_per_s"]["median"] > 0
        # The target judges the default kernel: the default noise version's (the hash) on the
        # widest level, with the table kernel (version 1) as its baseline.
        t = data["targets"]["cpp_per_thread_vs_fastnoisesimd"]
        assert t["limit"] == 1.0 and t["met"] == (t["reached"] >= 1.0)
        simd_cpu = methods["pyfastnoisesimd"]["samples_per_cpu_s"]
        default = methods["cpp_1_thread_" + _default_kernel(methods)]
        assert t["reached"] == pytest.approx(default["samples_per_cpu_s"] / simd_cpu)
        assert f"noise version {DEFAULT_VERSION}" in t["measure"]
        widest = simd_level_now()
        if widest != "scalar":
            assert _default_kernel(methods) == f"{widest}_hash"
            table = methods[f"cpp_1_thread_{widest}_{data['simd_fetch']}"]
            assert "version 1" in t["baseline"]["method"]
            assert t["baseline"]["reached"] == pytest.approx(table["samples_per_cpu_s"] / simd_cpu)
        assert "hash_per_thread_vs_fastnoisesimd" not in data["targets"]  # the same, now
    else:  # it builds only without pip's build isolation: the output says so
        assert "pyfastnoisesimd" in data["skipped"]
        assert "no-build-isolation" in data["skipped"]["pyfastnoisesimd"]
    assert data["ratios"]["cpp_2_threads_over_1"] > 0
    # The thread counts timed warm (the target) and cold (each 2-thread call after a 1-thread one).
    assert {"cpp_1_thread_cold", "cpp_2_threads_cold"} <= set(methods)
    cold = data["ratios"]["cpp_2_threads_over_1_cold"]
    assert cold == pytest.approx(
        methods["cpp_2_threads_cold"]["samples_per_s"]["median"]
        / methods["cpp_1_thread_cold"]["samples_per_s"]["median"]
    )
    assert data["targets"]["cpp_2_threads_over_1"]["reached_cold"] == cold
    # Every kernel this CPU runs, each fetch of each wide level.
    from cumuli.noise import SIMD_FETCHES, simd_levels

    for level in simd_levels()[1:]:
        for fetch in SIMD_FETCHES:
            assert methods[f"cpp_1_thread_{level}_{fetch}"]["simd_fetch"] == fetch
        assert methods[f"cpp_1_thread_{level}_hash"]["samples_per_s"]["median"] > 0
    assert "target" in stdout and "noise.json" in stdout


def _default_kernel(methods: dict) -> str:
    """The key suffix of the default kernel (the widest level and, for the default noise version,
    its fetch or ``hash``)."""
    m = methods["cpp_1_thread"]
    return m["simd_level"] if m["simd_fetch"] is None else f"{m['simd_level']}_{m['simd_fetch']}"


def test_run_all_passes_quick_and_out_through(tmp_path: Path) -> None:
    res = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "run_all.py"),
            "--quick",
            "--out",
            str(tmp_path),
            "noise",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        env=_env(),
    )
    assert res.returncode == 0, res.stderr + res.stdout
    assert json.loads((tmp_path / "noise.json").read_text())["quick"] is True
    bad = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "run_all.py"), "no_such_bench"],
        capture_output=True,
        text=True,
        timeout=60,
        env=_env(),
    )
    assert bad.returncode == 2 and "no benchmark matches" in bad.stderr
