"""The physical mode's light step (the default lighting): where its time goes, per cloud count.

Scenes: the demo's cumulus scene (`cumuli.demo.cumulus_scene`: `gaussian_cumulus(seed=1)`, sun
(0.45, 0.75, 0.5), noise seed 7, default settings: ``physical_resolution`` 40, Mie phase, sky
light and multiple scattering on) with 1, 2, 4, 8 and 16 clouds (--quick: 1, 2, 4 at
``physical_resolution`` 16) in two series, on a square grid 32 units apart in the horizontal
plane: *copies* (the cumulus translated) and *seeds* (``gaussian_cumulus(seed=1..n)``), 2 threads.

Per (series, count): the whole light step as the renderer runs it (``cumuli.prepare_light`` with
the light memo cleared before each repeat, its clouds lit side by side in rounds of one per
core; median / min / max of the repeats, the two series
interleaved; the process CPU time beside it, which other load on a shared machine does not
inflate) and its breakdown into the stages of `cumuli.light.physical.physical_light`
(``STAGES``: the extinction lattice, the cloud's own optical depth on the sun's lattice, the
optical depth of the other clouds upstream of it, the sun's transmittance on the world lattice,
the SH sky visibility, the diffusion solve), summed over the clouds, the median of as many
more passes as repeats (``stages_s``, and ``stages_share`` of their sum). The growth exponent is
the least-squares slope of log(time) over log(clouds).

``previous_default``: the one-cloud light step at the default resolution and at 48, the default
before (interleaved), and their ratio.

``noise_versions``: the one-cloud scene with noise version 1 (the table) and 2 (the hash, whose
wide fBm kernels compute the lattice in registers), timed alike (interleaved), each with its
stage profile and the largest stage (``slowest_stage``): where the light step's time goes.

``sky_rays``: the sky visibility stage alone on the default cloud's extinction lattice, with the
lattice's 26 neighbour steps (the default: Lebedev's rule, τ exact by one recurrence per
direction) and with the per-voxel march over the 18-direction product quadrature, interleaved
(one thread and ``THREADS``), each with its mean |error| and signed error against a march of 512
directions at ⅛-voxel steps over the cells that hold medium, and the march's time over the
lattice's.

``moving_sun``: the one-cloud light for a new sun direction from nothing and with the light
of another sun already made (its extinction lattice and sky visibility memoised: a moving sun
relights only the sun's terms), the median of the repeats, alternated, and their ratio.

``wind``: a drifting sky — one cloud, then the sixteen seeds' field, each cloud given a wind
(``WIND``, carrying its noise) — lit from nothing at time 0, then one second later with the
first frame's light memoised: the wind relights nothing of a cloud's own, only the shade of the
clouds upstream of it (the medians, and their ratio); and the copies series' sixteen copies
drifted with their noise (`Cloud.drifted`: the same medium at each place) against one of them,
and sixteen translated copies of one `VolumeCloud` (a volume's light does not depend on where it
stands: one light step, moved to each copy) against one of them.

Beside the times, ``mitsuba``: the error the light step gives against Mitsuba 3 — the CPU
render of the reference scene of ``tests/references`` (side-lit default cumulus, 160×120)
against its multiple-scattering reference, on the cloud-covered 4×4-pixel blocks: the median
and 90th percentile of the per-block relative error, the signed ratio of the mean radiances
minus 1 and the mean |ΔT| (``tests/rendering/test_mitsuba_reference.py`` holds them to
15 %, 40 %, ±10 % and 0.01), so that a faster light step shows what it costs in error.

``linearity``: the targets' ratios, timed in one interleaved run (round-robin, so that a slow
drift of a shared machine, which moves the light step by tens of percent over the minutes the
series take, touches both sides alike): the cumulus alone and its sixteen copies; each cloud of
the sixteen seeds lit alone (the same scene with that cloud only) and the sixteen together. The
seeds differ in size (the light step of ``gaussian_cumulus(seed=k)`` alone ranges over ~±15 %
around its mean), so for that series "one cloud" is their mean alone: n clouds over one is then
how the step grows with the number of clouds, not how much larger than seed 1 the other seeds
happen to be (``last_over_first`` keeps the series' ratio to seed 1 alone beside it).

Targets (the light step of the physical default): ≤ 40 ms per default cloud (the one-cloud
scene), and linear in clouds: 16 clouds ≤ 16× one (each series: the copies over the cumulus
alone, the seeds over their mean alone; ``met`` is null in --quick). Nothing passes or fails on
time.
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
from cumuli.demo import cumulus_scene  # noqa: E402
from cumuli.light.physical import STAGES, physical_light  # noqa: E402
from cumuli.testing import compare_images  # noqa: E402

REFERENCES = Path(__file__).resolve().parents[1] / "tests" / "references"

THREADS = 2
SPACING = 32.0
#: The wind of the drifting sky (world units per second): along +x, a little across.
WIND = (6.0, 0.0, 1.5)
COUNTS = (1, 2, 4, 8, 16)
QUICK_COUNTS = (1, 2, 4)
SERIES = ("copies", "seeds")
#: The lattice of the volume whose translated copies ``wind`` lights (an endless animation's
#: database volumes are 16³–64³).
VOLUME_SIZE = 48
TARGET_ONE_MS = 40.0
TARGET_GROWTH = 16.0


def places(count: int) -> list[tuple[float, float, float]]:
    """``count`` offsets on a square grid in the horizontal plane, ``SPACING`` apart."""
    side = math.ceil(math.sqrt(count))
    out = []
    for k in range(count):
        row, col = divmod(k, side)
        out.append(((col - (side - 1) / 2) * SPACING, 0.0, (row - (side - 1) / 2) * SPACING))
    return out


def scene(series: str, count: int, resolution: int | None) -> cu.Scene:
    """``count`` clouds of ``series`` on a square grid in the horizontal plane (:func:`places`):
    copies of the default cumulus (``"copies"``; ``"drifted"``: copies carrying their noise,
    one medium at every place) or ``gaussian_cumulus(seed=1 + k)`` (``"seeds"``)."""
    settings = cu.RenderSettings() if resolution is None else cu.RenderSettings(
        physical_resolution=resolution
    )  # fmt: skip
    base = cumulus_scene(settings=settings)
    clouds = []
    for k, offset in enumerate(places(count)):
        if series == "drifted":
            clouds.append(base.clouds[0].drifted(offset))
            continue
        cloud = base.clouds[0] if series == "copies" else cu.gaussian_cumulus(seed=1 + k)
        clouds.append(cloud.translated(offset))
    return base.replace(clouds=clouds)


def linearity(resolution: int | None, repeats: int, most: int) -> dict[str, Any]:
    """The targets' ratios (see the docstring): the cumulus alone, its ``most`` copies, each of
    the ``most`` seeds alone and the seeds together, all timed in one interleaved run (medians
    of ``repeats``)."""
    copies, seeds = scene("copies", most, resolution), scene("seeds", most, resolution)
    scenes = {"cumulus alone": copies.replace(clouds=copies.clouds[:1]), "copies": copies}
    scenes["seeds"] = seeds
    for k, cloud in enumerate(seeds.clouds):
        scenes[f"seed {k + 1} alone"] = seeds.replace(clouds=[cloud])
    fns = {name: (lambda sc=sc: light_step(sc)) for name, sc in scenes.items()}
    timed = common.interleaved_repeats(fns, repeats)
    median = {name: common.spread(timed[name][0])["median"] for name in fns}
    alone = [median[f"seed {k + 1} alone"] for k in range(most)]
    out = {
        "copies": {"one_s": median["cumulus alone"], "all_s": median["copies"]},
        "seeds": {"one_s": float(np.mean(alone)), "all_s": median["seeds"], "alone_s": alone},
    }
    for s, row in out.items():
        row["ratio"] = row["all_s"] / row["one_s"]
        common.log(
            f"linearity ({s}, interleaved): {most} clouds {1e3 * row['all_s']:.1f} ms, one "
            f"{1e3 * row['one_s']:.1f} ms: {row['ratio']:.2f}x"
        )
    return out


def light_step(sc: cu.Scene) -> None:
    """The renderer's light step from nothing memoised."""
    cu.light.prepare.clear_memo()
    cu.prepare_light(sc, threads=THREADS, progress=False)


def stages(sc: cu.Scene, passes: int = 1) -> dict[str, float]:
    """Seconds per stage of the physical light of every cloud of ``sc``, summed over the
    clouds: the median of ``passes`` passes."""
    runs: list[dict[str, float]] = []
    for _ in range(passes):
        cu.light.prepare.clear_memo()  # each stage from nothing (the medium terms are memoised)
        timings: dict[str, float] = {}
        for cloud in sc.clouds:
            physical_light(cloud, sc, THREADS, timings)
        runs.append(timings)
    return {name: float(np.median([t.get(name, 0.0) for t in runs])) for name in STAGES}


def profile(per_stage: dict[str, float]) -> dict[str, Any]:
    """A stage profile: milliseconds per stage, their shares and the slowest stage."""
    total = max(sum(per_stage.values()), 1e-12)
    return {
        "stages_ms": {k: 1e3 * v for k, v in per_stage.items()},
        "stages_share": {k: v / total for k, v in per_stage.items()},
        "slowest_stage": max(per_stage, key=lambda k: per_stage[k]),
    }


def previous_default(repeats: int) -> dict[str, Any]:
    """The one-cloud light step at the default ``physical_resolution`` (40) and at 48, the
    default before it (the gains' cell, ``GAIN_RESOLUTION``), interleaved: what the lower
    default saves (its picture is as close to Mitsuba, ``docs/fidelity.md``)."""
    sc = scene("copies", 1, None)
    old = sc.replace(settings=sc.settings.replace(physical_resolution=48))
    timed = common.interleaved_repeats(
        {"default": lambda: light_step(sc), "48": lambda: light_step(old)}, repeats
    )
    out = {name: common.spread(wall) for name, (wall, _cpu) in timed.items()}
    out["default_resolution"] = sc.settings.physical_resolution
    out["default_over_48"] = out["default"]["median"] / out["48"]["median"]
    common.log(
        f"light step at resolution {sc.settings.physical_resolution}: "
        f"{1e3 * out['default']['median']:.1f} ms, at 48: {1e3 * out['48']['median']:.1f} ms "
        f"({out['default_over_48']:.2f}x)"
    )
    return out


def noise_versions(resolution: int | None, repeats: int) -> dict[str, Any]:
    """The one-cloud scene's light step with noise version 1 and 2 (see the docstring)."""
    scenes = {
        f"v{v}": scene("copies", 1, resolution).replace(noise=cu.Noise(seed=7, version=v))
        for v in (1, 2)
    }
    fns = {name: (lambda sc=sc: light_step(sc)) for name, sc in scenes.items()}
    timed = common.interleaved_repeats(fns, repeats, warmup=1)
    out: dict[str, Any] = {}
    for name, sc in scenes.items():
        wall = common.spread(timed[name][0])
        out[name] = {
            "version": int(name[1:]),
            "light_step_s": wall,
            "light_step_cpu_s": common.spread(timed[name][1]),
            **profile(stages(sc, repeats)),
        }
        common.log(
            f"noise {name}: {1e3 * wall['median']:8.1f} ms  ("
            + ", ".join(f"{k} {v:.1f}" for k, v in out[name]["stages_ms"].items())
            + " ms)"
        )
    return out


def sky_rays(resolution: int | None, repeats: int) -> dict[str, Any]:
    """The sky visibility with lattice and march rays (see the docstring)."""
    from cumuli import _core
    from cumuli.light import physical as phys
    from cumuli.sky import sky_args

    sc = scene("copies", 1, resolution)
    s = sc.settings
    field = phys.extinction_grid(
        sc.clouds[0], sc.noise, s, s.physical_resolution, phys.SUPERSAMPLE, THREADS
    )
    ext = np.ascontiguousarray(field.values)
    lo, hi = field.box
    coeffs = _core.sky_sh(sky_args(sc.sky), phys.SKY_ORDER, phys.SKY_SAMPLES)

    def sky(method: str, threads: int, n_theta: int = phys.SKY_SAMPLES, step: float = 1.0):
        return _core.sky_irradiance(
            ext, lo, hi, coeffs, phys.SKY_ORDER, n_theta, step, threads, method=method
        )

    fns = {
        f"{m}_{t}": (lambda m=m, t=t: sky(m, t)) for m in ("lattice", "march") for t in (1, THREADS)
    }
    timed = common.interleaved_repeats(fns, max(repeats, 5), warmup=1)
    reference = sky("march", THREADS, 16, 0.125)
    inside = ext > 0.0
    scale = float(reference[inside].mean())
    out: dict[str, Any] = {"lattice": list(ext.shape), "medium_cells": int(inside.sum())}
    for m in ("lattice", "march"):
        diff = (sky(m, THREADS) - reference)[inside]
        out[m] = {
            "one_thread_ms": 1e3 * common.spread(timed[f"{m}_1"][0])["median"],
            "threads_ms": 1e3 * common.spread(timed[f"{m}_{THREADS}"][0])["median"],
            "mean_abs_error": float(np.abs(diff).mean()) / scale,
            "mean_signed_error": float(diff.mean()) / scale,
        }
        common.log(
            f"sky {m:7s}: {out[m]['one_thread_ms']:6.1f} ms one thread, "
            f"{out[m]['threads_ms']:6.1f} ms {THREADS}; error against 512 directions "
            f"{out[m]['mean_abs_error']:.4f} (signed {out[m]['mean_signed_error']:+.4f})"
        )
    out["march_over_lattice_one_thread"] = out["march"]["one_thread_ms"] / max(
        out["lattice"]["one_thread_ms"], 1e-9
    )
    return out


def moving_sun(resolution: int | None, repeats: int) -> dict[str, Any]:
    """The light for a new sun from nothing and after another sun's (see the docstring)."""
    import time

    sc = scene("copies", 1, resolution)
    before = sc.replace(sun=cu.Sun(direction=(0.45, 0.75, 0.5)))
    after = sc.replace(sun=cu.Sun(direction=(-0.3, 0.8, 0.2)))
    cloud = sc.clouds[0]
    cold, warm = [], []
    for _ in range(max(repeats, 5)):
        cu.light.prepare.clear_memo()
        t = time.perf_counter()
        physical_light(cloud, after, THREADS)
        cold.append(time.perf_counter() - t)
        cu.light.prepare.clear_memo()
        physical_light(cloud, before, THREADS)
        t = time.perf_counter()
        physical_light(cloud, after, THREADS)
        warm.append(time.perf_counter() - t)
    out = {
        "from_nothing_ms": 1e3 * float(np.median(cold)),
        "after_another_sun_ms": 1e3 * float(np.median(warm)),
    }
    out["ratio"] = out["from_nothing_ms"] / max(out["after_another_sun_ms"], 1e-9)
    common.log(
        f"moving sun: {out['from_nothing_ms']:.1f} ms from nothing, "
        f"{out['after_another_sun_ms']:.1f} ms after another sun ({out['ratio']:.2f}x)"
    )
    return out


def wind(resolution: int | None, repeats: int, most: int) -> dict[str, Any]:
    """A drifting sky's next frame against its first (see the docstring): for one cloud and for
    the field of ``most`` seeds, every cloud given a wind, the light step from nothing at time 0
    and the step at the next frame with the first frame's light memoised (medians, alternated);
    and ``most`` drifted copies of one cloud against one of them."""
    import time

    out: dict[str, Any] = {}
    for count in (1, most):
        sc = scene("seeds", count, resolution)
        windy = [cu.Cloud(c.centres, c.radii, c.rotations, wind=WIND) for c in sc.clouds]
        first, second = sc.replace(clouds=windy), sc.replace(clouds=[c.at(1.0) for c in windy])
        cold, warm = [], []
        for _ in range(max(repeats, 3)):
            cu.light.prepare.clear_memo()
            t = time.perf_counter()
            cu.prepare_light(first, threads=THREADS, progress=False)
            cold.append(time.perf_counter() - t)
            t = time.perf_counter()
            cu.prepare_light(second, threads=THREADS, progress=False)
            warm.append(time.perf_counter() - t)
        row = {
            "first_frame_ms": 1e3 * float(np.median(cold)),
            "next_frame_ms": 1e3 * float(np.median(warm)),
        }
        row["ratio"] = row["first_frame_ms"] / max(row["next_frame_ms"], 1e-9)
        out[str(count)] = row
        common.log(
            f"wind, {count} cloud(s): first frame {row['first_frame_ms']:.1f} ms, next frame "
            f"{row['next_frame_ms']:.1f} ms ({row['ratio']:.1f}x)"
        )
    # Copies of one cloud drifted with their noise (the copies series' places): one cloud's own
    # light step, then only the shade of the copies upstream of each.
    drifted = scene("drifted", most, resolution)
    one = drifted.replace(clouds=drifted.clouds[:1])
    timed = common.interleaved_repeats(
        {"one": lambda: light_step(one), "sixteen": lambda: light_step(drifted)}, max(repeats, 3)
    )
    one_ms, all_ms = (1e3 * common.spread(timed[k][0])["median"] for k in ("one", "sixteen"))
    out["drifted_copies"] = {
        "count": most, "one_ms": one_ms, "all_ms": all_ms, "ratio": all_ms / one_ms
    }  # fmt: skip
    common.log(
        f"{most} copies drifted with their noise: {all_ms:.1f} ms, {all_ms / one_ms:.2f}x one "
        f"({one_ms:.1f} ms)"
    )
    out["volume_copies"] = volume_copies(resolution, repeats, most)
    return out


def volume_copies(resolution: int | None, repeats: int, most: int) -> dict[str, Any]:
    """``most`` translated copies of one `VolumeCloud` (the default cumulus's extinction on a
    ``VOLUME_SIZE``³ lattice) on the grid of :func:`places` against one of them: a volume's light
    does not depend on where it stands, so the copies share one light step."""
    base = scene("copies", 1, resolution)
    field = cu.density_volume(base.clouds[0], base.noise, base.settings, VOLUME_SIZE)
    volume = cu.VolumeCloud(np.asarray(field.values), box=field.box, sigma_t=1.0)
    many = base.replace(clouds=[volume.translated(p) for p in places(most)])
    one = base.replace(clouds=[volume])
    timed = common.interleaved_repeats(
        {"one": lambda: light_step(one), "all": lambda: light_step(many)}, max(repeats, 3)
    )
    one_ms, all_ms = (1e3 * common.spread(timed[k][0])["median"] for k in ("one", "all"))
    common.log(
        f"{most} translated copies of a {VOLUME_SIZE}^3 volume: {all_ms:.1f} ms, "
        f"{all_ms / one_ms:.2f}x one ({one_ms:.1f} ms)"
    )
    return {"count": most, "size": VOLUME_SIZE, "one_ms": one_ms, "all_ms": all_ms,
            "ratio": all_ms / one_ms}  # fmt: skip


def mitsuba_error() -> dict[str, float]:
    """The physical mode's error against the Mitsuba 3 reference (see the module docstring)."""
    sys.path.insert(0, str(REFERENCES))
    import mitsuba_reference as ref

    ms = cu.read_image(REFERENCES / ref.FILES["ms"])[..., :3]
    t_ref = cu.read_image(REFERENCES / ref.FILES["transmittance"])[..., 0]
    cu.light.prepare.clear_memo()
    scene, camera = ref.reference_scene()
    img = cu.render(scene, camera, ref.WIDTH, ref.HEIGHT, backend="cpu")
    expected = np.concatenate([ms, 1.0 - t_ref[..., None]], axis=-1)
    m = compare_images(img, expected, block=ref.BLOCK, block_alpha=ref.COVERED)
    mask = ref.covered_blocks(t_ref)
    ratio = ref.blocks(img[..., :3])[mask].sum() / ref.blocks(ms)[mask].sum() - 1.0
    dt = np.abs(ref.blocks(1.0 - img[..., 3])[mask] - ref.blocks(t_ref)[mask]).mean()
    return {
        "blocks": int(m["blocks"]),
        "block_rel_median": float(m["block_rel_median"]),
        "block_rel_p90": float(m["block_rel_p90"]),
        "mean_ratio_minus_one": float(ratio),
        "transmittance_mean_abs": float(dt),
    }


def exponent(counts: list[int], seconds: list[float]) -> float | None:
    """Least-squares slope of log(seconds) over log(counts)."""
    if len(counts) < 2:
        return None
    return float(np.polyfit(np.log(counts), np.log(seconds), 1)[0])


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    counts = QUICK_COUNTS if args.quick else COUNTS
    resolution = 16 if args.quick else None
    repeats = 1 if args.quick else 7  # a noisy shared host: the median of seven
    results: dict[str, Any] = {s: {} for s in SERIES}
    for count in counts:
        scenes = {s: scene(s, count, resolution) for s in SERIES}
        fns = {s: (lambda sc=sc: light_step(sc)) for s, sc in scenes.items()}
        # One untimed step first at every count: the first allocations of a process (the heap
        # growing, huge pages first faulted) are not the light step's.
        timed = common.interleaved_repeats(fns, repeats, warmup=1)
        for s, sc in scenes.items():
            wall = common.spread(timed[s][0])
            cpu = common.spread(timed[s][1])
            per_stage = stages(sc, repeats)
            results[s][str(count)] = {
                "clouds": count,
                "light_step_s": wall,
                # Process CPU seconds (both threads): robust to other load on a shared machine.
                "light_step_cpu_s": cpu,
                "per_cloud_ms": 1e3 * wall["median"] / count,
                "stages_s": per_stage,
                "stages_share": {
                    k: v / max(sum(per_stage.values()), 1e-12) for k, v in per_stage.items()
                },
            }
            common.log(
                f"{s:6s} {count:2d} clouds: {1e3 * wall['median']:8.1f} ms  ("
                + ", ".join(f"{k} {1e3 * v:.1f}" for k, v in per_stage.items())
                + " ms)"
            )
    # The targets' ratios from one interleaved run: the cumulus alone for the copies, the
    # seeds' mean alone.
    linear = linearity(resolution, repeats, counts[-1])
    alone = linear["seeds"]["alone_s"]
    common.log(
        f"seeds alone: mean {1e3 * np.mean(alone):.1f} ms, seed 1 {1e3 * alone[0]:.1f} ms, "
        f"range {1e3 * min(alone):.1f}-{1e3 * max(alone):.1f} ms"
    )
    one = {s: linear[s]["one_s"] for s in SERIES}
    growth: dict[str, Any] = {}
    for s in SERIES:
        rows = [results[s][str(c)] for c in counts]
        secs = [r["light_step_s"]["median"] for r in rows]
        growth[s] = {
            "exponent": exponent(list(counts), secs),
            "stage_exponents": {
                k: exponent(list(counts), [max(r["stages_s"][k], 1e-9) for r in rows])
                for k in STAGES
            },
            "one_s": one[s],
            # The target: both sides from linearity's interleaved run.
            "last_over_one": linear[s]["ratio"],
            # The series' own last over its first (timed minutes apart) and over one alone.
            "series_last_over_one": secs[-1] / one[s],
            "last_over_first": secs[-1] / secs[0],
            # The first over the last in process CPU seconds: what other load on a shared
            # machine inflates least (it stretches the short one-cloud step more than the long).
            "last_over_first_cpu": rows[-1]["light_step_cpu_s"]["median"]
            / rows[0]["light_step_cpu_s"]["median"],
        }
    full = not args.quick
    one_ms = 1e3 * results["copies"]["1"]["light_step_s"]["median"]
    targets = {
        "per_default_cloud_ms": common.target(TARGET_ONE_MS, one_ms if full else None, "<="),
    }
    for s in SERIES:
        targets[f"sixteen_over_one_{s}"] = common.target(
            TARGET_GROWTH, growth[s]["last_over_one"] if full else None, "<="
        )
    before = previous_default(repeats) if full else None
    versions = noise_versions(resolution, repeats)
    rays = sky_rays(resolution, repeats)
    sun_moves = moving_sun(resolution, repeats)
    drift = wind(resolution, repeats, counts[-1])
    error = mitsuba_error()
    common.log(
        "against Mitsuba 3: per-block error median {block_rel_median:.4f}, p90 "
        "{block_rel_p90:.4f}, mean ratio - 1 {mean_ratio_minus_one:+.4f}, "
        "|dT| {transmittance_mean_abs:.4f}".format(**error)
    )
    data = {
        "benchmark": "physical_light",
        "machine": common.machine_info(),
        "quick": args.quick,
        "threads": THREADS,
        "physical_resolution": cu.RenderSettings().physical_resolution
        if resolution is None
        else resolution,
        "counts": list(counts),
        "repeats": repeats,
        "stages": list(STAGES),
        "series": results,
        "growth": growth,
        "seeds_alone_s": alone,
        "linearity": linear,
        "previous_default": before,
        "noise_versions": versions,
        "sky_rays": rays,
        "moving_sun": sun_moves,
        "wind": drift,
        "mitsuba": error,
        "targets": targets,
    }
    for name, t in targets.items():
        common.log(common.show_target(name, t))
    for s in SERIES:
        common.log(
            f"growth exponent ({s}): {growth[s]['exponent']:.3f}; {counts[-1]} clouds over one: "
            f"{growth[s]['last_over_one']:.2f} (over the first alone: "
            f"{growth[s]['last_over_first']:.2f} wall, {growth[s]['last_over_first_cpu']:.2f} CPU)"
        )
    path = common.write_json(args.out / "physical_light.json", data)
    plot(data, args.out / "physical_light.png")
    common.log(f"wrote {path} and {args.out / 'physical_light.png'}")
    return 0


def plot(data: dict[str, Any], path: Path) -> None:
    plt = common.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    counts = data["counts"]
    for s, style in zip(SERIES, ("-o", "--s"), strict=True):
        rows = [data["series"][s][str(c)] for c in counts]
        axes[0].plot(counts, [1e3 * r["light_step_s"]["median"] for r in rows], style, label=s)
    axes[0].plot(counts, [TARGET_ONE_MS * c for c in counts], "k:", label="40 ms × clouds")
    axes[0].set(xscale="log", yscale="log", xlabel="clouds", ylabel="light step (ms)",
                title=f"physical light step, {data['threads']} threads")  # fmt: skip
    rows = [data["series"]["seeds"][str(c)] for c in counts]
    bottom = np.zeros(len(counts))
    for k in data["stages"]:
        vals = np.array([1e3 * r["stages_s"][k] for r in rows])
        axes[1].bar([str(c) for c in counts], vals, bottom=bottom, label=k)
        bottom += vals
    axes[1].set(xlabel="clouds (seeds series)", ylabel="ms", title="time per stage")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    m = data["machine"]
    fig.suptitle(f"{m['cpu_model']}, {m['cores']} cores", fontsize=9)
    fig.tight_layout()
    common.save_figure(fig, path)


if __name__ == "__main__":
    sys.exit(main())
