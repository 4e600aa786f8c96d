"""Helpers shared by the benchmark scripts: arguments, machine description, timing, JSON.

Every benchmark writes one JSON file (machine, GL renderer string, commit, date, medians of
repeats, methods compared as ratios within the same run) and a matplotlib PNG under
``benchmarks/out/`` unless ``--out`` says otherwise. Nothing here passes or fails on time.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = ROOT / "benchmarks" / "out"


def parse_args(description: str, argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The common command line: ``--quick`` (small sizes, few repeats) and ``--out DIR``."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help="small sizes and few repeats")
    parser.add_argument(
        "--out", type=Path, default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})"
    )
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def cpu_model() -> str:
    """The CPU's model name (from /proc/cpuinfo where available)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def usable_cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def git_commit() -> str:
    """HEAD of the repository the benchmarks live in, with ``-dirty`` when files are modified."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        return head + ("-dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def gl_renderer() -> tuple[str | None, str | None]:
    """(renderer string, None) when a headless GL context works here, else (None, reason)."""
    try:
        from cumuli import gl
    except Exception as exc:  # a broken install should not stop CPU benchmarks
        return None, f"cumuli.gl import failed: {exc}"
    ok, text = gl.available()
    return (text, None) if ok else (None, text)


def machine_info() -> dict[str, Any]:
    """Where and when the numbers were taken."""
    import numpy as np

    try:
        import cumuli

        version = cumuli.__version__
    except Exception:
        version = "unavailable"
    renderer, reason = gl_renderer()
    info: dict[str, Any] = {
        "cpu_model": cpu_model(),
        "cores": usable_cores(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "cumuli": version,
        "gl_renderer": renderer,
        "commit": git_commit(),
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
    }
    if reason:
        info["gl_unavailable_reason"] = reason
    if hasattr(os, "getloadavg"):
        info["load_average"] = list(os.getloadavg())
    return info


def time_repeats(
    fn: Callable[[], Any], repeats: int, warmup: int = 1
) -> tuple[list[float], list[float]]:
    """Wall and process-CPU seconds of ``repeats`` calls of ``fn`` after ``warmup`` calls."""
    for _ in range(warmup):
        fn()
    wall, cpu = [], []
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
    return wall, cpu


def spread(samples: Sequence[float]) -> dict[str, float]:
    """Median and spread of repeated measurements."""
    values = sorted(float(v) for v in samples)
    if not values:
        raise ValueError("no samples")
    q = statistics.quantiles(values, n=4) if len(values) >= 2 else [values[0]] * 3
    return {
        "median": statistics.median(values),
        "min": values[0],
        "max": values[-1],
        "iqr": q[2] - q[0],
        "n": len(values),
    }


def rate(count: int, seconds: dict[str, float]) -> dict[str, float]:
    """Throughput (items per second) at the median, best and worst of a timing spread."""
    return {
        "median": count / seconds["median"],
        "best": count / seconds["min"],
        "worst": count / seconds["max"],
    }


def write_json(path: Path, data: dict[str, Any]) -> Path:
    """Write ``data`` as indented JSON atomically (temporary in the same folder, then replace)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(data, fh, indent=2, sort_keys=False)
            fh.write("\n")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def pyplot():
    """matplotlib.pyplot on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def log(message: str) -> None:
    print(message, flush=True, file=sys.stdout)
