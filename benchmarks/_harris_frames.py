"""Frame-time parts of ``bench_particles.py``: Harris 2002's
impostor claims measured as ratios in one run.

(b) **Fig. 8 sweep**: fields of N clouds × 200 particles, a circular path around the field and a
    fly-through along the view direction; the same frames drawn directly (all splats every
    frame) and through an :class:`cumuli.ImpostorCache`; frame time = wall time of the render
    call (draws, read-back, Python), median over the path; ratio direct / impostors per point.
(c) **34 large clouds, ~90 000 particles** flown through at the paper's two sizes, with and
    without impostors (inside a cloud the impostor is a screen impostor, regenerated every
    frame at ¼ resolution per axis).
(d) **Popping against tolerance**: update counts and the popping measure of spec §10.3.4 along a
    slow orbit for several tolerances; and the screen impostor's error and time at 1/2, 1/4,
    1/8 resolution per axis with the eye inside a cloud.

On a software rasteriser every image edge is divided by 4 and the sweep stops at 1600 clouds, as
the spec says; the camera speeds are 1 world unit per frame (clouds are ~40 units across).
"""

from __future__ import annotations

import math
import time
from typing import Any

import _common as common
import numpy as np

import cumuli as cu

#: Variants of the 200-particle cloud a field is made of (translated copies).
VARIANTS = 8
SPACING = 45.0  # world units per cloud along each axis of the field
SPEED = 1.0  # world units per frame
SUN = cu.Sun(direction=(0.35, 0.8, 0.25), intensity=1.6)


def variants(particles: int, radius: tuple[float, float], count: int = VARIANTS) -> list[Any]:
    return [
        cu.particle_cumulus((0.0, 0.0, 0.0), particles, seed=11 + k, radius=radius)
        for k in range(count)
    ]


def field(n: int, seed: int = 0) -> tuple[cu.Scene, float]:
    """``n`` clouds of 200 particles scattered over a square of side ``√n·SPACING`` (constant
    density), heights 0–30; returns the scene and the side."""
    rng = np.random.default_rng(seed)
    side = math.sqrt(n) * SPACING
    shapes = variants(200, (3.0, 5.0))
    clouds = [
        shapes[k % len(shapes)].translated(
            (rng.uniform(-side / 2, side / 2), rng.uniform(0, 30), rng.uniform(-side / 2, side / 2))
        )
        for k in range(n)
    ]
    scene = cu.Scene(
        clouds,
        sun=SUN,
        sprite_settings=cu.SpriteSettings(ambient=(0.15, 0.15, 0.18)),
        settings=cu.RenderSettings(lighting="paper"),
    )
    return scene, side


def paths(side: float, frames: int) -> dict[str, list[cu.Camera]]:
    """An orbit around the field (radius 0.6·side, 40 above, looking at the centre) and a
    fly-through across it along the view direction, both at ``SPEED`` units per frame."""
    radius = 0.6 * side
    step = math.degrees(SPEED / radius)
    orbit = cu.orbit((0.0, 15.0, 0.0), radius, frames, height=25.0, degrees=step * (frames - 1))
    start = np.array([-side / 2 - 30.0, 20.0, 0.0])
    fly = [
        cu.Camera(tuple(start + (SPEED * f, 0, 0)), tuple(start + (SPEED * f + 100, -2, 0)), fov=50)
        for f in range(frames)
    ]
    return {"orbit": orbit, "fly_through": fly}


def run_path(
    renderer: Any,
    scene: cu.Scene,
    cams: list[cu.Camera],
    size: tuple[int, int],
    variants: tuple[str, ...] = ("paper",),
) -> dict[str, Any]:
    """Frame times of a path drawn directly and through a fresh impostor cache per
    ``ImpostorSettings.preset`` in ``variants`` (interleaved frame by frame); the first frame
    (impostor generation of every cloud) apart. The first variant's numbers are at the top
    level, every variant's under ``variants``."""
    w, h = size
    cu.prepare_light(scene)  # the light step is memoised: not part of the frame times
    renderer.render(scene, cams[0], w, h)  # warm-up (programs, uploads)
    scenes = {v: scene.replace(impostor_settings=cu.ImpostorSettings.preset(v)) for v in variants}
    caches = {v: cu.ImpostorCache() for v in variants}
    direct: list[float] = []
    timed: dict[str, list[float]] = {v: [] for v in variants}
    first: dict[str, float] = {}
    for k, cam in enumerate(cams):
        t0 = time.perf_counter()
        renderer.render(scene, cam, w, h)
        if k:
            direct.append(time.perf_counter() - t0)
        for v in variants:
            t1 = time.perf_counter()
            renderer.render(scenes[v], cam, w, h, impostors=caches[v])
            seconds = time.perf_counter() - t1
            if k:
                timed[v].append(seconds)
            else:
                first[v] = seconds
    d = common.spread(direct)
    out: dict[str, Any] = {"direct_s": d, "frames": len(cams), "variants": {}}
    for v in variants:
        cache = caches[v]
        i = common.spread(timed[v])
        out["variants"][v] = {
            "impostors_s": i,
            "first_impostor_frame_s": first[v],
            "ratio": d["median"] / i["median"],
            "ratio_of_means": float(np.mean(direct) / np.mean(timed[v])),
            "updates_per_frame": float(
                np.mean([sum(hh["updates"].values()) for hh in cache.history[1:]])
            ),
            "updates_by_reason": cache.stats["updates"],
            "culled_per_frame": float(np.mean([hh["culled"] for hh in cache.history])),
            "texels": cache.stats["texels"],
        }
    out.update(out["variants"][variants[0]])
    return out


def sweep(renderer: Any, quick: bool, software: bool) -> dict[str, Any]:
    """Part (b): the Fig. 8 sweep."""
    if quick:
        counts, frames, size = [20, 40], 4, (64, 48)
    elif software:
        counts, frames, size = [100, 200, 400, 800, 1600], 10, (160, 120)
    else:
        counts, frames, size = [100, 200, 400, 800, 1600, 3200, 6400, 12800], 20, (640, 480)
    points = []
    for n in counts:
        scene, side = field(n)
        for name, cams in paths(side, frames).items():
            entry = {"clouds": n, "particles": 200 * n, "path": name, **run_path(
                renderer, scene, cams, size)}  # fmt: skip
            common.log(
                f"  (b) {n:>5} clouds {name:<11} direct {1e3 * entry['direct_s']['median']:8.1f} "
                f"ms  impostors {1e3 * entry['impostors_s']['median']:7.1f} ms  ratio "
                f"{entry['ratio']:.2f}  updates/frame {entry['updates_per_frame']:.1f}"
            )
            points.append(entry)
    ratios = [p["ratio"] for p in points]
    return {
        "size": list(size),
        "frames_per_path": frames,
        "speed_units_per_frame": SPEED,
        "points": points,
        "mean_ratio": float(np.mean(ratios)),
        "paper": "impostors 3-5x faster on average over 100-12800 clouds (GeForce 256)",
    }


def big_clouds(quick: bool) -> cu.Scene:
    """34 large clouds of ~2650 particles (~90 000 in all) in a loose row along +x."""
    count, per = (6, 300) if quick else (34, 2650)
    shapes = variants(per, (2.0, 3.5), count=min(count, 6))
    rng = np.random.default_rng(5)
    clouds = [
        shapes[k % len(shapes)].translated((70.0 * k, rng.uniform(-8, 8), rng.uniform(-25, 25)))
        for k in range(count)
    ]
    return cu.Scene(
        clouds,
        sun=SUN,
        sprite_settings=cu.SpriteSettings(ambient=(0.15,) * 3),
        settings=cu.RenderSettings(lighting="paper"),
    )


def fly_through_big(renderer: Any, quick: bool, software: bool) -> dict[str, Any]:
    """Part (c): 34 clouds / 90 000 particles, flown through, with and without impostors."""
    scene = big_clouds(quick)
    sizes = [(640, 480), (1600, 1200)]
    if quick:
        sizes = [(64, 48)]
    elif software:
        sizes = [(w // 4, h // 4) for w, h in sizes]
    frames = 4 if quick else 16
    # Along the row, passing through clouds (the eye enters some: screen impostors).
    start = np.array([-60.0, 0.0, 0.0])
    cams = [
        cu.Camera(tuple(start + (6.0 * f, 0, 0)), tuple(start + (6.0 * f + 50, -1, 3)), fov=55)
        for f in range(frames)
    ]
    out = []
    for size in sizes:
        entry = {"size": list(size), **run_path(renderer, scene, cams, size,
                                                ("paper", "skyworks"))}  # fmt: skip
        sky = entry["variants"]["skyworks"]
        common.log(
            f"  (c) {size[0]}x{size[1]}: direct {1e3 * entry['direct_s']['median']:.1f} ms, "
            f"impostors {1e3 * entry['impostors_s']['median']:.1f} ms, ratio {entry['ratio']:.2f}"
            f"; SkyWorks' resolution rule {1e3 * sky['impostors_s']['median']:.1f} ms, ratio "
            f"{sky['ratio']:.2f}"
        )
        out.append(entry)
    return {
        "clouds": len(scene.clouds),
        "particles": int(sum(c.n for c in scene.clouds)),
        "path": "along the row of clouds, through some of them (screen impostors inside)",
        "speed_units_per_frame": 6.0,
        "runs": out,
        "paper": "34 clouds, ~90 000 particles: >60 fps (640x480) and ~30 fps (1600x1200) with "
        "impostors, as low as 8 and 4 fps without: about 7.5x (GeForce 3)",
    }


def popping(renderer: Any, quick: bool, software: bool) -> dict[str, Any]:
    """Part (d): popping and updates against the tolerance; screen impostors' resolution."""
    size = (48, 36) if quick else ((160, 120) if software else (640, 480))
    frames = 6 if quick else 40
    shape = variants(600, (2.0, 3.5), count=1)[0]
    scene = cu.Scene(
        [shape],
        sun=SUN,
        sprite_settings=cu.SpriteSettings(ambient=(0.15,) * 3),
        settings=cu.RenderSettings(lighting="paper"),
    )
    cams = cu.orbit((0.0, 0.0, 0.0), 80.0, frames, height=10.0, degrees=0.25 * (frames - 1))
    w, h = size
    direct = [renderer.render(scene, c, w, h) for c in cams]
    tolerances = []
    for tol in (0.15, 0.25, 0.5, 1.0):
        sc = scene.replace(impostor_settings=cu.ImpostorSettings(tolerance=tol))
        cache = cu.ImpostorCache()
        imgs = [renderer.render(sc, c, w, h, impostors=cache) for c in cams]
        pops = [
            float(np.abs(imgs[f] - imgs[f - 1]).max() - np.abs(direct[f] - direct[f - 1]).max())
            for f in range(1, frames)
            if cache.history[f]["updates"]
        ]
        error = [float(np.abs(imgs[f] - direct[f]).mean()) for f in range(frames)]
        tolerances.append(
            {
                "tolerance_deg": tol,
                "updates": sum(sum(hh["updates"].values()) for hh in cache.history[1:]),
                "popping_mean": float(np.mean(pops)) if pops else 0.0,
                "popping_max": float(np.max(pops)) if pops else 0.0,
                "mean_abs_error_vs_direct": float(np.mean(error)),
            }
        )
        common.log(f"  (d) tolerance {tol}: {tolerances[-1]}")
    # Eye inside the cloud: screen impostors at 1/f per axis.
    inside = cu.Camera((0.0, 2.0, -2.0), (0.0, 2.0, 20.0), fov=60)
    ref = renderer.render(scene, inside, w, h)
    t0 = time.perf_counter()
    for _ in range(3):
        renderer.render(scene, inside, w, h)
    direct_s = (time.perf_counter() - t0) / 3
    factors = []
    for f in (1, 2, 4, 8):
        sc = scene.replace(impostor_settings=cu.ImpostorSettings(inside_factor=f))
        cache = cu.ImpostorCache()
        renderer.render(sc, inside, w, h, impostors=cache)
        t0 = time.perf_counter()
        for _ in range(3):
            img = renderer.render(sc, inside, w, h, impostors=cache)
        factors.append(
            {
                "factor": f,
                "frame_s": (time.perf_counter() - t0) / 3,
                "mean_abs_error": float(np.abs(img - ref).mean()),
                "updates_by_reason": cache.stats["updates"],
            }
        )
    return {
        "size": list(size),
        "orbit_deg_per_frame": 0.25,
        "tolerances": tolerances,
        "inside": {"direct_frame_s": direct_s, "factors": factors},
        "paper": "0.15 deg: imperceptible popping; up to 1 deg acceptable; inside clouds 1/4 "
        "resolution per axis is enough",
    }


def plot(data: dict[str, Any], path: Any) -> None:
    """Fig. 8 style: frame time against clouds, direct vs impostors, per path; ratios."""
    plt = common.pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    sweep_ = data.get("sweep")
    if sweep_:
        for name, style in (("orbit", "-"), ("fly_through", "--")):
            pts = [p for p in sweep_["points"] if p["path"] == name]
            xs = [p["clouds"] for p in pts]
            axes[0].plot(xs, [p["direct_s"]["median"] for p in pts], "o" + style,
                         label=f"direct, {name}")  # fmt: skip
            axes[0].plot(xs, [p["impostors_s"]["median"] for p in pts], "s" + style,
                         label=f"impostors, {name}")  # fmt: skip
            axes[1].plot(xs, [p["ratio"] for p in pts], "o" + style, label=name)
        axes[0].set(xscale="log", yscale="log", xlabel="clouds (200 particles each)",
                    ylabel="frame time (s)", title="Fig. 8 sweep")  # fmt: skip
        axes[1].axhspan(3, 5, color="0.9", label="paper: 3-5x")
        axes[1].set(xscale="log", xlabel="clouds", ylabel="direct / impostors",
                    title="impostor speed-up")  # fmt: skip
    pop = data.get("popping")
    if pop:
        t = [p["tolerance_deg"] for p in pop["tolerances"]]
        axes[2].plot(t, [p["popping_mean"] for p in pop["tolerances"]], "o-", label="popping")
        ax2 = axes[2].twinx()
        ax2.plot(t, [p["updates"] for p in pop["tolerances"]], "s--", color="C1", label="updates")
        ax2.set_ylabel("impostor updates along the orbit")
        ax2.legend(loc="upper center", fontsize=7)
        axes[2].set(xlabel="tolerance (deg)", ylabel="popping (max |Δ| above direct)",
                    title="popping vs tolerance")  # fmt: skip
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    m = data["machine"]
    fig.suptitle(f"Harris 2002 impostors — {m['cpu_model']}, GL: {m['gl_renderer']}", fontsize=9)
    fig.tight_layout()
    common.save_figure(fig, path)
