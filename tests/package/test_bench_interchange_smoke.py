"""The interchange benchmark runs in --quick mode and writes the documented JSON (speed not
checked)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_bench_interchange_quick_writes_json(tmp_path: Path) -> None:
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    script = str(ROOT / "benchmarks" / "bench_interchange.py")
    res = subprocess.run(
        [sys.executable, script, "--quick", "--out", str(tmp_path)],
        capture_output=True, text=True, timeout=600, env=env,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr + res.stdout
    data = json.loads((tmp_path / "interchange.json").read_text())
    assert data["benchmark"] == "interchange" and data["quick"] is True
    assert {".vdb", ".vol"} <= set(data["formats"])
    for entry in data["formats"].values():
        assert entry["write_seconds"]["median"] > 0 and entry["bytes"] > 0
        assert entry["bit_exact"] is True
    assert data["formats"][".vdb"]["bytes"] < data["formats"][".vol"]["bytes"]
    assert data["targets"]["round_trip_bit_exact"]["met"] is True
    assert (tmp_path / "interchange.png").stat().st_size > 0
