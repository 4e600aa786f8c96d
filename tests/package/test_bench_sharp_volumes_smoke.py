"""The sharp-volume benchmark runs in --quick mode and writes the documented JSON (speed not
checked)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.gl
def test_bench_sharp_volumes_quick_writes_json(tmp_path: Path) -> None:
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    script = str(ROOT / "benchmarks" / "bench_sharp_volumes.py")
    res = subprocess.run(
        [sys.executable, script, "--quick", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=600, env=env,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr + res.stdout
    data = json.loads((tmp_path / "sharp_volumes.json").read_text())
    assert data["benchmark"] == "sharp_volumes" and data["quick"] is True
    assert data["resolutions"] == [16, 32] and data["machine"]["gl_renderer"]
    names = {f"{r}_{read}_{b}" for r in (16, 32) for read in ("linear", "cubic", "sharp")
             for b in ("gl", "cpu")}  # fmt: skip
    assert set(data["seconds"]) == names
    for entry in data["seconds"].values():
        assert entry["median"] > 0 and entry["n"] >= 1
    assert all(v > 0 for v in data["ratios"].values())
    cells = data["targets"]["cell_edges_cubic_over_linear"]
    assert cells["reached"] > 0 and cells["met"] in (True, False)
    assert data["targets"]["frame_64_luminance_spread"]["met"] is None  # not measured quick
    assert (tmp_path / "sharp_volumes.png").stat().st_size > 0
