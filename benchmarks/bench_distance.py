"""Frame time against camera distance (the paper's Fig. 16 and Table 3).

The four benchmark clouds of §4.2 (``cumuli.demo.benchmark_scenes``: the 35-sphere cumulus with
the hollow filter, the 370-face mesh cloud at fixed step 0.1, the 6-sphere metaball cloud and the
128-sphere L-system cloud) are rendered from a camera on −z looking at the cloud's centre, from
inside (distance 0) to far away, at 640×480, 800×600 and 1920×1080 on a GPU (each edge / 4 on
llvmpipe, said in the JSON). From each curve, Table 3's quantity: the smallest sampled distance
from which every farther distance reaches 30 fps. On an H100/H200 the issue's goal is checked:
1920×1080 cumulus at distance 32 in ≤ 1 ms and from inside in ≤ 4 ms (GL timer queries).
Writes ``distance.json`` and ``distance.png`` under ``benchmarks/out/`` (or ``--out``).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.demo import BENCHMARK_SCENES, benchmark_scenes, distance_camera  # noqa: E402

DISTANCES = [0, 4, 8, 12, 16, 24, 32, 48, 64, 96, 128]
QUICK_DISTANCES = [0, 16, 64]
REALTIME_FPS = 30.0
#: The issue's GPU goals (H100/H200, 1920×1080 cumulus): (distance, milliseconds).
GPU_GOALS = [(32, 1.0), (0, 4.0)]
#: The paper's Table 3 (1920×1080, 30 fps from this distance on): card -> (cumulus, 3D model).
PAPER_TABLE3 = {"GT 1030": (32, 25), "GTX 1050": (24, 20), "GTX 970": (0, 12)}


def realtime_from(curve: list[dict[str, Any]], fps: float = REALTIME_FPS) -> float | None:
    """Smallest sampled distance from which every farther sample reaches ``fps`` (None: never)."""
    best = None
    for point in sorted(curve, key=lambda p: p["distance"], reverse=True):
        if point["fps"] < fps:
            break
        best = point["distance"]
    return best


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    machine = common.machine_info()
    sizes, size_note = common.render_sizes(machine["gl_renderer"], args.quick)
    distances = QUICK_DISTANCES if args.quick else DISTANCES
    repeats = 2 if args.quick else 5
    names = ("cumulus", "metaball") if args.quick else BENCHMARK_SCENES
    common.log(f"GL renderer: {machine['gl_renderer']}; sizes {sizes} ({size_note})")

    scenes = benchmark_scenes(names)
    for scene in scenes.values():
        cu.prepare_light(scene)  # light is memoised: the frames below do not repeat the pass
    curves: dict[str, dict[str, list[dict[str, Any]]]] = {}
    with cu.Renderer() as renderer:
        for w, h in sizes:
            key = f"{w}x{h}"
            curves[key] = {}
            for name, scene in scenes.items():
                cases = {d: (scene, distance_camera(scene, d)) for d in distances}
                timed = common.time_frames(renderer, cases, w, h, repeats)
                curves[key][name] = [{"distance": d, **timed[d]} for d in distances]
                common.log(
                    f"{key} {name}: "
                    + ", ".join(
                        f"d={d}: {1e3 * common.frame_median(timed[d]):.1f} ms" for d in distances
                    )
                )

    table3 = {
        key: {name: realtime_from(curve) for name, curve in by_scene.items()}
        for key, by_scene in curves.items()
    }
    targets = gpu_targets(curves, machine["gl_renderer"], sizes)
    data = {
        "benchmark": "distance",
        "quick": args.quick,
        "machine": machine,
        "sizes": [f"{w}x{h}" for w, h in sizes],
        "size_note": size_note,
        "distances": distances,
        "distance_definition": "camera to the centre of the cloud's primitive bounds, along -z",
        "scenes": {
            n: {"primitives": s.clouds[0].n, "settings": s.settings.to_dict()}
            for n, s in scenes.items()
        },
        "repeats": repeats,
        "frame_time": "GL timer queries"
        if common.gl_timer_reliable(machine["gl_renderer"])
        else "wall time of Renderer.render (llvmpipe's timer queries miss its raster threads)",
        "curves": curves,
        "realtime_fps": REALTIME_FPS,
        "table3_min_distance_30fps": table3,
        "paper_table3_1920x1080": {
            k: {"cumulus": v[0], "mesh": v[1]} for k, v in PAPER_TABLE3.items()
        },
        "targets": targets,
    }
    path = common.write_json(args.out / "distance.json", data)
    common.log(f"wrote {path}")
    for t in targets:
        common.log(
            f"target: {t['name']}: measured {t['measured_ms']} ms, met={t['met']} ({t['note']})"
        )
    plot(data, args.out / "distance.png")
    return 0


def gpu_targets(curves: dict, renderer: str | None, sizes: list[tuple[int, int]]) -> list[dict]:
    """The issue's H100/H200 goals, with the measured value where the size was run."""
    on_goal_gpu = any(g in str(renderer) for g in ("H100", "H200"))
    out = []
    for distance, limit in GPU_GOALS:
        name = f"1920x1080 cumulus at distance {distance} <= {limit} ms (H100/H200)"
        measured = None
        curve = curves.get("1920x1080", {}).get("cumulus")
        if curve:
            point = next((p for p in curve if p["distance"] == distance), None)
            measured = None if point is None else round(1e3 * common.frame_median(point), 4)
        if measured is None:
            note = "1920x1080 not run here (software GL or quick mode)"
        elif not on_goal_gpu:
            note = "measured on another GPU than the goal's"
        else:
            note = "GL timer queries"
        met = None if measured is None or not on_goal_gpu else measured <= limit
        out.append(
            {"name": name, "limit_ms": limit, "measured_ms": measured, "met": met, "note": note}
        )
    return out


def plot(data: dict, path: Path) -> None:
    plt = common.pyplot()
    sizes = data["sizes"]
    fig, axes = plt.subplots(1, len(sizes), figsize=(4.2 * len(sizes), 3.6), squeeze=False)
    for ax, key in zip(axes[0], sizes, strict=True):
        for name, curve in data["curves"][key].items():
            xs = [max(p["distance"], 0.5) for p in curve]  # log axis: distance 0 drawn at 0.5
            ax.plot(xs, [p["fps"] for p in curve], marker="o", ms=3, label=name)
        ax.axhline(data["realtime_fps"], color="k", lw=0.8, ls="--", label="30 fps")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("camera distance to cloud centre (0 drawn at 0.5)")
        ax.set_ylabel("frames per second")
        ax.set_title(key, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.suptitle(f"Fig. 16 analogue — {data['machine']['gl_renderer']}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
