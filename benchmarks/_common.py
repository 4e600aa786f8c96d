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


def interleaved_repeats(
    fns: dict[str, Callable[[], Any]], repeats: int, warmup: int = 1, settle: int = 0
) -> dict[str, tuple[list[float], list[float]]]:
    """Like :func:`time_repeats` for several functions, run round-robin (A, B, A, B, ...) so that
    a slow drift of a shared machine touches them alike; ``{name: (wall, cpu)}``.

    ``settle`` untimed calls precede each timed one: functions whose working sets differ (one
    kernel's table evicting another's from the caches) are then timed with warm caches, as a user
    calling one of them alone sees it, not with the caches the previous function left.
    """
    for fn in fns.values():
        for _ in range(warmup):
            fn()
    out: dict[str, tuple[list[float], list[float]]] = {name: ([], []) for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            for _ in range(settle):
                fn()
            c0, w0 = time.process_time(), time.perf_counter()
            fn()
            out[name][0].append(time.perf_counter() - w0)
            out[name][1].append(time.process_time() - c0)
    return out


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


def target(limit: float, reached: float | None, comparison: str, **extra: Any) -> dict[str, Any]:
    """One issue target as the benchmarks report it: ``{limit, comparison, reached, met}`` plus
    ``extra`` (e.g. ``baseline``: today's method and the ratio to it). ``reached`` None means the
    run did not measure it (``--quick``): ``met`` is then None, not a verdict."""
    if comparison not in ("<=", ">="):
        raise ValueError(f"comparison must be '<=' or '>=', got {comparison!r}")
    met = None
    if reached is not None:
        met = bool(reached <= limit) if comparison == "<=" else bool(reached >= limit)
    return {"limit": limit, "comparison": comparison, "reached": reached, "met": met, **extra}


def show_target(name: str, t: dict[str, Any], unit: str = "") -> str:
    """One line for a :func:`target`: limit, what was reached, the verdict and any baseline."""
    verdict = {True: "met", False: "MISSED", None: "-"}[t["met"]]
    got = "not measured (--quick)" if t["reached"] is None else f"{t['reached']:.4g}{unit}"
    line = f"target {name}: {t['comparison']} {t['limit']:.4g}{unit}, reached {got} [{verdict}]"
    base = t.get("baseline")
    if base and base.get("reached") is not None:
        line += f"; today's {base['method']}: {base['reached']:.4g}{unit}"
        if base.get("ratio") is not None:
            line += f" ({base['ratio']:.3g}x)"
    return line


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


def save_figure(fig: Any, path: Path, dpi: int = 100) -> Path:
    """Save a matplotlib figure as PNG atomically (a hidden temporary beside it, then replace)
    and close it."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp.png")
    try:
        fig.savefig(tmp, dpi=dpi)
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)
        pyplot().close(fig)
    return path


def log(message: str) -> None:
    print(message, flush=True, file=sys.stdout)


# --- frame timing shared by the render-pass benchmarks ------------------------------------------
def gl_timer_reliable(renderer_string: str | None) -> bool:
    """Whether GL_TIME_ELAPSED measures the draw here.

    Mesa's software rasterisers run the fragment work on their own threads after the query has
    ended (llvmpipe reported 12 ms for a 3 s draw), so there frame times are wall times of the
    render call (draw + ``finish`` + read-back).
    """
    text = str(renderer_string).lower()
    return not any(name in text for name in ("llvmpipe", "softpipe", "swrast"))


def time_frames(
    renderer: Any,
    cases: dict[str, tuple[Any, Any]],
    width: int,
    height: int,
    repeats: int,
    warmup: int = 1,
) -> dict[str, dict[str, Any]]:
    """Frame times of several ``(scene, camera)`` cases, interleaved round by round.

    Each case is rendered ``warmup`` times (shader variant compile, uploads), then ``repeats``
    rounds render every case once, so slow drifts of the machine touch all cases alike. An entry
    has ``wall_s`` and, when the driver times draws, ``gl_time_s`` (spreads), ``frame_s`` (the
    one of them that measures this GL: see :func:`gl_timer_reliable`), ``frame_source``,
    ``fps`` (at the median) and ``coverage`` (mean alpha of the image).
    """
    reliable = gl_timer_reliable(renderer.renderer_string)
    wall: dict[str, list[float]] = {k: [] for k in cases}
    gpu: dict[str, list[float]] = {k: [] for k in cases}
    coverage: dict[str, float] = {}
    for name, (scene, camera) in cases.items():
        for _ in range(warmup):
            img = renderer.render(scene, camera, width, height)
        coverage[name] = float(img[..., 3].mean()) if warmup else float("nan")
    for _ in range(repeats):
        for name, (scene, camera) in cases.items():
            t0 = time.perf_counter()
            renderer.render(scene, camera, width, height)
            wall[name].append(time.perf_counter() - t0)
            if renderer.last_gpu_ns is not None:
                gpu[name].append(renderer.last_gpu_ns * 1e-9)
    out: dict[str, dict[str, Any]] = {}
    for name in cases:
        entry: dict[str, Any] = {"wall_s": spread(wall[name])}
        if len(gpu[name]) == repeats:
            entry["gl_time_s"] = spread(gpu[name])
        use_gl = reliable and "gl_time_s" in entry
        entry["frame_s"] = entry["gl_time_s"] if use_gl else entry["wall_s"]
        entry["frame_source"] = "gl_timer" if use_gl else "wall"
        entry["fps"] = 1.0 / entry["frame_s"]["median"]
        entry["coverage"] = coverage[name]
        out[name] = entry
    return out


def frame_median(entry: dict[str, Any]) -> float:
    """Median frame seconds of a :func:`time_frames` entry."""
    return float(entry["frame_s"]["median"])


def render_sizes(renderer_string: str | None, quick: bool) -> tuple[list[tuple[int, int]], str]:
    """The paper's resolutions on a GPU; each edge divided by 4 on a software rasteriser.

    Returns the sizes and a note saying which were used.
    """
    paper = [(640, 480), (800, 600), (1920, 1080)]
    if quick:
        return [(64, 48), (80, 60)], "quick: tiny sizes (smoke test only)"
    if gl_timer_reliable(renderer_string):
        return paper, "the paper's resolutions"
    return (
        [(w // 4, h // 4) for w, h in paper],
        "software GL: the paper's resolutions with each edge divided by 4 (1/16 of the pixels); "
        "fps are for these sizes, not the paper's",
    )
