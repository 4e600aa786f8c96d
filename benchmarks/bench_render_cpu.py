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


def gl_renderer() -> tuple[Any, str]:
    """A GL Renderer and its renderer string, or (None, the reason there is none)."""
    try:
        from cumuli.gl import GLUnavailableError
        from cumuli.renderer import Renderer
    except ImportError as exc:
        return None, f"no GL renderer in this build ({exc})"
    try:
        r = Renderer()
    except GLUnavailableError as exc:
        return None, str(exc)
    return r, r.renderer_string


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
        "lsystem_cloud": cu.Scene(clouds=[cu.lsystem_cloud(iterations=7, seed=2)]),
    }
    renderer, gl_name = gl_renderer()
    results: list[dict[str, Any]] = []
    for name, scene in scenes.items():
        cu.prepare_light(scene)  # once, outside the timings: both marchers reuse the grids
        camera = scene.default_camera()
        for march in ("paper", "union"):
            sc = scene.replace(settings=scene.settings.replace(march=march))
            row: dict[str, Any] = {"scene": name, "march": march, "primitives": scene.clouds[0].n}
            for threads in sorted({1, cores}):
                med, _ = timed(
                    lambda sc=sc, t=threads, c=camera: cu.render_cpu(sc, c, width, height, t),
                    repeats,
                )
                row[f"cpu_{threads}t_s"] = med
            row["cpu_all_s"] = row[f"cpu_{cores}t_s"]
            row["thread_speedup"] = row["cpu_1t_s"] / row["cpu_all_s"]
            if renderer is not None:
                gpu: list[float] = []

                def gl(sc: cu.Scene = sc, c: cu.Camera = camera, gpu: list[float] = gpu) -> None:
                    renderer.render(sc, c, width, height)
                    if renderer.last_gpu_ns is not None:
                        gpu.append(renderer.last_gpu_ns * 1e-9)

                med, _ = timed(gl, repeats)
                row["gl_wall_s"] = med
                row["gl_gpu_s"] = statistics.median(gpu[1:]) if len(gpu) > 1 else None
                row["cpu_over_gl_wall"] = row["cpu_all_s"] / med
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
        "gl_renderer": gl_name,
        "timing": (
            "medians; cpu_*: wall clock of cumuli.render_cpu (light grids precomputed); "
            "gl_wall_s: Renderer.render wall clock (upload, draw, read-back); "
            "gl_gpu_s: GL timer queries of the draws"
        ),
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
        keys = [k for k in ("cpu_1t_s", "cpu_all_s", "gl_wall_s", "gl_gpu_s") if results[0].get(k)]
        fig, ax = plt.subplots(figsize=(8, 4))
        for i, k in enumerate(keys):
            ax.bar(x + (i - 1.5) * 0.2, [r[k] * 1e3 for r in results], 0.2, label=k)
        ax.set_xticks(x, labels)
        ax.set_ylabel(f"ms per {width}x{height} image (median)")
        ax.set_yscale("log")
        ax.legend()
        ax.set_title(f"CPU marcher vs GL ({gl_name[:40]})")
        fig.tight_layout()
        fig.savefig(out / "bench_render_cpu.png", dpi=100)
    except ImportError:
        pass
    if renderer is not None:
        renderer.close()
    print(f"wrote {out / 'bench_render_cpu.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
