"""Endless cloud animation (Iwasaki et al. 2011): precompute and per-frame costs.

Measured (median / best / worst wall time of repeats, plus process CPU time):

* ``similarity``: the similarity matrix ``D`` (C++) against the number of volumes N and their
  resolution, on 1 thread and on all cores (ratio), and against a numpy reference at one size
  (ratio: C++ speed-up).
* ``optical_depth``: per database volume, the sun optical depth and the SH optical depth, by
  sweeping (``method="sweep"``: each sun-parallel line of a sheared grid integrated
  once) and by brute-force marching (one march per voxel and direction, today's method), against
  resolution: times, march/sweep ratios and the swept depths' mean difference from the marched.
* ``precompute``: the example of docs/iwasaki-animation.md, ``VolumeLighting`` on 24 volumes of
  32³ with the default settings (order-4 SH over 72 directions, 32 scattering points; --quick:
  4 volumes of 16³), by sweeping (all cores), against marching (timed on one volume and scaled
  by the volume count).
* ``sky_accuracy``: the SH exponential (the paper's fitted eq. 7 against scaling and squaring)
  at SH orders 2–4, with swept and with marched depths: median / 90th-percentile relative error
  of the uniform-sky visibility ``∫τ dω`` against brute-force marching along every quadrature
  direction, and the light time.

Issue 14's targets, ``targets[name] = {limit, comparison, reached, met}`` with today's method
(marching) as ``baseline``: the docs example's precompute in ≤ 10 s, at the same accuracy (the
order-4 squaring sky-visibility error with swept depths no more than 1 point above the marched).
* ``frame``: one displayed frame of a cross-dissolve: blend the densities and the optical depths,
  evaluate the light (SH exponential), render on the CPU and (where a GL context exists) with
  the GL marcher — the shares of the frame time.

No pass/fail on time. JSON + PNG under ``benchmarks/out/`` (``--out`` to change).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402
import numpy as np  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.light.volume import (  # noqa: E402
    sh_optical_depth,
    sphere_quadrature,
    sun_optical_depth,
)

#: The sun of the docs example (towards the sun).
SUN_DIR = (0.5, 0.7, 0.3)
#: Issue 14: the docs example's precompute, seconds.
TARGET_PRECOMPUTE_S = 10.0
#: The swept depths may cost at most this much sky-visibility accuracy (median relative error).
TARGET_ACCURACY_SLACK = 0.01


def _timed(fn, repeats: int) -> dict[str, Any]:
    wall, cpu = common.time_repeats(fn, repeats)
    return {"wall_s": common.spread(wall), "cpu_s": common.spread(cpu)}


def _med(r: dict[str, Any]) -> float:
    return r["wall_s"]["median"]


def bench_similarity(quick: bool, repeats: int, cores: int) -> dict[str, Any]:
    rng = np.random.default_rng(0)
    counts = [8, 16, 32] if quick else [16, 32, 64, 128]
    resolutions = [16, 24] if quick else [16, 32, 48]
    rows = []
    for res in resolutions:
        for n in counts:
            vols = rng.random((n, res, res, res), dtype=np.float32)
            row: dict[str, Any] = {"n": n, "resolution": res}
            row["threads_1"] = _timed(lambda v=vols: cu.similarity_matrix(v, threads=1), repeats)
            if cores > 1:
                row["threads_all"] = _timed(lambda v=vols: cu.similarity_matrix(v), repeats)
                row["all_over_1_speedup"] = _med(row["threads_1"]) / _med(row["threads_all"])
            rows.append(row)
    n, res = counts[0], resolutions[0]
    vols = rng.random((n, res, res, res), dtype=np.float32)
    flat = vols.reshape(n, -1).astype(np.float64)

    def numpy_ref() -> np.ndarray:
        return np.array([[((a - b) ** 2).sum() for b in flat] for a in flat])

    ref = _timed(numpy_ref, repeats)
    cpp = _timed(lambda: cu.similarity_matrix(vols, threads=1), repeats)
    return {
        "sizes": rows,
        "numpy_reference": {
            "n": n,
            "resolution": res,
            "numpy": ref,
            "cpp_1_thread": cpp,
            "numpy_over_cpp": _med(ref) / _med(cpp),
        },
    }


def _cloud_volumes(res: int, n: int) -> cu.VolumeDatabase:
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), seed=1)
    return cu.evolving_cloud_volumes(
        cloud, cu.Noise(seed=7), n, res, density_scale=2.0, frequency=0.3, seed=3
    )


def _relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).mean() / max(float(np.abs(b).mean()), 1e-30))


def bench_optical_depth(quick: bool, repeats: int) -> list[dict[str, Any]]:
    resolutions = [12, 16, 24] if quick else [16, 32, 48]
    sh_samples = 3 if quick else 6
    rows = []
    for res in resolutions:
        db = _cloud_volumes(res, 1)
        vol, box = db.volumes, db.box
        row: dict[str, Any] = {
            "resolution": res,
            "voxels": res**3,
            "sh_order": 3,
            "directions": 2 * sh_samples**2,
        }
        march_repeats = 1 if res >= 32 else max(1, repeats // 2)
        for method, reps in (("sweep", repeats), ("march", march_repeats)):
            row[method] = {
                "sun_per_volume": _timed(
                    lambda m=method, v=vol, b=box: sun_optical_depth(v, *b, SUN_DIR, method=m),
                    reps,
                ),
                "sky_sh_per_volume": _timed(
                    lambda m=method, v=vol, b=box: sh_optical_depth(v, *b, 3, sh_samples, method=m),
                    reps,
                ),
            }
        # Today's keys (the marched ones), kept for the plot and report.
        row["sun_per_volume"] = row["march"]["sun_per_volume"]
        row["sky_sh_per_volume"] = row["march"]["sky_sh_per_volume"]
        row["sky_over_sun"] = _med(row["sky_sh_per_volume"]) / _med(row["sun_per_volume"])
        row["march_over_sweep_sun"] = _med(row["march"]["sun_per_volume"]) / _med(
            row["sweep"]["sun_per_volume"]
        )
        row["march_over_sweep_sky"] = _med(row["march"]["sky_sh_per_volume"]) / _med(
            row["sweep"]["sky_sh_per_volume"]
        )
        sun = {m: sun_optical_depth(vol, *box, SUN_DIR, method=m) for m in ("sweep", "march")}
        sky = {m: sh_optical_depth(vol, *box, 3, sh_samples, method=m) for m in ("sweep", "march")}
        row["sweep_minus_march"] = {
            "sun_mean_abs_over_mean": _relative_difference(sun["sweep"], sun["march"]),
            "sun_max_abs": float(np.abs(sun["sweep"] - sun["march"]).max()),
            "sky_mean_abs_over_mean": _relative_difference(sky["sweep"], sky["march"]),
        }
        rows.append(row)
    return rows


def bench_precompute(quick: bool, repeats: int) -> dict[str, Any]:
    """The docs example's VolumeLighting precompute: swept (timed) against marched (one volume,
    scaled by the number of volumes); the database is made outside the timing."""
    n, res = (4, 16) if quick else (24, 32)
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), seed=1)
    db = cu.evolving_cloud_volumes(
        cloud, cu.Noise(seed=7), n, res, growth=0.25, wind=(0.08, 0.03, 0), density_scale=2.0,
        frequency=0.3, seed=3,
    )  # fmt: skip
    sun = cu.Sun(direction=SUN_DIR, intensity=10.0)
    sweep = _timed(
        lambda: cu.VolumeLighting(db, sun, sky=cu.Sky(), progress=False), 1 if quick else 3
    )
    one = cu.VolumeDatabase(db.volumes[:1], *db.box)
    march_one = _timed(
        lambda: cu.VolumeLighting(one, sun, sky=cu.Sky(), method="march", progress=False), 1
    )
    # The depths of the first volume, swept against marched.
    a = cu.VolumeLighting(one, sun, sky=cu.Sky(), progress=False)
    b = cu.VolumeLighting(one, sun, sky=cu.Sky(), method="march", progress=False)
    march_total = n * _med(march_one)
    return {
        "volumes": n,
        "resolution": res,
        "settings": "defaults: sh_order 4, sh_samples 6 (72 directions), ms_points 32, step 0.5",
        "sweep": sweep,
        "march_one_volume": march_one,
        "march_estimate_s": march_total,
        "march_over_sweep": march_total / _med(sweep),
        "sweep_minus_march": {
            "sun_depth": _relative_difference(a.sun_depth, b.sun_depth),
            "sky_depth": _relative_difference(a.sky_depth, b.sky_depth),
            "point_depth": _relative_difference(a.point_depth, b.point_depth),
            "light": _relative_difference(a.light(0), b.light(0)),
        },
    }


def bench_sky_accuracy(quick: bool, repeats: int) -> list[dict[str, Any]]:
    res, samples = (12, 4) if quick else (24, 6)
    db = _cloud_volumes(res, 1)
    dirs, w = sphere_quadrature(samples)
    depth = np.stack(
        [sun_optical_depth(db.volumes[0], *db.box, d, method="march") for d in dirs], -1
    )
    true = (np.exp(-depth) * w).sum(-1)
    inside = db.volumes[0] > 0
    rows = []
    for depth_method in ("sweep", "march"):
        for order in (2, 3, 4):
            for method in ("fit", "squaring"):
                lit = cu.VolumeLighting(
                    db, cu.Sun(), sky=(1, 1, 1), sh_order=order, sh_samples=samples, shexp=method,
                    ms_points=0, method=depth_method, progress=False,
                )  # fmt: skip
                vis = lit.light(0)[..., 1]
                rel = np.abs(vis - true) / true
                rows.append(
                    {
                        "sh_order": order,
                        "shexp": method,
                        "depth_method": depth_method,
                        "resolution": res,
                        "directions": int(len(dirs)),
                        "median_rel_error": float(np.median(rel)),
                        "p90_rel_error": float(np.percentile(rel, 90)),
                        "median_rel_error_in_cloud": float(np.median(rel[inside])),
                        "light": _timed(lambda lit=lit: lit.light(0), repeats),
                    }
                )
    return rows


def bench_frame(quick: bool, repeats: int, gl_ok: bool) -> dict[str, Any]:
    res = 20 if quick else 40
    width, height = (64, 48) if quick else (320, 240)
    db = _cloud_volumes(res, 8)
    sun = cu.Sun(direction=SUN_DIR, intensity=10.0)
    lighting = cu.VolumeLighting(
        db, sun, sh_order=3 if quick else 4, sh_samples=3 if quick else 6, progress=False
    )
    frame = cu.AnimationFrame(0, 2, 5, 0.5, True)
    density = cu.blend_volumes(db[2], db[5], 0.5)
    light = lighting.light(frame)
    lo, hi = np.array(db.box_min), np.array(db.box_max)
    c = (lo + hi) / 2
    cam = cu.Camera(tuple(c + np.array([0, 0.2, 0.9]) * (hi - lo).max()), tuple(c), fov=45)
    out: dict[str, Any] = {"resolution": res, "width": width, "height": height}
    out["blend_density"] = _timed(lambda: cu.blend_volumes(db[2], db[5], 0.5), repeats)
    out["blend_depths"] = _timed(lambda: lighting.optical_depth(frame), repeats)
    out["light"] = _timed(lambda: lighting.light(frame), repeats)
    out["render_cpu"] = _timed(
        lambda: cu.render_volume(density, light, db.box, cam, width, height, sun), repeats
    )
    if gl_ok:
        with cu.VolumeRenderer() as r:
            out["render_gl"] = _timed(
                lambda: r.render(density, light, db.box, cam, width, height, sun), repeats
            )
        out["cpu_over_gl"] = _med(out["render_cpu"]) / _med(out["render_gl"])
    render = _med(out.get("render_gl", out["render_cpu"]))
    out["frame_total_s"] = _med(out["blend_density"]) + _med(out["light"]) + render
    return out


def plot(result: dict[str, Any], path: Path) -> None:
    plt = common.pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    ax = axes[0]
    rows = result["similarity"]["sizes"]
    for res in sorted({r["resolution"] for r in rows}):
        sel = [r for r in rows if r["resolution"] == res]
        ax.loglog([r["n"] for r in sel], [_med(r["threads_1"]) for r in sel], "o-", label=f"{res}³")
    ax.set_xlabel("volumes N")
    ax.set_ylabel("seconds (median, 1 thread)")
    ax.set_title("similarity matrix D")
    ax.legend()
    ax = axes[1]
    od = result["optical_depth"]
    vox = [r["voxels"] for r in od]
    for method, style in (("march", "-"), ("sweep", ":")):
        ax.loglog(vox, [_med(r[method]["sun_per_volume"]) for r in od], "o" + style,
                  label=f"sun ({method})")  # fmt: skip
        ax.loglog(vox, [_med(r[method]["sky_sh_per_volume"]) for r in od], "s" + style,
                  label=f"sky SH ({method})")  # fmt: skip
    ax.set_xlabel("voxels per volume")
    ax.set_title("optical-depth precompute per volume")
    ax.legend()
    ax = axes[2]
    fr = result["frame"]
    names = [
        k for k in ("blend_density", "blend_depths", "light", "render_cpu", "render_gl") if k in fr
    ]
    ax.bar(names, [_med(fr[k]) * 1e3 for k in names])
    ax.set_ylabel("ms per frame (median)")
    ax.set_title(f"one frame ({fr['resolution']}³, {fr['width']}×{fr['height']})")
    ax.tick_params(axis="x", rotation=30)
    m = result["machine"]
    fig.suptitle(f"{m['cpu_model']} ×{m['cores']} — GL: {m['gl_renderer']}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    repeats = 3 if args.quick else 7
    machine = common.machine_info()
    common.log(f"machine: {machine['cpu_model']} ×{machine['cores']}, GL: {machine['gl_renderer']}")
    result: dict[str, Any] = {
        "benchmark": "animation",
        "description": "Iwasaki 2011: similarity matrix, optical-depth precompute, per-frame cost",
        "quick": args.quick,
        "repeats": repeats,
        "machine": machine,
        "similarity": bench_similarity(args.quick, repeats, machine["cores"]),
        "optical_depth": bench_optical_depth(args.quick, repeats),
        "precompute": bench_precompute(args.quick, repeats),
        "sky_accuracy": bench_sky_accuracy(args.quick, repeats),
        "frame": bench_frame(args.quick, repeats, machine["gl_renderer"] is not None),
    }
    pre = result["precompute"]
    acc = {
        r["depth_method"]: r["median_rel_error"]
        for r in result["sky_accuracy"]
        if r["sh_order"] == 4 and r["shexp"] == "squaring"
    }
    result["targets"] = {
        # The docs example (24 × 32³); --quick runs a smaller database, so no verdict.
        "precompute_readme_s": common.target(
            TARGET_PRECOMPUTE_S,
            None if args.quick else _med(pre["sweep"]),
            "<=",
            measure=f"VolumeLighting wall time, {pre['volumes']} volumes of {pre['resolution']}³, "
            "all cores, median",
            baseline={
                "method": "march",
                "reached": None if args.quick else pre["march_estimate_s"],
                "ratio": pre["march_over_sweep"],
            },
        ),  # fmt: skip
        "sky_visibility_error_order4": common.target(
            acc["march"] + TARGET_ACCURACY_SLACK,
            acc["sweep"],
            "<=",
            measure="median relative error of ∫τ dω against brute-force marching, order 4, "
            "scaling and squaring, swept depths (limit: marched depths' error + 0.01)",
            baseline={"method": "march", "reached": acc["march"], "ratio": None},
        ),  # fmt: skip
    }
    json_path = common.write_json(args.out / "animation.json", result)
    plot(result, args.out / "animation.png")
    for r in result["similarity"]["sizes"]:
        extra = f", all cores ×{r['all_over_1_speedup']:.2f}" if "all_over_1_speedup" in r else ""
        common.log(
            f"D: N={r['n']:4d} at {r['resolution']}³: {_med(r['threads_1']) * 1e3:9.2f} ms{extra}"
        )
    ref = result["similarity"]["numpy_reference"]
    common.log(f"D: numpy reference / C++ (1 thread) = ×{ref['numpy_over_cpp']:.1f}")
    for r in result["optical_depth"]:
        d = r["sweep_minus_march"]
        common.log(
            f"optical depth {r['resolution']}³ per volume: sun "
            f"{_med(r['sweep']['sun_per_volume']) * 1e3:.1f} ms swept / "
            f"{_med(r['march']['sun_per_volume']) * 1e3:.1f} ms marched "
            f"(×{r['march_over_sweep_sun']:.1f}), sky SH ({r['directions']} dirs) "
            f"{_med(r['sweep']['sky_sh_per_volume']) * 1e3:.1f} / "
            f"{_med(r['march']['sky_sh_per_volume']) * 1e3:.1f} ms "
            f"(×{r['march_over_sweep_sky']:.1f}); swept − marched: mean |Δ|/mean sun "
            f"{d['sun_mean_abs_over_mean']:.3f}, sky {d['sky_mean_abs_over_mean']:.3f}"
        )
    d = pre["sweep_minus_march"]
    common.log(
        f"precompute, {pre['volumes']} volumes of {pre['resolution']}³: swept "
        f"{_med(pre['sweep']):.2f} s, marched ≈ {pre['march_estimate_s']:.1f} s "
        f"(×{pre['march_over_sweep']:.1f}); swept − marched, mean |Δ|/mean: sun "
        f"{d['sun_depth']:.3f}, sky {d['sky_depth']:.3f}, points {d['point_depth']:.3f}, "
        f"light {d['light']:.3f}"
    )
    for r in result["sky_accuracy"]:
        common.log(
            f"sky visibility, order {r['sh_order']} {r['shexp']:8s} ({r['depth_method']} depths):"
            f" median rel. error {r['median_rel_error']:.3f} (p90 {r['p90_rel_error']:.3f}), "
            f"light {_med(r['light']) * 1e3:.1f} ms"
        )
    for name, t in result["targets"].items():
        common.log(common.show_target(name, t, " s" if name.endswith("_s") else ""))
    fr = result["frame"]
    parts = ", ".join(
        f"{k} {_med(fr[k]) * 1e3:.2f} ms"
        for k in ("blend_density", "blend_depths", "light", "render_cpu", "render_gl")
        if k in fr
    )
    common.log(f"frame: {parts}; total {fr['frame_total_s'] * 1e3:.1f} ms")
    common.log(f"wrote {json_path} and {args.out / 'animation.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
