"""Billboard clouds (Torchelsen & Musse 2005): generation, CAF and weather-step times, one run.

- **Generation** (`seed_box_cloud`, C++): time against the number of reproduction levels L (one
  seed box, 3 directions, (2, 2) boxes per level and direction, 6 billboards per box: boxes grow
  linearly with L) and against the boxes per level (L = 3, (k, k) boxes), on one thread and on
  all cores (bit-identical results).
- **CAF** (`absorption_factors`, C++, all cores): time of ``overlap="sum"`` (the paper's sum of
  chords) and ``"union"`` against the box count M (4 seed boxes of 16 levels, 5 directions,
  (k, k) boxes: M = 4·(1 + 80k), 324 … 20 484; a uniform grid finds the candidate boxes), the
  union/sum ratio, and per-billboard CAFs at the largest M.
- **Weather step** (`Weather.step`, C++): time per step against the layer's instance count N*
  (one layer, 1 variant, wind along +x at 10 units/s on a 1000-unit square, dt = 0.1 s), after a
  warm-up so that clouds enter and leave.
- **CAF vs the NDT light grid** (not a timing): Spearman's rank correlation between the CAF of
  each box and cumuli's volumetric light grid (Jiménez de Parga 2018, NDT, constant density) of
  the same boxes as ellipsoids, sampled at the box centres, per preset and sun, for sum and union.

- **Render time** (the sprite renderer, GL and its C++ CPU twin, per frame of a lit scene: the
  frame's sprite list — cull, fades, sort, vertex colours — plus the draw) against the number of
  clouds N (a `BillboardField` of 10 cumulus variants at constant density, 10…10³ on llvmpipe,
  10⁴ where a GPU runs it) and against the billboards per cloud (100 clouds, 1…16 billboards per
  box); **with and without impostors** (one per field instance; orbit and fly-through at 1 unit
  per frame, GL and the C++ twin: ``_billboard_impostors.py``).
- **The paper's four scenes** ([TM] §5): the cirrus of 15 seeds / 50 billboards (25 Hz), a nimbus
  sky of 10 models × 200 instances (20 Hz), raining clouds of 10 models × 1000 (10 Hz), both
  flown through, and the Table 1 day (two layers, CV 0 → 1 over 600 s, the weather stepped, lit
  and drawn every frame: 27 Hz mean, 20–35). GL at 160×120 on llvmpipe, 640×480 on a GPU; each
  as frames per second (median, min, max, mean), the ratio to the paper's rate and whether it
  "reaches at least" that rate (2005 GeForce 6800 vs this machine: only that statement and the
  ratios between scenes mean anything). The same frames through impostors (per backend, a fresh
  cache), and the Table 1 day also under a steady light (the day relights every frame, which
  regenerates every impostor).

Medians of repeats; nothing passes or fails on time.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _billboard_impostors as imp  # noqa: E402
import _common as common  # noqa: E402
import numpy as np  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.anim.weather import CloudLayer, SkyState, Weather  # noqa: E402
from cumuli.light.caf import (  # noqa: E402
    absorption_factors,
    light_grid_at_boxes,
    rank_correlation,
)
from cumuli.model import seedbox_presets as presets  # noqa: E402
from cumuli.model.billboards import (  # noqa: E402
    BasisModel,
    SeedBox,
    cloud_variants,
    seed_box_cloud,
)

SUN = (0.3, 0.8, 0.2)


def generation_model(levels: int, per_level: int, directions: int = 3) -> BasisModel:
    dirs = ((1.0, 0.2, 0.0), (-1.0, 0.2, 0.0), (0.0, 1.0, 0.0), (0.0, 0.2, 1.0), (0.0, 0.2, -1.0))
    seed = SeedBox(
        directions=dirs[:directions],
        apertures=(60.0,) * directions,
        levels=levels,
        boxes_per_level=(per_level, per_level),
        billboards_per_box=(6, 6),
    )
    return BasisModel((seed,))


def time_generation(model: BasisModel, repeats: int) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, threads in (("1_thread", 1), ("all_cores", 0)):
        wall, _ = common.time_repeats(
            lambda t=threads: seed_box_cloud(model, 7, threads=t), repeats
        )
        out[name] = common.spread(wall)
    cloud = seed_box_cloud(model, 7)
    out["boxes"] = cloud.n_boxes
    out["billboards"] = cloud.n_billboards
    out["us_per_billboard_1_thread"] = 1e6 * out["1_thread"]["median"] / max(cloud.n_billboards, 1)
    return out


def caf_model(k: int) -> BasisModel:
    """A growing cloud: 4 seed boxes 30 units apart, each with 16 levels, 5 directions and
    (k, k) boxes per level and direction: M = 4·(1 + 80k) boxes."""
    base = generation_model(16, k, directions=5).seeds[0]
    seeds = tuple(
        SeedBox(**{**base.to_dict(), "centre": (30.0 * i, 0.0, 0.0), "billboards_per_box": (2, 2)})
        for i in range(4)
    )
    return BasisModel(seeds)


def time_caf(k: int, repeats: int) -> dict[str, Any]:
    cloud = seed_box_cloud(caf_model(k), 3)
    fns = {
        overlap: (lambda o=overlap: absorption_factors(cloud, SUN, overlap=o))
        for overlap in ("sum", "union")
    }
    timings = common.interleaved_repeats(fns, repeats)
    out: dict[str, Any] = {"boxes": cloud.n_boxes, "billboards": cloud.n_billboards}
    for name, (wall, _) in timings.items():
        out[name] = common.spread(wall)
        out[f"{name}_us_per_box"] = 1e6 * out[name]["median"] / cloud.n_boxes
    out["union_over_sum"] = out["union"]["median"] / out["sum"]["median"]
    return out


def time_weather(n_star: int, steps: int) -> dict[str, Any]:
    state = SkyState(0.0, (presets.cumulus(),), variants=1, count=n_star)
    layer = CloudLayer(40.0, 8.0, (10.0, 0.0), (state,))
    w = Weather(((-500.0, -500.0), (500.0, 500.0)), [layer], cv=0.0, seed=1)
    for _ in range(200):  # 20 s: a fifth of a transit, clouds already leaving and entering
        w.step(0.1)
    times = []
    for _ in range(steps):
        t0 = time.perf_counter()
        w.step(0.1)
        times.append(time.perf_counter() - t0)
    # The largest sky (10⁵ instances) builds ~4.4 GiB of billboards, beyond the default memory
    # budget: measuring that scale is the point here, so the budget is raised for this call.
    with cu.limits(memory="16G"):
        fields_t0 = time.perf_counter()
        w.fields()
        fields_s = time.perf_counter() - fields_t0
    spread = common.spread(times)
    return {
        "instances": sum(w.counts()[0]),
        "step_s": spread,
        "ns_per_instance": 1e9 * spread["median"] / max(n_star, 1),
        "fields_s": fields_s,
    }


def caf_vs_ndt(resolution: int) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name in presets.NAMES:
        cloud = seed_box_cloud(presets.preset(name), 3)
        rows = {}
        for sun in ((0.3, 0.8, 0.2), (0.0, 1.0, 0.0), (-0.7, 0.4, 0.3)):
            grid = light_grid_at_boxes(cloud, sun, resolution=resolution)
            rows[str(list(sun))] = {
                o: rank_correlation(absorption_factors(cloud, sun, overlap=o).caf, grid)
                for o in ("sum", "union")
            }
        out[name] = {"boxes": cloud.n_boxes, "spearman": rows}
    return out


# --- rendering ------------------------------------------------------------------------------------
#: [TM] §5's frame rates (GeForce 6800, image size not stated).
PAPER_HZ = {"cirrus": 25.0, "nimbus": 20.0, "rain": 10.0, "table1": 27.0}
PAPER_TEXT = {
    "cirrus": "Fig. 10: cirrus of 15 seeds and 50 billboards at 25 Hz",
    "nimbus": "Fig. 11: 10 models replicated 200 times (200 clouds) at 20 Hz",
    "rain": "Fig. 12: 10 models replicated 1000 times at 10 Hz",
    "table1": "Fig. 14 / Table 1: the climatic variation at 27 Hz mean (best 35, worst 20)",
}
RENDER_SUN = cu.Sun(direction=(0.35, 0.75, -0.55), colour=(1.0, 0.97, 0.92), intensity=1.6)


def software_gl(renderer: str | None) -> bool:
    """Whether the GL renderer is a CPU rasteriser (Mesa llvmpipe/softpipe)."""
    text = (renderer or "").lower()
    return any(k in text for k in ("llvmpipe", "softpipe", "swrast"))


def centred(clouds: list[Any]) -> list[Any]:
    return [c.translated(-c.centre.astype(float)) for c in clouds]


def cloud_field(n: int, per_box: int | None = None, preset: str = "cumulus", models: int = 10,
                spacing: float = 40.0, altitude: float = 40.0, seed: int = 1) -> Any:  # fmt: skip
    """``n`` instances of ``models`` variants of a preset, one per ``spacing²`` of a square at
    ``altitude`` (constant density: the square grows with n), yaw random."""
    model = presets.preset(preset)
    if per_box is not None:
        s = model.seeds[0]
        model = BasisModel(
            (SeedBox(**{**s.to_dict(), "billboards_per_box": (per_box, per_box)}),),
            atlas=model.atlas, billboard_size=model.billboard_size, opacity=model.opacity,
        )  # fmt: skip
    rng = np.random.default_rng(seed)
    half = 0.5 * spacing * math.sqrt(n)
    offsets = np.stack([rng.uniform(-half, half, n), altitude + rng.uniform(-4, 4, n),
                        rng.uniform(-half, half, n)], axis=1)  # fmt: skip
    return cu.BillboardField(centred(cloud_variants(model, models, seed=seed)), offsets,
                             yaw=rng.uniform(0.0, 360.0, n))  # fmt: skip


def field_camera(n: int, spacing: float = 40.0) -> Any:
    """On the ground at the edge of the field, looking across it and up."""
    half = 0.5 * spacing * math.sqrt(n)
    return cu.Camera(position=(0.0, 5.0, -half - 40.0), target=(0.0, 45.0, 0.0), fov=60.0)


def sprites_drawn(lit: Any, camera: Any, size: tuple[int, int]) -> int:
    from cumuli.rendering.billboards import billboard_frame

    return len(billboard_frame(lit, range(len(lit.scene.clouds)), camera, *size).sprites)


def time_backends(renderer: Any, lit: Any, cameras: list[Any], size: tuple[int, int],
                  repeats: int, cpu: bool = True) -> dict[str, Any]:  # fmt: skip
    """Median wall time per frame of a lit scene over ``cameras`` × ``repeats`` (GL, and the C++
    twin with ``cpu``); the light is prepared once (a static sun)."""
    out: dict[str, Any] = {}
    fns = {"gl": lambda c: renderer.render(lit, c, *size)}
    if cpu:
        fns["cpu"] = lambda c: cu.render_cpu(lit, c, *size)
    for name, fn in fns.items():
        fn(cameras[0])  # warm-up: programs, atlas textures
        wall, gpu = [], []
        for _ in range(repeats):
            for c in cameras:
                t0 = time.perf_counter()
                fn(c)
                wall.append(time.perf_counter() - t0)
                if name == "gl" and renderer.last_gpu_ns is not None:
                    gpu.append(1e-9 * renderer.last_gpu_ns)
        out[name] = common.spread(wall)
        if gpu:
            out[f"{name}_gpu_s"] = common.spread(gpu)
    if cpu:
        out["gl_over_cpu"] = out["gl"]["median"] / out["cpu"]["median"]
    return out


def render_vs_clouds(renderer: Any, ns: list[int], size: tuple[int, int], repeats: int,
                     cpu_max: int) -> dict[str, Any]:  # fmt: skip
    out: dict[str, Any] = {}
    for n in ns:
        field = cloud_field(n)
        lit = cu.prepare_light(
            cu.Scene([field], sun=RENDER_SUN, settings=cu.RenderSettings(lighting="paper"))
        )
        cam = field_camera(n)
        row = time_backends(renderer, lit, [cam], size, repeats, cpu=n <= cpu_max)
        row["clouds"] = n
        row["billboards"] = int(sum(field.variants[v].n_billboards for v in field.variant))
        row["sprites_drawn"] = sprites_drawn(lit, cam, size)
        row["gl_ns_per_sprite"] = 1e9 * row["gl"]["median"] / max(row["sprites_drawn"], 1)
        out[str(n)] = row
        common.log(
            f"render N={n:6d}: {row['sprites_drawn']:7d} sprites drawn, GL "
            f"{1e3 * row['gl']['median']:.1f} ms"
            + (f", CPU {1e3 * row['cpu']['median']:.1f} ms" if "cpu" in row else "")
        )
    return out


def render_vs_billboards(renderer: Any, ks: list[int], size: tuple[int, int],
                         repeats: int) -> dict[str, Any]:  # fmt: skip
    out: dict[str, Any] = {}
    for k in ks:
        field = cloud_field(100, per_box=k)
        lit = cu.prepare_light(
            cu.Scene([field], sun=RENDER_SUN, settings=cu.RenderSettings(lighting="paper"))
        )
        cam = field_camera(100)
        row = time_backends(renderer, lit, [cam], size, repeats)
        row["billboards_per_box"] = k
        row["billboards_per_cloud"] = float(np.mean([v.n_billboards for v in field.variants]))
        row["sprites_drawn"] = sprites_drawn(lit, cam, size)
        out[str(k)] = row
        common.log(
            f"render 100 clouds, {row['billboards_per_cloud']:.0f} billboards/cloud: GL "
            f"{1e3 * row['gl']['median']:.1f} ms, CPU {1e3 * row['cpu']['median']:.1f} ms"
        )
    return out


def fps_stats(frame_s: list[float], claim: float, by_mean: bool = False) -> dict[str, Any]:
    """Frame rates of a run; the paper's rate is compared with the median (``by_mean``: with
    frames over total time, [TM]'s "average" of the Table 1 day)."""
    fps = [1.0 / t for t in frame_s]
    mean = len(frame_s) / sum(frame_s)
    measure = mean if by_mean else float(np.median(fps))
    return {
        "frames": len(frame_s),
        "frame_s": common.spread(frame_s),
        "fps_median": float(np.median(fps)),
        "fps_min": min(fps),
        "fps_max": max(fps),
        "fps_mean": mean,
        "paper_hz": claim,
        "compared": "mean" if by_mean else "median",
        "ratio_to_paper": measure / claim,
        "reaches_paper_rate": bool(measure >= claim),
    }


def with_runs(row: dict[str, Any], t: dict[str, Any]) -> dict[str, Any]:
    """The CPU twin's rates and both backends' rates through impostors beside the GL row."""
    keys = ("fps_median", "fps_min", "fps_max", "fps_mean", "ratio_to_paper", "reaches_paper_rate")
    for name, label in (("cpu", "cpu_twin"), ("gl_impostors", "gl_impostors"),
                        ("cpu_impostors", "cpu_impostors")):  # fmt: skip
        if name in t:
            stats = fps_stats(t[name], row["paper_hz"])
            row[label] = {k: stats[k] for k in keys}
            backend = name.split("_")[0]
            if name.endswith("impostors") and backend in t["caches"]:
                row[label].update(imp.cache_summary(t["caches"][backend]))
    return row


def paper_scenes(renderer: Any, size: tuple[int, int], quick: bool) -> dict[str, Any]:
    from cumuli.anim.frames import fly_towards, orbit
    from cumuli.anim.weather_presets import STORMY

    frames = {"cirrus": 3, "nimbus": 3, "rain": 3, "table1": 3} if quick else {
        "cirrus": 60, "nimbus": 30, "rain": 20, "table1": 61}  # fmt: skip
    out: dict[str, Any] = {}
    cirrus = seed_box_cloud(presets.cirrus(), 2).translated((0.0, 150.0, 0.0))
    scene = cu.Scene([cirrus], sun=RENDER_SUN, settings=cu.RenderSettings(lighting="paper"))
    cams = orbit((0.0, 150.0, 0.0), 80.0, frames["cirrus"], height=-35.0, fov=65.0)
    t = imp.path_with_impostors(renderer, scene, cams, size)
    out["cirrus"] = with_runs({"seed_boxes": len(presets.cirrus().seeds),
                               "billboards": cirrus.n_billboards,
                               **fps_stats(t["gl"], PAPER_HZ["cirrus"])}, t)  # fmt: skip
    for name, count, area, altitude, sky in (("nimbus", 200, 600.0, 60.0, cu.Sky()),
                                             ("rain", 1000, 1000.0, 40.0, STORMY)):  # fmt: skip
        n = count if not quick else count // 10
        field = cloud_field(n, preset=name, spacing=area / math.sqrt(count), altitude=altitude)
        half = 0.5 * area
        cams = fly_towards((0.0, altitude - 25.0, -half - 30.0), (0.0, altitude - 10.0, half),
                           frames[name], fov=60.0)  # fmt: skip
        step = float(np.linalg.norm(np.subtract(cams[1].position, cams[0].position)))
        paper = cu.RenderSettings(lighting="paper")
        t = imp.path_with_impostors(renderer, cu.Scene([field], sun=RENDER_SUN, sky=sky,
                                                       settings=paper), cams, size)  # fmt: skip
        out[name] = with_runs({"models": 10, "instances": n, "units_per_frame": step,
                               **fps_stats(t["gl"], PAPER_HZ[name])}, t)  # fmt: skip
        slow = imp.steps_path(cams[0].position, cams[-1].target, frames[name], imp.SPEED)
        paper = cu.RenderSettings(lighting="paper")
        t = imp.path_with_impostors(renderer, cu.Scene([field], sun=RENDER_SUN, sky=sky,
                                                       settings=paper), slow, size)  # fmt: skip
        out[name]["slow"] = with_runs({"units_per_frame": imp.SPEED,
                                       **fps_stats(t["gl"], PAPER_HZ[name])}, t)  # fmt: skip
        row = out[name]["slow"]
        common.log(f"{name} at {imp.SPEED:g} unit/frame: GL {row['fps_median']:.1f} fps, "
                   f"impostors {row['gl_impostors']['fps_median']:.1f}; CPU twin "
                   f"{row['cpu_twin']['fps_median']:.1f}, impostors "
                   f"{row['cpu_impostors']['fps_median']:.1f}")  # fmt: skip
    times, clouds, _, end = imp.table1_day(renderer, size, frames["table1"], False, False)
    stats = fps_stats(times, PAPER_HZ["table1"], by_mean=True)
    out["table1"] = {"weather_seconds": end, "dt": end / (frames["table1"] - 1),
                     "clouds_min": min(clouds), "clouds_max": max(clouds), **stats}  # fmt: skip
    keys = ("fps_median", "fps_min", "fps_max", "fps_mean", "ratio_to_paper", "reaches_paper_rate")
    for label, impostors, steady in (("gl_impostors", True, False),
                                     ("gl_steady_light", False, True),
                                     ("gl_steady_light_impostors", True, True)):  # fmt: skip
        times, _, cache, _ = imp.table1_day(renderer, size, frames["table1"], impostors, steady)
        stats = fps_stats(times, PAPER_HZ["table1"], by_mean=True)
        out["table1"][label] = {k: stats[k] for k in keys}
        if cache is not None:
            out["table1"][label].update(imp.cache_summary(cache))
    out["table1"]["paper_rate"] = imp.table1_at_paper_rate(
        renderer, size, 3 if quick else 20, fps_stats
    )
    for name, row in out.items():
        extra = "".join(
            f"; {label} {row[label]['fps_mean' if name == 'table1' else 'fps_median']:.1f} fps"
            for label in ("cpu_twin", "gl_impostors", "cpu_impostors", "gl_steady_light",
                          "gl_steady_light_impostors") if label in row
        )  # fmt: skip
        common.log(f"{PAPER_TEXT[name]}: GL median {row['fps_median']:.1f} fps "
                   f"[{row['fps_min']:.1f}–{row['fps_max']:.1f}], mean {row['fps_mean']:.1f}; "
                   f"reaches {row['paper_hz']:g} Hz: {row['reaches_paper_rate']} "
                   f"(×{row['ratio_to_paper']:.2f}){extra}")  # fmt: skip
    return out


def rendering(quick: bool) -> dict[str, Any] | None:
    """The render parts, on the GL renderer (None when no GL context can be made here)."""
    renderer_text, reason = common.gl_renderer()
    if renderer_text is None:
        common.log(f"render benchmarks skipped: no GL here ({reason})")
        return None
    software = software_gl(renderer_text)
    size = (160, 120) if software else (640, 480)
    ns = [10, 100] if quick else [10, 100, 1000, 10_000]  # [TM]'s 10…10⁴ (≈ 5 s/frame on llvmpipe)
    ks = [1, 4] if quick else [1, 2, 4, 8, 16]
    repeats = 2 if quick else 5
    with cu.Renderer() as renderer:
        data = {
            "size": list(size),
            "software_gl": software,
            "render_vs_clouds": render_vs_clouds(renderer, ns, size, repeats, cpu_max=10_000),
            "render_vs_billboards_per_cloud": render_vs_billboards(renderer, ks, size, repeats),
            "impostors": imp.sweep(renderer, cloud_field, RENDER_SUN, size, quick, software),
            "paper_scenes": paper_scenes(renderer, size, quick),
        }
    return data


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    quick = bool(args.quick)
    repeats = 3 if quick else 11
    levels = [1, 2, 4] if quick else [1, 2, 4, 8, 12, 16]
    per_level = [1, 4] if quick else [1, 2, 4, 8, 16, 32, 64]
    caf_k = [1, 4] if quick else [1, 2, 4, 8, 16, 32, 64]
    n_stars = [100, 1000] if quick else [100, 1000, 10_000, 100_000]

    gen_levels = {}
    for L in levels:
        gen_levels[str(L)] = time_generation(generation_model(L, 2), repeats)
        r = gen_levels[str(L)]
        common.log(f"generation L={L:2d}: {r['boxes']:5d} boxes, {r['billboards']:6d} billboards, "
                   f"{1e3 * r['1_thread']['median']:.3f} ms (1 thread), "
                   f"{1e3 * r['all_cores']['median']:.3f} ms (all cores)")  # fmt: skip
    gen_boxes = {}
    for k in per_level:
        gen_boxes[str(k)] = time_generation(generation_model(3, k), repeats)
        r = gen_boxes[str(k)]
        common.log(f"generation (k, k)={k:2d}: {r['boxes']:5d} boxes, "
                   f"{1e3 * r['1_thread']['median']:.3f} ms (1 thread)")  # fmt: skip
    caf = {}
    for k in caf_k:
        caf[str(k)] = time_caf(k, repeats)
        r = caf[str(k)]
        sum_ms, union_ms = 1e3 * r["sum"]["median"], 1e3 * r["union"]["median"]
        common.log(f"CAF M={r['boxes']:5d}: sum {sum_ms:.3f} ms, union {union_ms:.3f} ms, "
                   f"union/sum {r['union_over_sum']:.2f}")  # fmt: skip
    big = seed_box_cloud(caf_model(caf_k[-1]), 3)
    wall, _ = common.time_repeats(lambda: absorption_factors(big, SUN, at="billboard"), repeats)
    caf_billboards = {"billboards": big.n_billboards, "wall_s": common.spread(wall)}
    weather = {}
    for n in n_stars:
        weather[str(n)] = time_weather(n, 20 if quick else 100)
        r = weather[str(n)]
        step_ms, fields_ms = 1e3 * r["step_s"]["median"], 1e3 * r["fields_s"]
        common.log(f"weather N*={n:6d}: step {step_ms:.3f} ms ({r['ns_per_instance']:.1f} "
                   f"ns/instance), fields() {fields_ms:.1f} ms")  # fmt: skip
    render = rendering(quick)
    ndt = caf_vs_ndt(12 if quick else 24)
    for name, row in ndt.items():
        text = ", ".join(
            f"{sun} sum {v['sum']:.2f} union {v['union']:.2f}" for sun, v in row["spearman"].items()
        )
        common.log(f"CAF vs NDT {name:8s} ({row['boxes']} boxes): {text}")

    data = {
        "benchmark": "billboards",
        "quick": quick,
        "machine": common.machine_info(),
        "settings": {"sun": SUN, "repeats": repeats},
        "generation_vs_levels": gen_levels,
        "generation_vs_boxes_per_level": gen_boxes,
        "caf_vs_boxes": caf,
        "caf_per_billboard": caf_billboards,
        "weather_step_vs_instances": weather,
        "caf_vs_ndt": ndt,
        "render": render,
    }
    path = common.write_json(args.out / "billboards.json", data)
    plot(data, args.out / "billboards.png")
    common.log(f"wrote {path} and {args.out / 'billboards.png'}")
    return 0


def plot(data: dict[str, Any], path: Path) -> None:
    plt = common.pyplot()
    render = data.get("render")
    rows_ = 1 + (render is not None) + bool(render and render["impostors"].get("points"))
    fig, grid = plt.subplots(rows_, 3, figsize=(15, 4 * rows_), squeeze=False)
    axes = grid[0]
    for key, label in (("generation_vs_levels", "vs levels L"),
                       ("generation_vs_boxes_per_level", "vs boxes per level")):  # fmt: skip
        rows = list(data[key].values())
        for series, style in (("1_thread", "-o"), ("all_cores", "--s")):
            axes[0].plot([r["billboards"] for r in rows], [1e3 * r[series]["median"] for r in rows],
                         style, label=f"{label}, {series}")  # fmt: skip
    axes[0].set(xlabel="billboards per cloud", ylabel="median time (ms)", xscale="log",
                yscale="log", title="seed_box_cloud")  # fmt: skip
    rows = list(data["caf_vs_boxes"].values())
    for series, style in (("sum", "-o"), ("union", "--s")):
        axes[1].plot([r["boxes"] for r in rows], [1e3 * r[series]["median"] for r in rows], style,
                     label=f"overlap={series}")  # fmt: skip
    axes[1].set(xlabel="boxes M", ylabel="median time (ms)", xscale="log", yscale="log",
                title="absorption_factors (CAF per box)")  # fmt: skip
    rows = list(data["weather_step_vs_instances"].values())
    axes[2].plot([r["instances"] for r in rows], [1e3 * r["step_s"]["median"] for r in rows], "-o")
    axes[2].set(xlabel="instances in the layer", ylabel="median step time (ms)", xscale="log",
                yscale="log", title="Weather.step (dt = 0.1 s)")  # fmt: skip
    if render:
        plot_render(render, grid[1])
    if rows_ == 3:
        imp.plot_sweep(render, grid[2])
    for ax in grid.flat:
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    m = data["machine"]
    fig.suptitle(f"cumuli billboard clouds — {m['cpu_model']}, {m['cores']} cores, GL "
                 f"{m.get('gl_renderer')}", fontsize=9)  # fmt: skip
    fig.tight_layout()
    common.save_figure(fig, path)


def plot_render(render: dict[str, Any], axes: Any) -> None:
    w, h = render["size"]
    rows = list(render["render_vs_clouds"].values())
    for series, style in (("gl", "-o"), ("cpu", "--s")):
        pts = [(r["clouds"], 1e3 * r[series]["median"]) for r in rows if series in r]
        axes[0].plot(*zip(*pts, strict=True), style, label=f"{series.upper()} ({w}×{h})")
    axes[0].set(xlabel="clouds (10 cumulus models, instanced)", ylabel="median frame (ms)",
                xscale="log", yscale="log", title="render vs clouds")  # fmt: skip
    rows = list(render["render_vs_billboards_per_cloud"].values())
    for series, style in (("gl", "-o"), ("cpu", "--s")):
        axes[1].plot(
            [r["billboards_per_cloud"] for r in rows],
            [1e3 * r[series]["median"] for r in rows],
            style,
            label=series.upper(),
        )
    axes[1].set(xlabel="billboards per cloud (100 clouds)", ylabel="median frame (ms)",
                xscale="log", yscale="log", title="render vs billboards per cloud")  # fmt: skip
    scenes = render["paper_scenes"]
    names = list(scenes)
    x = np.arange(len(names))
    key = {n: "fps_mean" if scenes[n]["compared"] == "mean" else "fps_median" for n in names}
    measured = [scenes[n][key[n]] for n in names]
    through = [scenes[n].get("gl_impostors", {}).get(key[n], 0.0) for n in names]
    axes[2].bar(x - 0.27, measured, 0.27, label=f"cumuli GL {w}×{h}")
    axes[2].bar(x, through, 0.27, label="cumuli GL, impostors")
    axes[2].bar(x + 0.27, [scenes[n]["paper_hz"] for n in names], 0.27, label="[TM] 2005")
    axes[2].set_xticks(x, names)
    axes[2].set(ylabel="frames per second", yscale="log", title="[TM]'s four scenes")


if __name__ == "__main__":
    sys.exit(main())
