"""Cloud-shape generators: time per cloud against size, and the methods they can choose between.

Measured (median / best / worst wall time of repeats, plus process CPU time):

* ``gaussian``: `gaussian_cumulus` at n = 35 (the paper: "pre-computation under 0.010 s"), and at
  growing n with and without the O(n²) containment filter of eq. (17) (ratio: filter cost).
* ``lsystem``: `lsystem_cloud` with the paper's grammar at growing iterations (2ⁿ spheres):
  expansion + turtle, spheres per second.
* ``mesh``: `ellipsoids_from_mesh` (eqs. 22–30) on the procedural rabbit at growing face counts,
  on 1 thread and on all cores (ratio: parallel speed-up; only meaningful with idle cores, the
  load average is recorded), and `mesh_cloud` with quadric decimation to 400 faces.

No pass/fail on time. JSON + PNG under ``benchmarks/out/`` (``--out`` to change).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402

import cumuli as cu  # noqa: E402


def _timed(fn, repeats: int, count: int) -> dict[str, Any]:
    wall, cpu = common.time_repeats(fn, repeats)
    w = common.spread(wall)
    return {"wall_s": w, "cpu_s": common.spread(cpu), "items_per_s": common.rate(count, w)}


def bench_gaussian(quick: bool, repeats: int) -> dict[str, Any]:
    sizes = [35, 350, 1000] if quick else [35, 350, 1000, 3500, 10000]
    out: dict[str, Any] = {"paper_n35": _timed(lambda: cu.gaussian_cumulus(seed=1), repeats, 35)}
    rows = []
    for n in sizes:
        with_filter = _timed(lambda n=n: cu.gaussian_cumulus(n=n, seed=1), repeats, n)
        without = _timed(
            lambda n=n: cu.gaussian_cumulus(n=n, seed=1, remove_contained=False), repeats, n
        )
        rows.append(
            {
                "n": n,
                "with_containment": with_filter,
                "without_containment": without,
                "containment_cost_ratio": with_filter["wall_s"]["median"]
                / without["wall_s"]["median"],
            }
        )
    out["sizes"] = rows
    return out


def bench_lsystem(quick: bool, repeats: int) -> list[dict[str, Any]]:
    iterations = [7, 10, 13] if quick else [7, 10, 13, 16, 18]
    rows = []
    for it in iterations:
        rows.append(
            {
                "iterations": it,
                "spheres": 2**it,
                **_timed(
                    lambda it=it: cu.lsystem_cloud(iterations=it, angle=(50, 100), seed=2),
                    repeats,
                    2**it,
                ),
            }
        )
    return rows


def bench_mesh(quick: bool, repeats: int, cores: int) -> dict[str, Any]:
    subdivisions = [1, 2, 3] if quick else [1, 2, 3, 4, 5]
    rows = []
    for s in subdivisions:
        v, f = cu.meshes.bunny_like(subdivisions=s)
        one = _timed(
            lambda v=v, f=f: cu.ellipsoids_from_mesh(v, f, 1.2, threads=1), repeats, len(f)
        )
        row: dict[str, Any] = {"faces": int(len(f)), "threads_1": one}
        if cores > 1:
            many = _timed(
                lambda v=v, f=f: cu.ellipsoids_from_mesh(v, f, 1.2, threads=0), repeats, len(f)
            )
            row["threads_all"] = many
            row["all_over_1_speedup"] = one["wall_s"]["median"] / many["wall_s"]["median"]
        rows.append(row)
    v, f = cu.meshes.bunny_like(subdivisions=2)
    decimate = _timed(lambda: cu.mesh_cloud((v, f), scale=1.2, target_faces=400), repeats, len(f))
    return {"sizes": rows, "mesh_cloud_decimate_2240_to_400": decimate}


def plot(result: dict[str, Any], path: Path) -> None:
    plt = common.pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    g = result["gaussian"]["sizes"]
    ax = axes[0]
    ns = [r["n"] for r in g]
    ax.loglog(ns, [r["with_containment"]["wall_s"]["median"] for r in g], "o-", label="filters")
    ax.loglog(
        ns, [r["without_containment"]["wall_s"]["median"] for r in g], "s--", label="no eq. (17)"
    )
    ax.set_xlabel("primitives drawn n")
    ax.set_ylabel("seconds per cloud (median)")
    ax.set_title("gaussian_cumulus")
    ax.legend()
    ax = axes[1]
    ls = result["lsystem"]
    ax.loglog([r["spheres"] for r in ls], [r["wall_s"]["median"] for r in ls], "o-")
    ax.set_xlabel("spheres (2^iterations)")
    ax.set_title("lsystem_cloud (X→X+Y, Y→X&Y)")
    ax = axes[2]
    ms = result["mesh"]["sizes"]
    faces = [r["faces"] for r in ms]
    ax.loglog(faces, [r["threads_1"]["wall_s"]["median"] for r in ms], "o-", label="1 thread")
    if all("threads_all" in r for r in ms):
        ax.loglog(
            faces, [r["threads_all"]["wall_s"]["median"] for r in ms], "s--", label="all cores"
        )
    ax.set_xlabel("triangles")
    ax.set_title("ellipsoids_from_mesh")
    ax.legend()
    machine = result["machine"]
    fig.suptitle(f"{machine['cpu_model']} ×{machine['cores']} — medians of {result['repeats']}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    repeats = 3 if args.quick else 9
    machine = common.machine_info()
    common.log(f"machine: {machine['cpu_model']} ×{machine['cores']}")
    result: dict[str, Any] = {
        "benchmark": "shapes",
        "description": "cloud-shape generators: seconds per cloud against size",
        "quick": args.quick,
        "repeats": repeats,
        "machine": machine,
        "gaussian": bench_gaussian(args.quick, repeats),
        "lsystem": bench_lsystem(args.quick, repeats),
        "mesh": bench_mesh(args.quick, repeats, machine["cores"]),
    }
    json_path = common.write_json(args.out / "shapes.json", result)
    plot(result, args.out / "shapes.png")
    p = result["gaussian"]["paper_n35"]["wall_s"]["median"]
    common.log(f"gaussian_cumulus n=35: {p * 1e3:.3f} ms per cloud (paper: < 10 ms incl. light)")
    for r in result["gaussian"]["sizes"]:
        common.log(
            f"  n={r['n']:6d}: {r['with_containment']['wall_s']['median'] * 1e3:9.3f} ms, "
            f"containment filter ×{r['containment_cost_ratio']:.2f}"
        )
    for r in result["lsystem"]:
        common.log(
            f"lsystem {r['iterations']:2d} iterations ({r['spheres']} spheres): "
            f"{r['wall_s']['median'] * 1e3:.3f} ms"
        )
    for r in result["mesh"]["sizes"]:
        extra = f", all cores ×{r['all_over_1_speedup']:.2f}" if "all_over_1_speedup" in r else ""
        common.log(
            f"mesh {r['faces']:6d} faces: {r['threads_1']['wall_s']['median'] * 1e3:.3f} ms "
            f"on 1 thread{extra}"
        )
    d = result["mesh"]["mesh_cloud_decimate_2240_to_400"]["wall_s"]["median"]
    common.log(f"mesh_cloud with decimation 2240 → 400 faces: {d * 1e3:.2f} ms")
    common.log(f"wrote {json_path} and {args.out / 'shapes.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
