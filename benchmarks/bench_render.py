"""Render-pass speed: the GLSL marcher (GL timer queries) against the C++ reference marcher.

The default cumulus (``cumuli.demo.cumulus_scene``: 35-sphere Gaussian cumulus, 20³ light grid)
is rendered at 320×240 and 640×480 on llvmpipe, at 640×480, 800×600 and 1920×1080 on a GPU
(``--quick``: 160×120 and 320×240, fewer repeats) with
``march="paper"`` and ``march="union"`` on both backends, and the physical lighting mode (the
default settings: the Mie phase, the resolve pass and the air included) against
the paper mode (``lighting_ratio``: the issue's limit of 1.5× the paper mode's frame time, as
``{limit, comparison, reached, met}``; GL and CPU, interleaved repeats of the same run; light
steps excluded), and the GL frame time without and with empty-space skipping and the early
exit (``work_per_pixel``, ``_work.py``). GL time per frame is the sum of the
tiles' GL_TIME_ELAPSED queries (the draw only: no upload, no read-back); wall time of the whole
``render`` call is recorded too. Ratios (union/paper, GL/CPU) come from the same run; on
llvmpipe, whose timer queries miss the deferred rasteriser threads, they use wall time.
Writes ``render.json`` and ``render.png`` under ``benchmarks/out/`` (or ``--out``).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402
import _work  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.demo import cumulus_scene  # noqa: E402

#: The issue's limit on the physical mode's frame time, in paper-mode frame times.
PHYSICAL_LIMIT = 1.5


def target(limit: float, reached: float) -> dict:
    """An issue target: its limit, what this run reached and whether it is met."""
    return {"limit": limit, "comparison": "<=", "reached": reached, "met": bool(reached <= limit)}


def lighting_ratios(base: cu.Scene, camera: cu.Camera, sizes, repeats: int, timer_ok: bool) -> dict:
    """Physical against paper lighting, GL and CPU, per image size (light steps done first)."""
    scenes = {
        m: base.replace(settings=base.settings.replace(lighting=m)) for m in ("paper", "physical")
    }
    lit = {m: cu.prepare_light(s) for m, s in scenes.items()}
    out: dict[str, dict] = {}
    with cu.Renderer() as renderer:
        for w, h in sizes:
            gpu: dict[str, list[float]] = {m: [] for m in lit}

            def gl(m: str, w: int = w, h: int = h, gpu: dict = gpu) -> None:
                renderer.render(lit[m], camera, w, h)
                if renderer.last_gpu_ns is not None:
                    gpu[m].append(renderer.last_gpu_ns * 1e-9)

            fns = {f"gl_{m}": (lambda m=m: gl(m)) for m in lit}
            fns.update({f"cpu_{m}": (lambda m=m, w=w, h=h: cu.render_cpu(lit[m], camera, w, h))
                        for m in lit})  # fmt: skip
            times = common.interleaved_repeats(fns, repeats)
            entry: dict = {k: {"wall_s": common.spread(v[0])} for k, v in times.items()}
            for m in lit:
                if len(gpu[m]) > 1:
                    entry[f"gl_{m}"]["gl_time_s"] = common.spread(gpu[m][1:])
            gl_stat = "gl_time_s" if timer_ok and "gl_time_s" in entry["gl_paper"] else "wall_s"

            def med(name: str, stat: str = "wall_s", entry=entry) -> float:
                return entry[name][stat]["median"]

            entry["gl_physical_over_paper"] = target(
                PHYSICAL_LIMIT, med("gl_physical", gl_stat) / med("gl_paper", gl_stat)
            )
            entry["cpu_physical_over_paper"] = target(
                PHYSICAL_LIMIT, med("cpu_physical") / med("cpu_paper")
            )
            key = f"{w}x{h}"
            out[key] = entry
            common.log(
                f"{key} physical/paper: GL {entry['gl_physical_over_paper']['reached']:.2f}, "
                f"CPU {entry['cpu_physical_over_paper']['reached']:.2f}"
            )
    return out


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    machine = common.machine_info()
    software = "llvmpipe" in str(machine["gl_renderer"]).lower()
    if args.quick:
        sizes = [(160, 120), (320, 240)]
    elif software:
        sizes = [(320, 240), (640, 480)]
    else:  # a real GPU: the sizes
        sizes = [(640, 480), (800, 600), (1920, 1080)]
    repeats = 3 if args.quick else 7
    common.log(f"GL renderer: {machine['gl_renderer']}; {machine['cores']} cores")

    base = cumulus_scene(seed=1, settings=cu.RenderSettings(lighting="paper"))
    camera = base.default_camera()
    cu.prepare_light(base)  # memoised: light grids are not part of the render pass timings
    results: dict[str, dict[str, dict]] = {}
    with cu.Renderer() as renderer:
        for w, h in sizes:
            key = f"{w}x{h}"
            results[key] = {}
            for march in ("paper", "union"):
                scene = base.replace(settings=base.settings.replace(march=march))
                renderer.render(scene, camera, w, h)  # warm-up: shader compile, uploads
                gpu, wall = [], []
                for _ in range(repeats):
                    t0 = time.perf_counter()
                    renderer.render(scene, camera, w, h)
                    wall.append(time.perf_counter() - t0)
                    if renderer.last_gpu_ns is not None:
                        gpu.append(renderer.last_gpu_ns * 1e-9)
                entry = {"wall_s": common.spread(wall)}
                if gpu:
                    entry["gl_time_s"] = common.spread(gpu)
                results[key][f"gl_{march}"] = entry
                gl_ms = entry.get("gl_time_s", {}).get("median", float("nan")) * 1e3
                common.log(
                    f"{key} gl {march}: GL {gl_ms:.1f} ms, "
                    f"wall {entry['wall_s']['median'] * 1e3:.1f} ms"
                )
                cpu_wall, _ = common.time_repeats(
                    lambda scene=scene, w=w, h=h: cu.render_cpu(scene, camera, w, h),
                    max(1, repeats // 2),
                )
                results[key][f"cpu_{march}"] = {"wall_s": common.spread(cpu_wall)}
                common.log(
                    f"{key} cpu {march}: wall {common.spread(cpu_wall)['median'] * 1e3:.1f} ms"
                )

    # Mesa's llvmpipe runs the rasteriser on its own threads and its GL_TIME_ELAPSED does not
    # cover that work (it reported 12 ms for a 3 s draw): there the ratios use wall time.
    timer_ok = "llvmpipe" not in str(machine["gl_renderer"]).lower()
    ratios: dict[str, dict[str, float]] = {}
    for key, methods in results.items():

        def med(name: str, stat: str, methods=methods) -> float:
            return methods[name][stat]["median"]

        gl_stat = "gl_time_s" if timer_ok and "gl_time_s" in methods["gl_paper"] else "wall_s"
        ratios[key] = {
            "gl_union_over_paper": med("gl_union", gl_stat) / med("gl_paper", gl_stat),
            "cpu_union_over_paper": med("cpu_union", "wall_s") / med("cpu_paper", "wall_s"),
            "gl_wall_over_cpu_wall_paper": med("gl_paper", "wall_s") / med("cpu_paper", "wall_s"),
            "gl_wall_over_cpu_wall_union": med("gl_union", "wall_s") / med("cpu_union", "wall_s"),
        }
    lighting = lighting_ratios(base, camera, sizes, repeats, timer_ok)
    # Issue 14 item 4: GL frame time without skipping and early exit, with skipping (the
    # default), with both (_work.VARIANTS); wall time of Renderer.render.
    with cu.Renderer() as renderer:
        work = {
            f"{w}x{h}": _work.gl_frame_times(renderer, base, camera, w, h, repeats)
            for w, h in sizes
        }
    for key, entry in work.items():
        common.log(
            f"{key} gl work: off/skip {entry['gl_off_over_skip']:.2f}, "
            f"off/fast {entry['gl_off_over_fast']:.2f}"
        )
    data = {
        "benchmark": "render",
        "quick": args.quick,
        "scene": "cumuli.demo.cumulus_scene(seed=1)",
        "settings": base.settings.to_dict(),
        "sizes": list(results),
        "repeats": repeats,
        "machine": machine,
        "methods": results,
        "ratios": ratios,
        "lighting": lighting,
        "work_per_pixel": work,
        "gl_ratio_time": "gl_time_s (GL timer queries)" if timer_ok else "wall_s",
        "gl_timer_note": None
        if timer_ok
        else "llvmpipe's GL_TIME_ELAPSED misses its deferred rasteriser threads; use wall_s",
    }
    path = common.write_json(args.out / "render.json", data)
    common.log(f"wrote {path}")

    plt = common.pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    names = ["gl_paper", "gl_union", "cpu_paper", "cpu_union"]
    width = 0.2
    for k, name in enumerate(names):
        stat = "gl_time_s" if name.startswith("gl") and timer_ok else "wall_s"
        values = [
            results[s][name].get(stat, results[s][name]["wall_s"])["median"] * 1e3 for s in results
        ]
        label = f"{name} ({'GL timer' if stat == 'gl_time_s' else 'wall'})"
        ax.bar([i + (k - 1.5) * width for i in range(len(results))], values, width, label=label)
    ax.set_xticks(range(len(results)), list(results))
    ax.set_ylabel("ms per frame (median)")
    ax.set_title(f"render pass, default cumulus\n{machine['gl_renderer']}", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out / "render.png", dpi=100)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
