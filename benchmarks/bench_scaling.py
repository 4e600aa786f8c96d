"""Frame time against the number of clouds and of primitives per cloud (the paper's §4.1).

The complexity analysis of §4.1 sums, over the |B| boxes a ray meets, a candidate search linear
in the s primitives of the box, a sort quadratic in the c candidates at worst, and the march.

- **Clouds** (1 to 64): copies of the default cumulus on a square grid in a vertical plane, the
  camera backing off so the whole grid fills the same part of the view; every pixel's ray is box
  tested against every cloud.
- **Primitives per cloud** (6 to 512), two series at a fixed camera:
  *search*: a 6-sphere cumulus plus n − 6 tiny inert spheres (radius 0.01) scattered in its box,
  so the image stays the same while every ray that enters the box tests n primitives: this
  isolates §4.1's linear term, and a least-squares line through time(n) gives the cost per
  primitive and R²; *generator*: Gaussian cumuli of n spheres (no filters, so exactly n), where
  coverage, candidates and marching grow with n as well (the practical cost of bigger clouds).
  ``max_candidates`` is 128 so no ray drops candidates.

GL timer queries on a GPU, wall time on llvmpipe. Writes ``scaling.json`` and ``scaling.png``
under ``benchmarks/out/`` (or ``--out``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402
import numpy as np  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.demo import benchmark_scenes, distance_camera  # noqa: E402

CLOUD_COUNTS = [1, 2, 4, 8, 16, 32, 64]
PRIMITIVE_COUNTS = [6, 12, 24, 48, 96, 192, 384, 512]
SPACING = 32.0  # grid spacing of the cloud copies (the cumulus is ~28 units wide)


def cloud_grid(count: int) -> tuple[cu.LitScene, cu.Camera]:
    """``count`` copies of the benchmark cumulus on a √count-wide grid, framed by the camera."""
    base = benchmark_scenes(("cumulus",))["cumulus"]
    cloud = base.clouds[0]
    grid = cu.prepare_light(base).lights[0]  # one grid, shared by every copy (same sun, shape)
    side = math.ceil(math.sqrt(count))
    clouds, grids = [], []
    for k in range(count):
        row, col = divmod(k, side)
        offset = ((col - (side - 1) / 2) * SPACING, (row - (side - 1) / 2) * SPACING, 0.0)
        clouds.append(cloud.translated(offset))
        lo, hi = grid.box
        grids.append(cu.LightGrid(grid, (np.add(lo, offset), np.add(hi, offset)), grid.sun))
    scene = base.replace(clouds=clouds)
    # Back off so the grid (side·SPACING wide) fills the view as one cloud does from 48 units.
    return cu.prepare_light(scene, lights=grids), distance_camera(scene, 48.0 * side)


def primitive_scenes(n: int) -> dict[str, tuple[cu.Scene, cu.Camera]]:
    """The *search* and *generator* scenes with ``n`` primitives (see the module docstring)."""
    base = benchmark_scenes(("cumulus",))["cumulus"]
    settings = base.settings.replace(max_candidates=128)
    core = cu.gaussian_cumulus(centre=(0, 0, 0), n=6, seed=5, hollow=False, remove_contained=False)
    lo, hi = core.bbox
    rng = np.random.default_rng(n)
    extra = rng.uniform(lo, hi, size=(n - core.n, 3)).astype(np.float32)
    search = cu.Cloud(
        np.concatenate([core.centres, extra]),
        np.concatenate([core.radii, np.full((n - core.n, 3), 0.01, np.float32)]),
    )
    generator = cu.gaussian_cumulus(
        centre=(0, 0, 0), n=n, seed=5, hollow=False, remove_contained=False
    )
    # One fixed camera for every n: framing each cloud anew would move it as the clouds grow.
    camera = cu.Camera(position=(0.0, 0.0, -48.0), target=(0.0, 0.0, 0.0), fov=45.0)
    out = {}
    for name, cloud in (("search", search), ("generator", generator)):
        scene = base.replace(clouds=[cloud], settings=settings)
        out[name] = (cu.prepare_light(scene), camera)
    return out


def linear_fit(xs: list[float], ys: list[float]) -> dict[str, float]:
    """Least-squares ``y = a + b·x`` with R²."""
    x, y = np.asarray(xs, float), np.asarray(ys, float)
    b, a = np.polyfit(x, y, 1)
    pred = a + b * x
    ss_res = float(np.sum((y - pred) ** 2))
    ss_tot = float(np.sum((y - y.mean()) ** 2)) or 1.0
    return {"intercept_s": float(a), "slope_s_per_unit": float(b), "r2": 1.0 - ss_res / ss_tot}


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    machine = common.machine_info()
    sizes, size_note = common.render_sizes(machine["gl_renderer"], args.quick)
    w, h = sizes[-1] if args.quick else sizes[1]
    repeats = 2 if args.quick else 5
    counts = [1, 4] if args.quick else CLOUD_COUNTS
    prims = [6, 48] if args.quick else PRIMITIVE_COUNTS
    common.log(f"GL renderer: {machine['gl_renderer']}; frames at {w}x{h}")

    with cu.Renderer() as renderer:
        clouds_rows: list[dict[str, Any]] = []
        for count in counts:
            scene, camera = cloud_grid(count)
            t = common.time_frames(renderer, {"frame": (scene, camera)}, w, h, repeats)["frame"]
            clouds_rows.append(
                {"clouds": count, "primitives_total": sum(c.n for c in scene.scene.clouds), **t}
            )
            ms = 1e3 * common.frame_median(t)
            common.log(f"{count:3d} clouds: {ms:.1f} ms, coverage {t['coverage']:.2f}")
        prim_rows: dict[str, list[dict[str, Any]]] = {"search": [], "generator": []}
        for n in prims:
            timed = common.time_frames(renderer, primitive_scenes(n), w, h, repeats)
            for series, t in timed.items():
                prim_rows[series].append({"primitives": n, **t})
            common.log(
                f"{n:4d} primitives: "
                + ", ".join(
                    f"{k} {1e3 * common.frame_median(t):.1f} ms (coverage {t['coverage']:.2f})"
                    for k, t in timed.items()
                )
            )

    def fit(rows: list[dict[str, Any]], key: str) -> dict[str, float]:
        return linear_fit([r[key] for r in rows], [common.frame_median(r) for r in rows])

    prim_fit = {series: fit(rows, "primitives") for series, rows in prim_rows.items()}
    cloud_fit = fit(clouds_rows, "clouds")
    data = {
        "benchmark": "scaling",
        "quick": args.quick,
        "machine": machine,
        "size": f"{w}x{h}",
        "size_note": size_note,
        "repeats": repeats,
        "frame_time": "GL timer queries"
        if common.gl_timer_reliable(machine["gl_renderer"])
        else "wall time of Renderer.render (llvmpipe's timer queries miss its raster threads)",
        "clouds": {"rows": clouds_rows, "linear_fit": cloud_fit, "spacing": SPACING},
        "primitives": {
            "series": {
                k: {"rows": rows, "linear_fit": prim_fit[k]} for k, rows in prim_rows.items()
            },
            "search_inert_radius": 0.01,
            "max_candidates": 128,
        },
        "paper": "§4.1: time linear in the primitives s of a box (candidate search), "
        "c² sort at worst",
    }
    path = common.write_json(args.out / "scaling.json", data)
    search = prim_fit["search"]
    common.log(
        f"wrote {path}; candidate search: {1e6 * search['slope_s_per_unit']:.1f} µs per "
        f"primitive per frame, R² {search['r2']:.3f}"
    )
    plot(data, args.out / "scaling.png")
    return 0


def plot(data: dict, path: Path) -> None:
    plt = common.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    rows = data["clouds"]["rows"]
    axes[0].plot([r["clouds"] for r in rows], [1e3 * r["frame_s"]["median"] for r in rows], "o-")
    axes[0].set(xlabel="clouds in view", ylabel="ms per frame (median)", xscale="log", yscale="log")
    axes[0].set_title("frame time vs clouds (same framing)", fontsize=9)
    for series, entry in data["primitives"]["series"].items():
        rows = entry["rows"]
        xs = [r["primitives"] for r in rows]
        line = axes[1].plot(xs, [1e3 * r["frame_s"]["median"] for r in rows], "o-", label=series)
        fit = entry["linear_fit"]
        axes[1].plot(xs, [1e3 * (fit["intercept_s"] + fit["slope_s_per_unit"] * x) for x in xs],
                     "--", lw=0.8, color=line[0].get_color(),
                     label=f"{series} linear fit, R² {fit['r2']:.3f}")  # fmt: skip
    axes[1].set(xlabel="primitives per cloud", ylabel="ms per frame (median)")
    axes[1].set_title("frame time vs primitives", fontsize=9)
    axes[1].legend(fontsize=7)
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle(f"{data['size']} — {data['machine']['gl_renderer']}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
