"""Impostor parts of ``bench_billboards.py`` (Torchelsen & Musse 2005 skies through Harris 2002's
dynamic impostors, one per cloud and per field instance).

- **Render time against clouds, with and without impostors**: fields of N clouds (10 cumulus
  variants, constant density), an orbit around the field and a fly-through across it (through
  the cloud layer) at 1 world unit per frame (clouds are ~20 units across), as
  ``bench_particles`` part (b); per backend (GL and the C++ twin) the same frames drawn directly
  and through an :class:`cumuli.ImpostorCache`, interleaved frame by frame; the first frame (every
  impostor generated) apart; ratio direct / impostors of the medians, updates per frame by
  reason and the mean |impostors − direct| per frame.
- **The paper's scenes with impostors**: the frames of the direct rows (same cameras, same
  weather) timed through a fresh cache per backend, and for the Table 1 day also under a steady
  light (sun and sky held: only the wind moves the clouds), since the day dims the sun and
  darkens the sky with CV every frame — a light change regenerates every impostor. The direct
  rows sample the paths sparsely (the nimbus flight moves 22 units per frame, the day 10 s per
  frame), which no impostor survives; so the nimbus and rain flights are also flown at 1 unit
  per frame, and the day at [TM]'s own frame spacing (1/27 s per frame, from its start, middle
  and end), directly and through impostors.

Medians of the frames; nothing passes or fails on time.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable
from typing import Any

import _common as common
import numpy as np

import cumuli as cu

SPEED = 1.0  # world units per frame


def sweep_paths(n: int, frames: int, spacing: float = 40.0, altitude: float = 40.0) -> dict:
    """An orbit around a field of ``n`` clouds (radius 0.6·side, 20 below the layer, looking at
    its centre) and a fly-through across it at the layer's height, both at ``SPEED``."""
    side = spacing * math.sqrt(n)
    radius = 0.6 * side
    step = math.degrees(SPEED / radius)
    orbit = cu.orbit((0.0, altitude, 0.0), radius, frames, height=-20.0,
                     degrees=step * (frames - 1), fov=60.0)  # fmt: skip
    start = np.array([-side / 2 - 30.0, altitude, 0.0])
    fly = [cu.Camera(tuple(start + (SPEED * f, 0, 0)), tuple(start + (SPEED * f + 100, 2, 0)),
                     fov=60.0) for f in range(frames)]  # fmt: skip
    return {"orbit": orbit, "fly_through": fly}


def _draws(renderer: Any, size: tuple[int, int]) -> dict[str, Callable[..., Any]]:
    w, h = size
    return {
        "gl": lambda s, c, cache=None: renderer.render(s, c, w, h, impostors=cache),
        "cpu": lambda s, c, cache=None: cu.render_cpu(s, c, w, h, impostors=cache),
    }


def _record(direct: list[float], timed: list[float], first: float, cache: Any,
            errors: list[float]) -> dict[str, Any]:  # fmt: skip
    d, i = common.spread(direct), common.spread(timed)
    later = cache.history[1:]
    return {
        "direct_s": d,
        "impostors_s": i,
        "first_impostor_frame_s": first,
        "ratio": d["median"] / i["median"],
        "updates_per_frame": float(np.mean([sum(x["updates"].values()) for x in later])),
        "impostors_per_frame": float(np.mean([x["impostors"] for x in later])),
        "screen_per_frame": float(np.mean([x["screen"] for x in later])),
        "culled_per_frame": float(np.mean([x["culled"] for x in later])),
        "updates_by_reason": cache.stats["updates"],
        "mean_abs_error": common.spread(errors),
    }


def run_path(renderer: Any, lit: Any, cams: list[Any], size: tuple[int, int],
             backends: tuple[str, ...] = ("gl", "cpu")) -> dict[str, Any]:  # fmt: skip
    """Frame times of a path of a lit scene drawn directly and through a fresh impostor cache,
    interleaved frame by frame, per backend; the first frame apart."""
    out: dict[str, Any] = {"frames": len(cams)}
    for name in backends:
        draw = _draws(renderer, size)[name]
        draw(lit, cams[0])  # warm-up (programs, atlas textures)
        cache = cu.ImpostorCache()
        direct, timed, errors = [], [], []
        first = 0.0
        for k, cam in enumerate(cams):
            t0 = time.perf_counter()
            ref = draw(lit, cam)
            t1 = time.perf_counter()
            img = draw(lit, cam, cache)
            t2 = time.perf_counter()
            if k:
                direct.append(t1 - t0)
                timed.append(t2 - t1)
                errors.append(float(np.abs(img - ref).mean()))
            else:
                first = t2 - t1
        out[name] = _record(direct, timed, first, cache, errors)
    return out


def sweep(renderer: Any, field_of: Callable[[int], Any], sun: Any, size: tuple[int, int],
          quick: bool, software: bool) -> dict[str, Any]:  # fmt: skip
    """Render time against clouds with and without impostors (see the module docstring)."""
    if quick:
        counts, frames = [10, 40], 3
    elif software:
        counts, frames = [10, 100, 1000], 10
    else:
        counts, frames = [10, 100, 1000, 10_000], 20
    points = []
    for n in counts:
        lit = cu.prepare_light(
            cu.Scene([field_of(n)], sun=sun, settings=cu.RenderSettings(lighting="paper"))
        )
        for path, cams in sweep_paths(n, frames).items():
            row = {"clouds": n, "path": path, **run_path(renderer, lit, cams, size)}
            points.append(row)
            common.log(
                f"impostors N={n:5d} {path:<11}"
                + "".join(
                    f" {b.upper()} direct {1e3 * row[b]['direct_s']['median']:7.1f} ms, "
                    f"impostors {1e3 * row[b]['impostors_s']['median']:7.1f} ms "
                    f"(×{row[b]['ratio']:.2f}, {row[b]['updates_per_frame']:.1f} "
                    "updates/frame);"
                    for b in ("gl", "cpu")
                )  # fmt: skip
            )
    ratios = {b: [p[b]["ratio"] for p in points] for b in ("gl", "cpu")}
    return {
        "status": "measured",
        "size": list(size),
        "frames_per_path": frames,
        "speed_units_per_frame": SPEED,
        "points": points,
        "ratio_range": {b: [min(r), max(r)] for b, r in ratios.items()},
    }


def path_with_impostors(renderer: Any, scene: Any, cams: list[Any], size: tuple[int, int],
                        backends: tuple[str, ...] = ("gl", "cpu")) -> dict[str, Any]:  # fmt: skip
    """Per-frame wall times along ``cams`` of each backend, directly (``"gl"``, ``"cpu"``) and
    through a fresh impostor cache (``"gl_impostors"``, ...; warmed up at the first camera like
    the direct draws), light prepared once; ``"caches"``: the caches."""
    lit = cu.prepare_light(scene)
    out: dict[str, Any] = {"caches": {}}
    for name in backends:
        draw = _draws(renderer, size)[name]
        for suffix, cache in (("", None), ("_impostors", cu.ImpostorCache())):
            draw(lit, cams[0], cache)  # warm-up; impostors: every cloud generated
            times = []
            for cam in cams:
                t0 = time.perf_counter()
                draw(lit, cam, cache)
                times.append(time.perf_counter() - t0)
            out[name + suffix] = times
            if cache is not None:
                out["caches"][name] = cache
    return out


def cache_summary(cache: Any) -> dict[str, Any]:
    later = cache.history[1:]  # after the warm-up frame
    return {
        "updates_per_frame": float(np.mean([sum(x["updates"].values()) for x in later])),
        "impostors_per_frame": float(np.mean([x["impostors"] for x in later])),
        "updates_by_reason": dict(sum((Counter(x["updates"]) for x in later), Counter())),
    }


def table1_day(renderer: Any, size: tuple[int, int], frames: int, impostors: bool,
               steady: bool, dt: float | None = None,
               start: float = 0.0) -> tuple[list[float], list[int], Any, float]:  # fmt: skip
    """[TM]'s Table 1 day (two layers, CV 0 → 1 over the schedule) filmed in ``frames`` frames:
    the weather stepped, lit and drawn every frame (GL); ``steady``: the sun and sky held (the
    base scene's) instead of dimming/darkening with CV. ``dt`` (default: the whole day in
    ``frames`` frames) seconds per frame from ``start`` seconds (stepped to, untimed). Returns
    the frame times, the clouds per frame, the cache (None without impostors) and the day's
    duration."""
    from cumuli.anim.weather_presets import table1

    weather = table1(seed=0)
    base = cu.Scene(sun=cu.Sun(direction=(0.3, 0.6, 0.6), colour=(1.0, 0.97, 0.92),
                               intensity=1.4),
                    settings=cu.RenderSettings(lighting="paper"))  # fmt: skip
    cam = cu.Camera(position=(0.0, 2.0, -420.0), target=(0.0, 198.0, 0.0), fov=65.0)
    end = weather.schedule.keys[-1][0]
    dt = end / (frames - 1) if dt is None else dt
    for _ in range(int(round(start / 10.0))):
        weather.step(10.0)
    cache = cu.ImpostorCache() if impostors else None

    def scene() -> Any:
        s = weather.scene_at(base)
        return s.replace(sun=base.sun, sky=base.sky) if steady else s

    renderer.render(scene(), cam, *size, impostors=cache)  # warm-up
    times, clouds = [], []
    for k in range(frames):
        t0 = time.perf_counter()
        if k:
            weather.step(dt)
        renderer.render(scene(), cam, *size, impostors=cache)  # step, light, draw
        times.append(time.perf_counter() - t0)
        clouds.append(sum(map(sum, weather.counts())))
    return times, clouds, cache, end


def table1_at_paper_rate(renderer: Any, size: tuple[int, int], frames: int,
                         fps_stats: Callable[..., dict[str, Any]]) -> dict[str, Any]:  # fmt: skip
    """The Table 1 day at [TM]'s own frame spacing (dt = 1/27 s: the wind moves the clouds ~0.2
    units per frame) for ``frames`` frames from the start, the middle and the end of the day:
    directly and through impostors, relit with CV (the sun dims a little every frame) or under a
    steady light. Rates are compared with 27 Hz by their mean."""
    out: dict[str, Any] = {"dt": 1.0 / 27.0, "frames": frames, "starts_s": [0.0, 300.0, 590.0]}
    keys = ("fps_median", "fps_min", "fps_max", "fps_mean", "ratio_to_paper", "reaches_paper_rate")
    for label, impostors, steady in (("gl", False, False), ("gl_impostors", True, False),
                                     ("gl_steady_light", False, True),
                                     ("gl_steady_light_impostors", True, True)):  # fmt: skip
        times: list[float] = []
        caches = []
        for start in out["starts_s"]:
            t, _, cache, _ = table1_day(renderer, size, frames, impostors, steady, 1.0 / 27.0,
                                        start)  # fmt: skip
            times += t
            caches.append(cache)
        stats = fps_stats(times, 27.0, by_mean=True)
        out[label] = {k: stats[k] for k in keys}
        if impostors:
            out[label].update(cache_summary(_merged(caches)))
        common.log(f"Table 1 at 1/27 s per frame, {label}: mean {stats['fps_mean']:.1f} fps, "
                   f"reaches 27 Hz: {stats['reaches_paper_rate']}")  # fmt: skip
    return out


class _merged:
    """The histories of several caches as one (for `cache_summary`: each one's warm-up frame
    dropped)."""

    def __init__(self, caches: list[Any]) -> None:
        first = caches[0].history[:1]
        self.history = first + [h for c in caches for h in c.history[1:]]


def steps_path(start: Any, target: Any, frames: int, step: float) -> list[Any]:
    """``frames`` cameras from ``start`` towards ``target``, ``step`` units apart, looking at
    it (a slower navigation along the direct rows' line)."""
    a, b = np.asarray(start, np.float64), np.asarray(target, np.float64)
    u = (b - a) / np.linalg.norm(b - a)
    return [cu.Camera(tuple(a + k * step * u), tuple(b), fov=60.0) for k in range(frames)]


def plot_sweep(render: dict[str, Any], axes: Any) -> None:
    """Frame time against clouds, directly and through impostors (orbit, fly-through), and the
    impostor updates per frame."""
    points = render["impostors"]["points"]
    for col, path in enumerate(("orbit", "fly_through")):
        rows = [p for p in points if p["path"] == path]
        n = [p["clouds"] for p in rows]
        for backend, colour in (("gl", "C0"), ("cpu", "C1")):
            axes[col].plot(n, [1e3 * p[backend]["direct_s"]["median"] for p in rows], "-o",
                           color=colour, label=f"{backend.upper()} direct")  # fmt: skip
            axes[col].plot(n, [1e3 * p[backend]["impostors_s"]["median"] for p in rows], "--s",
                           color=colour, label=f"{backend.upper()} impostors")  # fmt: skip
        axes[col].set(xlabel="clouds (field instances)", ylabel="median frame (ms)",
                      xscale="log", yscale="log",
                      title=f"{path.replace('_', '-')} at {SPEED:g} unit/frame")  # fmt: skip
        axes[2].plot(n, [p["gl"]["updates_per_frame"] for p in rows], "-o" if col == 0 else "--s",
                     label=f"{path}: updates")  # fmt: skip
        axes[2].plot(n, [p["gl"]["impostors_per_frame"] for p in rows], ":" ,
                     label=f"{path}: impostors shown")  # fmt: skip
    axes[2].set(xlabel="clouds", ylabel="per frame", xscale="log", yscale="log",
                title="impostor updates (GL)")  # fmt: skip
