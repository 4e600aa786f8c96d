"""The CPU reference marcher (``backend="cpu"``): thread scaling and cloud shapes, against GL.

``bench_render.py`` times the default cumulus on both backends at two image sizes; this script
looks at the C++ marcher itself: one thread against every core (the image is the same bit for
bit), ``march="paper"`` against ``"union"``, on the four cloud kinds of the paper (Gaussian
cumulus, metaball cumulus, L-system castellanus, mesh → ellipsoids), with the GLSL marcher of the
same run (GL timer queries of the draws, and wall time) for the CPU/GL ratios, and the physical
lighting mode against the paper mode on every scene (``lighting``: the issue's limit of 1.5×, as
``{limit, comparison, reached, met}``, CPU on every core and GL wall time, interleaved repeats),
and the work per pixel (``work_per_pixel``, ``_work.py``: fBm evaluations per
pixel without and with empty-space skipping and the early exit, their ratio against the target
of 2, the image difference against 2e-3, CPU and GL frame-time ratios), and ``hd``: the default
scene (``cumuli.demo.default_scene``, physical lighting, resolve on) at 1920×1080 on 2 threads,
its light step done once outside the timing (a ``LitScene``), against the limit of 0.6 s, with
each noise version (2, the hash, which the scene uses by default; 1, the table), the frame's fBm
evaluations and what they cost in the bulk SIMD kernel on 2 threads (``fbm_bulk_s``,
``fbm_bulk_share`` of the frame: the physical marcher queues its samples and evaluates them 16 at
a time in that kernel, so this is about the noise's part of the frame; the paper marcher still
evaluates one at a time).
Light grids are computed once, outside the timings. Writes ``render_cpu.json`` and
``render_cpu.png`` under ``benchmarks/out/`` (or ``--out``); ``--quick`` renders 96×72 with fewer
repeats.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402
import _work  # noqa: E402

import cumuli as cu  # noqa: E402


def scenes() -> dict[str, cu.Scene]:
    """The paper's four cloud kinds, each alone in the default scene settings, with the paper's
    noise (version 1, seed 0)."""
    rabbit = cu.mesh_cloud(cu.meshes.bunny_like(1), scale=1.2)
    paper = cu.RenderSettings(lighting="paper")
    scenes = {
        "gaussian_cumulus": cu.Scene(clouds=[cu.gaussian_cumulus(seed=1)], settings=paper),
        "metaball_cumulus": cu.Scene(clouds=[cu.metaball_cumulus(seed=2)], settings=paper),
        "lsystem_cloud": cu.Scene(clouds=[cu.lsystem_cloud(iterations=7, seed=2)], settings=paper),
        # The paper marches its mesh clouds with a fixed step smaller than the ellipsoids.
        "mesh_cloud": cu.Scene(
            clouds=[rabbit],
            settings=cu.RenderSettings(fixed_step=0.03, absorption=3.0, lighting="paper"),
        ),
    }
    noise = cu.Noise(seed=0, version=1)
    return {name: scene.replace(noise=noise) for name, scene in scenes.items()}


#: The 1080p frame: size, threads and the issue's limit (seconds, physical default, resolve on).
HD_SIZE = (1920, 1080)
HD_THREADS = 2
HD_LIMIT_S = 0.6


def hd_frame(quick: bool, repeats: int) -> dict[str, Any]:
    """The default scene at 1920×1080 (480×270 with ``quick``) on `HD_THREADS` threads, per noise
    version, interleaved; ``target`` judges the scene as it is (the default version, 2)."""
    import numpy as np

    from cumuli.demo import default_scene

    width, height = (480, 270) if quick else HD_SIZE
    lit: dict[int, Any] = {}
    for version in (1, 2):
        scene = default_scene()
        scene = scene.replace(noise=cu.Noise(seed=scene.noise.seed, version=version))
        lit[version] = cu.prepare_light(scene)  # the light step, once, outside the timing
    camera = default_scene().camera
    assert camera is not None
    timed = common.interleaved_repeats(
        {v: (lambda v=v: cu.render_cpu(lit[v], camera, width, height, HD_THREADS)) for v in lit},
        repeats,
        settle=0,
    )
    out: dict[str, Any] = {"image": [width, height], "threads": HD_THREADS, "versions": {}}
    for version, (wall, _) in timed.items():
        _, stats = cu.render_cpu(lit[version], camera, width, height, HD_THREADS,
                                 return_stats=True)  # fmt: skip
        # As many evaluations of this noise in the bulk kernel, on as many threads.
        pts = np.random.default_rng(0).uniform(-60, 60, (1 << 20, 3)).astype(np.float32)
        noise = lit[version].scene.noise
        fbm_wall, _ = common.time_repeats(lambda n=noise, p=pts: n.fbm(p, threads=HD_THREADS), 3)
        per_eval = common.spread(fbm_wall)["median"] / len(pts)
        frame = common.spread(wall)
        out["versions"][str(version)] = {
            "wall_s": frame,
            "fbm_evaluations": int(stats.fbm_evaluations),
            "fbm_bulk_s": stats.fbm_evaluations * per_eval,
            "fbm_bulk_share": stats.fbm_evaluations * per_eval / frame["median"],
        }
    own = default_scene().noise.version  # the scene as it is
    out["stages"] = hd_stages(lit[own], camera, width, height, repeats)
    other = 3 - own
    reached = out["versions"][str(own)]["wall_s"]["median"] if not quick else None
    beside = out["versions"][str(other)]["wall_s"]["median"] if not quick else None
    out["target"] = common.target(
        HD_LIMIT_S, reached, "<=",
        measure=f"wall seconds of cumuli.render_cpu, {HD_SIZE[0]}x{HD_SIZE[1]}, "
        f"{HD_THREADS} threads, default scene (noise version {own}), light step excluded",
        **{f"reached_noise_version_{other}": beside},
    )  # fmt: skip
    return out


def hd_stages(lit: Any, camera: Any, width: int, height: int, repeats: int) -> dict[str, Any]:
    """What bounds the 1080p frame: the compositor's single pass split into its stages, each
    timed alone on `HD_THREADS` threads (median of ``repeats``) — the march of every pixel, the
    edge pass (the outline found, its two rays per pixel marched, their means), the finish
    (resolve and air) — with the march's samples and its wall time per sample and thread."""
    import numpy as np

    from cumuli.rendering.compositor import finish, seen_from
    from cumuli.rendering.edges import SUB, edge_mask, supersample_edges
    from cumuli.rendering.marcher_cpu import draw_clouds_cpu
    from cumuli.rendering.painters import CPUPainter

    seen = seen_from(lit, camera)
    scene = seen.scene
    indices = list(range(len(scene.clouds)))
    painter = CPUPainter(HD_THREADS)

    def march() -> np.ndarray:
        return painter.layer(seen, "cloud", indices, camera, width, height, True)

    def sub(pixels: np.ndarray) -> np.ndarray:
        return painter.marched(seen, indices, camera, SUB * width, SUB * height, pixels)

    image = march()
    edged, edges = supersample_edges(image, sub)
    stages = {
        "march": march,
        "edge_pass": lambda: supersample_edges(image, sub),
        "finish": lambda: finish(edged, scene, camera, seen.shadow, HD_THREADS, edges),
    }
    timed = common.interleaved_repeats(stages, repeats, settle=0)
    # The first march's own samples (render_cpu's statistics add the edge pass's).
    _, raw = draw_clouds_cpu(seen, indices, camera, width, height, True, HD_THREADS,
                             return_stats=True)  # fmt: skip
    samples = int(raw["steps"])
    out: dict[str, Any] = {name: common.spread(wall) for name, (wall, _) in timed.items()}
    out["march_samples"] = samples
    out["march_ns_per_sample_thread"] = out["march"]["median"] * HD_THREADS / max(samples, 1) * 1e9
    out["edge_pixels"] = int(edge_mask(image[..., 3]).sum())
    out["covered_pixels"] = int((image[..., 3] > 1e-3).sum())
    out["note"] = (
        "the march's time is its samples times their shading (light lattices, octaves, fBm); "
        "the edge pass marches 2 rays in each outline pixel, the outline's rays being a "
        "cloud's longest"
    )
    return out


#: The issue's limit on the physical mode's frame time, in paper-mode frame times.
PHYSICAL_LIMIT = 1.5


def physical_ratios(renderer_ok: bool, width: int, height: int, repeats: int) -> dict[str, Any]:
    """Physical over paper lighting per scene: CPU (every core) and GL wall time."""
    out: dict[str, Any] = {}
    renderer = cu.Renderer() if renderer_ok else None
    try:
        for name, base in scenes().items():
            camera = base.default_camera()
            lit = {
                m: cu.prepare_light(base.replace(settings=base.settings.replace(lighting=m)))
                for m in ("paper", "physical")
            }
            fns = {
                f"cpu_{m}": (lambda m=m, lit=lit, c=camera: cu.render_cpu(lit[m], c, width, height))
                for m in lit
            }
            if renderer is not None:
                fns.update({
                    f"gl_{m}": (lambda m=m, lit=lit, c=camera, r=renderer:
                                r.render(lit[m], c, width, height))
                    for m in lit
                })  # fmt: skip
            times = common.interleaved_repeats(fns, repeats)
            entry: dict[str, Any] = {k: {"wall_s": common.spread(v[0])} for k, v in times.items()}
            for backend in ("cpu", "gl"):
                if f"{backend}_paper" not in entry:
                    continue
                reached = (entry[f"{backend}_physical"]["wall_s"]["median"]
                           / entry[f"{backend}_paper"]["wall_s"]["median"])  # fmt: skip
                entry[f"{backend}_physical_over_paper"] = {
                    "limit": PHYSICAL_LIMIT, "comparison": "<=", "reached": reached,
                    "met": bool(reached <= PHYSICAL_LIMIT),
                }  # fmt: skip
            out[name] = entry
            common.log(
                f"{name} physical/paper: "
                + ", ".join(f"{k} {v['reached']:.2f}" for k, v in entry.items() if "over" in k)
            )
    finally:
        if renderer is not None:
            renderer.close()
    return out


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    width, height = (96, 72) if args.quick else (320, 240)
    repeats = 3 if args.quick else 5
    machine = common.machine_info()
    cores = machine["cores"]
    threads = sorted({1, cores})
    common.log(f"GL renderer: {machine['gl_renderer']}; {cores} cores; {width}x{height}")

    renderer = cu.Renderer() if machine["gl_renderer"] else None
    results: dict[str, dict[str, Any]] = {}
    try:
        for name, base in scenes().items():
            cu.prepare_light(base)  # once (memoised); every march mode and backend reuses it
            camera = base.default_camera()
            for march in ("paper", "union"):
                scene = base.replace(settings=base.settings.replace(march=march))
                key = f"{name}/{march}"
                entry: dict[str, Any] = {"primitives": scene.clouds[0].n}
                for t in threads:
                    wall, _ = common.time_repeats(
                        lambda s=scene, c=camera, t=t: cu.render_cpu(s, c, width, height, t),
                        repeats,
                    )
                    entry[f"cpu_{t}t_wall_s"] = common.spread(wall)
                if renderer is not None:
                    gpu: list[float] = []

                    def draw(s: cu.Scene = scene, c: cu.Camera = camera, gpu=gpu) -> None:
                        renderer.render(s, c, width, height)
                        if renderer.last_gpu_ns is not None:
                            gpu.append(renderer.last_gpu_ns * 1e-9)

                    wall, _ = common.time_repeats(draw, repeats)
                    entry["gl_wall_s"] = common.spread(wall)
                    if len(gpu) > 1:
                        entry["gl_time_s"] = common.spread(gpu[1:])  # gpu[0] is the warm-up
                results[key] = entry
                common.log(
                    f"{key}: "
                    + ", ".join(
                        f"{k} {v['median'] * 1e3:.1f} ms"
                        for k, v in entry.items()
                        if isinstance(v, dict)
                    )
                )
    finally:
        if renderer is not None:
            renderer.close()

    ratios: dict[str, dict[str, float]] = {}
    for key, e in results.items():
        cpu_all = e[f"cpu_{cores}t_wall_s"]["median"]
        r = {"cpu_1t_over_all": e["cpu_1t_wall_s"]["median"] / cpu_all}
        if "gl_wall_s" in e:
            r["cpu_all_over_gl_wall"] = cpu_all / e["gl_wall_s"]["median"]
        if "gl_time_s" in e:
            r["cpu_all_over_gl_time"] = cpu_all / e["gl_time_s"]["median"]
        ratios[key] = r
    for name in {k.split("/")[0] for k in results}:
        paper, union = results[f"{name}/paper"], results[f"{name}/union"]
        ratios[f"{name}/union_over_paper_cpu"] = {
            "value": union[f"cpu_{cores}t_wall_s"]["median"]
            / paper[f"cpu_{cores}t_wall_s"]["median"]
        }
    lighting = physical_ratios(renderer_ok=bool(machine["gl_renderer"]), width=width,
                               height=height, repeats=repeats)  # fmt: skip
    work_renderer = cu.Renderer() if machine["gl_renderer"] else None
    try:
        work = _work.work_per_pixel(scenes(), width, height, repeats, work_renderer)
    finally:
        if work_renderer is not None:
            work_renderer.close()
    hd = hd_frame(args.quick, 3)
    data = {
        "benchmark": "render_cpu",
        "quick": args.quick,
        "image": [width, height],
        "repeats": repeats,
        "threads": threads,
        "machine": machine,
        "timing": (
            "cpu_*: wall clock of cumuli.render_cpu; gl_wall_s: Renderer.render wall clock "
            "(upload, draws, read-back); gl_time_s: GL timer queries of the draws"
        ),
        "methods": results,
        "ratios": ratios,
        "lighting": lighting,
        "work_per_pixel": work,
        "work_variants": _work.VARIANTS,
        "hd": hd,
        "targets": {"hd_1080p_2_threads_s": hd["target"]},
    }
    path = common.write_json(args.out / "render_cpu.json", data)
    for version, v in hd["versions"].items():
        common.log(
            f"hd {hd['image']} noise version {version}: {v['wall_s']['median']:.3f} s, "
            f"{v['fbm_evaluations']} fBm evaluations ({v['fbm_bulk_s']:.3f} s in the bulk kernel)"
        )
    st = hd["stages"]
    common.log(
        "hd stages: march {:.3f} s ({} samples, {:.0f} ns per sample and thread), edge pass "
        "{:.3f} s ({} outline pixels), finish {:.3f} s".format(
            st["march"]["median"], st["march_samples"], st["march_ns_per_sample_thread"],
            st["edge_pass"]["median"], st["edge_pixels"], st["finish"]["median"],
        )
    )  # fmt: skip
    common.log(common.show_target("hd_1080p_2_threads_s", hd["target"], " s"))
    common.log(f"wrote {path}")

    plt = common.pyplot()
    fig, ax = plt.subplots(figsize=(9, 4))
    series = [f"cpu_{t}t_wall_s" for t in threads] + ["gl_time_s", "gl_wall_s"]
    series = [s for s in series if all(s in e for e in results.values())]
    keys = list(results)
    bar = 0.8 / max(1, len(series))
    for k, s in enumerate(series):
        ax.bar(
            [i + (k - (len(series) - 1) / 2) * bar for i in range(len(keys))],
            [results[key][s]["median"] * 1e3 for key in keys],
            bar,
            label=s,
        )
    ax.set_xticks(range(len(keys)), [k.replace("/", "\n") for k in keys], fontsize=7)
    ax.set_yscale("log")
    ax.set_ylabel(f"ms per {width}x{height} frame (median)")
    ax.set_title(f"CPU reference marcher vs GL\n{machine['gl_renderer']}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out / "render_cpu.png", dpi=100)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
