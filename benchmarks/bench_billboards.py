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

Render timings (the paper's 25/20/10/27 Hz) come with the sprite renderer (phase 2). Medians of
repeats; nothing passes or fails on time.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402

from cumuli.anim.weather import CloudLayer, SkyState, Weather  # noqa: E402
from cumuli.light.caf import (  # noqa: E402
    absorption_factors,
    light_grid_at_boxes,
    rank_correlation,
)
from cumuli.model import seedbox_presets as presets  # noqa: E402
from cumuli.model.billboards import BasisModel, SeedBox, seed_box_cloud  # noqa: E402

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
    }
    path = common.write_json(args.out / "billboards.json", data)
    plot(data, args.out / "billboards.png")
    common.log(f"wrote {path} and {args.out / 'billboards.png'}")
    return 0


def plot(data: dict[str, Any], path: Path) -> None:
    plt = common.pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
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
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    m = data["machine"]
    fig.suptitle(f"cumuli billboard clouds — {m['cpu_model']}, {m['cores']} cores", fontsize=9)
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    tmp.replace(path)


if __name__ == "__main__":
    sys.exit(main())
