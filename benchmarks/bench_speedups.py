"""The paper's claimed speed-ups, each measured as a ratio within one run (§3.3, §3.6.1, §4.1).

1. Hollow filter on vs off: the paper removes ~20 % of the cumulus spheres and reports ~30 % more
   fps. Several seeds, the same cloud with and without the filter, several distances.
2. NDT vs naive light precompute: ~2× (the naive method "would double" the time) and under
   10 ms at 20³ on a 2009 i7-860; 1 thread and all threads.
3. Candidate sort: insertion sort (the paper's) against iterative quicksort (which the paper found
   slower), Batcher's odd-even mergesort (which it suggests) and no sort (a cost floor; its image
   is wrong where candidates overlap). The three sorts give the same images
   (tests/rendering/test_candidate_sort.py).
4. LOD step (Algorithm 1, line 50) against the fixed reference step 0.1 (the paper's Fig. 16b
   "LOD bypassed to force higher quality"), with the image difference it costs.
5. ``march="paper"`` against ``march="union"`` (each point of overlapping candidates once).

Frame times are GL timer queries on a GPU and wall times on llvmpipe. Writes ``speedups.json`` and
``speedups.png`` under ``benchmarks/out/`` (or ``--out``).
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402
import bench_light  # noqa: E402
import numpy as np  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.demo import benchmark_scenes, distance_camera  # noqa: E402
from cumuli.settings import CANDIDATE_SORTS  # noqa: E402

#: What the paper claims, as "variant time / baseline time" or fps ratios (for RESULTS.md).
CLAIMS = {
    "hollow": "~1.3x fps with the hollow filter (about 20 % of spheres removed)",
    "light": "naive/NDT ~2x; NDT under 10 ms at 20^3 (i7-860, 2009)",
    "sort": "insertion sort fastest; iterative quicksort slower",
    "lod": "the LOD step is faster than forcing the fixed fine step (Fig. 16b)",
    "march": "not in the paper (union marching is cumuli's NDT-for-camera-rays)",
}


def scene_with(scene: cu.Scene, **settings: Any) -> cu.Scene:
    return scene.replace(settings=scene.settings.replace(**settings))


def median_ratio(num: dict, den: dict) -> float:
    return common.frame_median(num) / common.frame_median(den)


def hollow(renderer, size, quick: bool) -> dict[str, Any]:
    seeds = [1] if quick else [1, 2, 3, 4, 5, 6]
    distances = [32] if quick else [0, 16, 32, 64]
    w, h = size
    base = benchmark_scenes(("cumulus",))["cumulus"]
    runs = []
    for seed in seeds:
        with_filter = cu.gaussian_cumulus(centre=(0, 0, 0), seed=seed, hollow=True)
        without = cu.gaussian_cumulus(centre=(0, 0, 0), seed=seed, hollow=False)
        scenes = {
            "hollow": base.replace(clouds=[with_filter]),
            "full": base.replace(clouds=[without]),
        }
        for s in scenes.values():
            cu.prepare_light(s)
        for d in distances:
            camera = distance_camera(scenes["full"], d)  # the same camera for both
            cases = {k: (s, camera) for k, s in scenes.items()}
            t = common.time_frames(renderer, cases, w, h, 2 if quick else 5)
            fps_ratio = 1.0 / median_ratio(t["hollow"], t["full"])
            runs.append(
                {
                    "seed": seed,
                    "distance": d,
                    "primitives": {"hollow": with_filter.n, "full": without.n},
                    "removed_share": 1 - with_filter.n / without.n,
                    "hollow": t["hollow"],
                    "full": t["full"],
                    "fps_ratio_hollow_over_full": fps_ratio,
                }
            )
            common.log(f"hollow seed {seed} d={d}: fps ratio {fps_ratio:.2f}")
    ratios = [r["fps_ratio_hollow_over_full"] for r in runs]
    return {
        "size": f"{w}x{h}",
        "runs": runs,
        "summary": {
            "fps_ratio_median": statistics.median(ratios),
            "fps_ratio_min": min(ratios),
            "fps_ratio_max": max(ratios),
            "removed_share_mean": statistics.mean(r["removed_share"] for r in runs),
        },
        "claim": CLAIMS["hollow"],
    }


def light(quick: bool) -> dict[str, Any]:
    """NDT against naive at 20³ on several cumulus seeds, 1 thread and all: bench_light's timing
    (the core's march time, ``bench_light.run_one``) on the claim's grid."""
    seeds = [1] if quick else [1, 2, 3, 4, 5, 6]
    repeats = 3 if quick else 15
    noise = cu.Noise(seed=7, version=1)  # the paper's noise: its claims are about it
    by_threads: dict[str, Any] = {}
    for threads in (1, 0):
        rows = []
        for seed in seeds:
            cloud = cu.gaussian_cumulus(centre=(0, 0, 0), seed=seed)
            runs = {
                m: bench_light.run_one(cloud, noise, 20, m, repeats, threads)
                for m in ("ndt", "naive")
            }
            for run in runs.values():
                run.pop("_grid")
            rows.append(
                {
                    "seed": seed,
                    "primitives": cloud.n,
                    "ndt_s": runs["ndt"]["march_s"],
                    "naive_s": runs["naive"]["march_s"],
                    "samples_per_voxel": {m: r["samples_per_voxel"] for m, r in runs.items()},
                    "naive_over_ndt": runs["naive"]["march_s"]["median"]
                    / runs["ndt"]["march_s"]["median"],
                }
            )
        label = "1 thread" if threads == 1 else f"all {common.usable_cores()} threads"
        ratios = [r["naive_over_ndt"] for r in rows]
        ndt_ms = [1e3 * r["ndt_s"]["median"] for r in rows]
        by_threads[label] = {
            "rows": rows,
            "naive_over_ndt_median": statistics.median(ratios),
            "ndt_ms_median": statistics.median(ndt_ms),
            "ndt_ms_max": max(ndt_ms),
        }
        common.log(
            f"light {label}: NDT {statistics.median(ndt_ms):.2f} ms at 20^3, "
            f"naive/NDT {statistics.median(ratios):.2f}"
        )
    return {
        "resolution": 20,
        "step": bench_light.STEP,
        "sun": bench_light.SUN,
        "threads": by_threads,
        "claim": CLAIMS["light"],
    }


def sort(renderer, size, quick: bool) -> dict[str, Any]:
    w, h = size
    names = ("cumulus",) if quick else ("cumulus", "lsystem", "mesh")
    distances = [16] if quick else [0, 16, 32, 64]
    scenes = benchmark_scenes(names)
    out: dict[str, Any] = {}
    for name, scene in scenes.items():
        cu.prepare_light(scene)
        out[name] = []
        for d in distances:
            camera = distance_camera(scene, d)
            cases = {s: (scene_with(scene, candidate_sort=s), camera) for s in CANDIDATE_SORTS}
            t = common.time_frames(renderer, cases, w, h, 2 if quick else 5)
            ratios = {s: median_ratio(t[s], t["insertion"]) for s in CANDIDATE_SORTS}
            out[name].append({"distance": d, "times": t, "time_over_insertion": ratios})
            common.log(
                f"sort {name} d={d}: "
                + ", ".join(f"{s} {r:.2f}" for s, r in ratios.items() if s != "insertion")
            )
    return {"size": f"{w}x{h}", "scenes": out, "claim": CLAIMS["sort"]}


def lod(renderer, size, quick: bool) -> dict[str, Any]:
    w, h = size
    distances = [32] if quick else [0, 16, 32, 64, 128]
    scene = benchmark_scenes(("cumulus",))["cumulus"]
    cu.prepare_light(scene)
    fixed = scene_with(scene, fixed_step=scene.settings.step_ref)
    rows = []
    for d in distances:
        camera = distance_camera(scene, d)
        t = common.time_frames(
            renderer, {"lod": (scene, camera), "fixed": (fixed, camera)}, w, h, 2 if quick else 5
        )
        a = renderer.render(scene, camera, w, h)
        b = renderer.render(fixed, camera, w, h)
        rows.append(
            {
                "distance": d,
                "lod_step": scene.settings.step_for(d),
                "fixed_step": fixed.settings.fixed_step,
                "times": t,
                "fixed_over_lod": median_ratio(t["fixed"], t["lod"]),
                "image_mean_abs_diff": float(np.abs(a - b).mean()),
            }
        )
        common.log(f"lod d={d}: fixed/LOD {rows[-1]['fixed_over_lod']:.2f}")
    return {"size": f"{w}x{h}", "scene": "cumulus", "rows": rows, "claim": CLAIMS["lod"]}


def march(renderer, size, quick: bool) -> dict[str, Any]:
    w, h = size
    names = ("cumulus",) if quick else ("cumulus", "mesh", "metaball", "lsystem")
    distances = [16] if quick else [0, 16, 64]
    out: dict[str, Any] = {}
    for name, scene in benchmark_scenes(names).items():
        cu.prepare_light(scene)
        out[name] = []
        for d in distances:
            camera = distance_camera(scene, d)
            cases = {m: (scene_with(scene, march=m), camera) for m in ("paper", "union")}
            t = common.time_frames(renderer, cases, w, h, 2 if quick else 5)
            out[name].append(
                {
                    "distance": d,
                    "times": t,
                    "union_over_paper": median_ratio(t["union"], t["paper"]),
                }
            )
            common.log(f"march {name} d={d}: union/paper {out[name][-1]['union_over_paper']:.2f}")
    return {"size": f"{w}x{h}", "scenes": out, "claim": CLAIMS["march"]}


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    machine = common.machine_info()
    sizes, size_note = common.render_sizes(machine["gl_renderer"], args.quick)
    size = sizes[-1] if args.quick else sizes[1]  # 800x600 (or its quarter), as Fig. 16a
    common.log(f"GL renderer: {machine['gl_renderer']}; frames at {size[0]}x{size[1]}")
    start = time.perf_counter()
    with cu.Renderer() as renderer:
        results = {
            "hollow": hollow(renderer, size, args.quick),
            "light": light(args.quick),
            "sort": sort(renderer, size, args.quick),
            "lod": lod(renderer, size, args.quick),
            "march": march(renderer, size, args.quick),
        }
    data = {
        "benchmark": "speedups",
        "quick": args.quick,
        "machine": machine,
        "size_note": size_note,
        "frame_time": "GL timer queries"
        if common.gl_timer_reliable(machine["gl_renderer"])
        else "wall time of Renderer.render (llvmpipe's timer queries miss its raster threads)",
        "seconds": time.perf_counter() - start,
        **results,
        "summary": summary(results),
    }
    path = common.write_json(args.out / "speedups.json", data)
    common.log(f"wrote {path}")
    for key, row in data["summary"].items():
        common.log(f"{key}: {row['measured']} | paper: {row['claim']}")
    plot(data, args.out / "speedups.png")
    return 0


def summary(r: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """One line per claim: the measured ratio(s) beside the paper's."""
    light1 = r["light"]["threads"]["1 thread"]
    sorts = [row["time_over_insertion"] for rows in r["sort"]["scenes"].values() for row in rows]
    sort_median = {s: statistics.median(x[s] for x in sorts) for s in CANDIDATE_SORTS}
    lod_ratios = [row["fixed_over_lod"] for row in r["lod"]["rows"]]
    march_ratios = [
        row["union_over_paper"] for rows in r["march"]["scenes"].values() for row in rows
    ]
    hollow = r["hollow"]["summary"]
    return {
        "hollow": {
            "measured": f"fps ratio hollow/full median {hollow['fps_ratio_median']:.2f} "
            f"(range {hollow['fps_ratio_min']:.2f}-{hollow['fps_ratio_max']:.2f}), "
            f"{100 * hollow['removed_share_mean']:.0f} % spheres removed",
            "value": r["hollow"]["summary"]["fps_ratio_median"],
            "claim": CLAIMS["hollow"],
        },
        "light": {
            "measured": f"naive/NDT {light1['naive_over_ndt_median']:.2f}, NDT "
            f"{light1['ndt_ms_median']:.2f} ms at 20^3 on 1 thread",
            "value": light1["naive_over_ndt_median"],
            "ndt_ms": light1["ndt_ms_median"],
            "claim": CLAIMS["light"],
        },
        "sort": {
            "measured": ", ".join(
                f"{s}/insertion {v:.2f}" for s, v in sort_median.items() if s != "insertion"
            ),
            "value": sort_median,
            "claim": CLAIMS["sort"],
        },
        "lod": {
            "measured": f"fixed 0.1 / LOD time median {statistics.median(lod_ratios):.2f}",
            "value": statistics.median(lod_ratios),
            "claim": CLAIMS["lod"],
        },
        "march": {
            "measured": f"union/paper time median {statistics.median(march_ratios):.2f}",
            "value": statistics.median(march_ratios),
            "claim": CLAIMS["march"],
        },
    }


def plot(data: dict, path: Path) -> None:
    plt = common.pyplot()
    s = data["summary"]
    labels = ["hollow: fps ratio", "light: naive/NDT", "quicksort/insertion", "oddeven/insertion",
              "none/insertion", "fixed step/LOD", "union/paper"]  # fmt: skip
    values = [s["hollow"]["value"], s["light"]["value"], s["sort"]["value"]["quicksort"],
              s["sort"]["value"]["oddeven"], s["sort"]["value"]["none"], s["lod"]["value"],
              s["march"]["value"]]  # fmt: skip
    paper = [1.3, 2.0, None, None, None, None, None]
    fig, ax = plt.subplots(figsize=(7.5, 3.8))
    ax.barh(range(len(values)), values, color="tab:blue", label="measured (median)")
    for i, p in enumerate(paper):
        if p is not None:
            ax.plot(
                [p, p], [i - 0.4, i + 0.4], color="tab:red", lw=2, label="paper" if i == 0 else None
            )
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_yticks(range(len(values)), labels, fontsize=8)
    ax.set_xlabel("ratio")
    ax.set_title(f"claimed speed-ups — {data['machine']['gl_renderer']}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
