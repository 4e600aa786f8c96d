"""Benchmark of the CPU reference marcher (``backend="cpu"``), with the GL marcher as reference.

Renders the default Gaussian cumulus (and the metaball cumulus) with the C++ marcher on one
thread and on every core, with ``march="paper"`` and ``"union"``, and, where a headless GL
context exists, with the GLSL marcher in the same run, so that the GL/CPU ratio compares
like with like. Medians of repeats; JSON and a PNG plot under ``benchmarks/out/``.

    python benchmarks/bench_render_cpu.py [--quick] [--out benchmarks/out]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import cumuli as cu


def timed(fn: Any, repeats: int) -> tuple[float, list[float]]:
    """Median wall time of ``fn()`` over ``repeats`` runs (after one warm-up)."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times


def give_light(scene: cu.Scene) -> str:
    """Light grids as the renderers compute them; a flat grid if this build has no light pass."""
    try:
        from cumuli.renderer import prepare_light

        prepare_light(scene)
        return "light_grid"
    except (ImportError, ValueError):
        for cloud in scene.clouds:
            if cloud.light is None:
                lo, hi = cloud.bbox
                cloud.light = np.ones((8, 8, 8), np.float32)
                cloud.light_box = (tuple(map(float, lo)), tuple(map(float, hi)))
        return "flat (cumuli.light_grid unavailable)"


def gl_info() -> tuple[Any, str]:
    """The GL render function and renderer string, or (None, reason)."""
    try:
        from cumuli.gl import available
        from cumuli.renderer import render
    except ImportError as exc:
        return None, f"no GL renderer in this build ({exc})"
    ok, info = available()
    return (render if ok else None), info


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small image, few repeats")
    ap.add_argument("--out", default=str(Path(__file__).parent / "out"))
    args = ap.parse_args(argv)
    width, height, repeats = (96, 72, 3) if args.quick else (320, 240, 5)
    cores = os.cpu_count() or 1

    scenes = {
        "gaussian_cumulus": cu.Scene(clouds=[cu.gaussian_cumulus(seed=1)]),
        "metaball_cumulus": cu.Scene(clouds=[cu.metaball_cumulus(seed=2)]),
    }
    gl_render, gl_renderer = gl_info()
    results: list[dict[str, Any]] = []
    for name, scene in scenes.items():
        light = give_light(scene)
        camera = scene.default_camera()
        for march in ("paper", "union"):
            sc = scene.replace(settings=scene.settings.replace(march=march))
            row: dict[str, Any] = {"scene": name, "march": march, "light": light}
            for threads in sorted({1, cores}):
                med, _ = timed(
                    lambda sc=sc, t=threads, c=camera: cu.render_cpu(sc, c, width, height, t),
                    repeats,
                )
                row[f"cpu_{threads}t_s"] = med
            row["cpu_all_s"] = row[f"cpu_{cores}t_s"]
            row["thread_speedup"] = row["cpu_1t_s"] / row["cpu_all_s"]
            if gl_render is not None:
                med, _ = timed(lambda sc=sc, c=camera: gl_render(sc, c, width, height), repeats)
                row["gl_wall_s"] = med
                row["cpu_over_gl"] = row["cpu_all_s"] / med
            results.append(row)
            print(json.dumps(row), flush=True)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    report = {
        "benchmark": "render_cpu",
        "quick": args.quick,
        "image": [width, height],
        "repeats": repeats,
        "machine": {
            "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "cpu_count": cores,
            "python": sys.version.split()[0],
        },
        "gl_renderer": gl_renderer,
        "timing": "wall clock medians; GL includes upload, draw and read-back",
        "results": results,
    }
    tmp = out / ".bench_render_cpu.json.tmp"
    tmp.write_text(json.dumps(report, indent=1))
    os.replace(tmp, out / "bench_render_cpu.json")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        labels = [f"{r['scene']}\n{r['march']}" for r in results]
        x = np.arange(len(results))
        keys = [k for k in ("cpu_1t_s", "cpu_all_s", "gl_wall_s") if k in results[0]]
        fig, ax = plt.subplots(figsize=(8, 4))
        for i, k in enumerate(keys):
            ax.bar(x + (i - 1) * 0.25, [r[k] * 1e3 for r in results], 0.25, label=k)
        ax.set_xticks(x, labels)
        ax.set_ylabel(f"ms per {width}x{height} image (median)")
        ax.set_yscale("log")
        ax.legend()
        ax.set_title(f"CPU marcher vs GL ({gl_renderer[:40]})")
        fig.tight_layout()
        fig.savefig(out / "bench_render_cpu.png", dpi=100)
    except ImportError:
        pass
    print(f"wrote {out / 'bench_render_cpu.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
