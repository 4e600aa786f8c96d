"""The physical mode's air and soft shadows: what they cost on the demo's frame.

Scene: ``cumuli.demo.sunset_scene()`` (three cumuli over a ground at sunset, the demo) with its
camera, in the physical mode (the default: aerial perspective, aureole, soft ground shadows) and
the paper mode (``lighting="paper"``), light steps done first (memoised, not timed).

Per image size (320×240 and 640×480; --quick: 160×120 and 320×240), interleaved repeats of
``Renderer.render`` (GL, wall time: llvmpipe's timer queries miss its rasteriser threads) and
``render_cpu`` (2 threads) of the two modes; the air pass alone (``rendering.air.add_air`` on
the raw physical frame) and its share of the physical frame. The ground's shadow map
(``light.shadow.compute_shadow`` at ``shadow_resolution`` 256, --quick 64): soft (the
physical defaults: the sun disc's penumbra and the light through the clouds) against hard
(``sun_angular_diameter=0``, ``diffuse_shadows=False``).

Target: the physical frame at most 1.5× the paper mode's, GL and CPU, at the largest size
(``met`` is null in --quick). Nothing passes or fails on time.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.demo import sunset_scene  # noqa: E402
from cumuli.light.shadow import compute_shadow, default_extent  # noqa: E402
from cumuli.rendering.air import add_air  # noqa: E402

THREADS = 2
LIMIT = 1.5


def frames(lit: dict[str, Any], camera: cu.Camera, w: int, h: int, repeats: int) -> dict:
    """Wall seconds of both modes' frames on both backends, and the air pass alone."""
    with cu.Renderer() as renderer:
        fns = {f"gl_{m}": (lambda m=m: renderer.render(lit[m], camera, w, h)) for m in lit}
        fns.update({f"cpu_{m}": (lambda m=m: cu.render_cpu(lit[m], camera, w, h, THREADS))
                    for m in lit})  # fmt: skip
        times = common.interleaved_repeats(fns, repeats)
    phys = lit["physical"]
    raw_scene = phys.scene.replace(
        settings=phys.scene.settings.replace(air_extinction=0.0, haze=0.0, resolve=False)
    )
    raw = cu.render_cpu(cu.LitScene(raw_scene, phys.lights, phys.shadow), camera, w, h, THREADS)
    air, _ = common.time_repeats(lambda: add_air(raw, phys.scene, camera, phys.shadow), repeats)
    entry: dict[str, Any] = {k: {"wall_s": common.spread(v[0])} for k, v in times.items()}
    entry["air_pass_s"] = common.spread(air)
    for b in ("gl", "cpu"):
        p, q = entry[f"{b}_physical"]["wall_s"]["median"], entry[f"{b}_paper"]["wall_s"]["median"]
        entry[f"{b}_physical_over_paper"] = p / q
        entry[f"air_share_of_{b}_physical"] = entry["air_pass_s"]["median"] / p
    return entry


def shadow_maps(scene: cu.Scene, resolution: int, repeats: int) -> dict:
    """Seconds of the soft and the hard shadow map of ``scene``."""
    height = scene.ground.height
    extent = default_extent(scene, height)
    hard = scene.replace(
        settings=scene.settings.replace(sun_angular_diameter=0.0, diffuse_shadows=False)
    )
    lights = cu.prepare_light(scene, progress=False).lights
    shape = (resolution, resolution)
    fns = {
        name: (lambda s=s: compute_shadow(s, extent, shape, height, THREADS, lights))
        for name, s in (("soft", scene), ("hard", hard))
    }
    times = common.interleaved_repeats(fns, repeats)
    out: dict[str, Any] = {k: {"wall_s": common.spread(v[0])} for k, v in times.items()}
    out["soft_over_hard"] = out["soft"]["wall_s"]["median"] / out["hard"]["wall_s"]["median"]
    out["resolution"] = resolution
    return out


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    sizes = [(160, 120), (320, 240)] if args.quick else [(320, 240), (640, 480)]
    repeats = 2 if args.quick else 5
    base = sunset_scene()
    camera = base.default_camera()
    lit = {
        m: cu.prepare_light(base.replace(settings=base.settings.replace(lighting=m)),
                            threads=THREADS, progress=False)
        for m in ("paper", "physical")
    }  # fmt: skip
    sizes_out: dict[str, Any] = {}
    for w, h in sizes:
        entry = frames(lit, camera, w, h, repeats)
        sizes_out[f"{w}x{h}"] = entry
        common.log(
            f"{w}x{h}: physical/paper GL {entry['gl_physical_over_paper']:.2f}, CPU "
            f"{entry['cpu_physical_over_paper']:.2f}; air pass "
            f"{1e3 * entry['air_pass_s']['median']:.1f} ms "
            f"({100 * entry['air_share_of_cpu_physical']:.1f} % of the CPU frame)"
        )
    shadows = shadow_maps(base, 64 if args.quick else 256, repeats)
    common.log(
        f"shadow map {shadows['resolution']}²: soft {1e3 * shadows['soft']['wall_s']['median']:.1f}"
        f" ms, hard {1e3 * shadows['hard']['wall_s']['median']:.1f} ms"
    )
    last = sizes_out[f"{sizes[-1][0]}x{sizes[-1][1]}"]
    full = not args.quick
    targets = {
        f"{b}_physical_over_paper": common.target(
            LIMIT, last[f"{b}_physical_over_paper"] if full else None, "<="
        )
        for b in ("gl", "cpu")
    }
    for name, t in targets.items():
        common.log(common.show_target(name, t))
    data = {
        "benchmark": "air",
        "machine": common.machine_info(),
        "quick": args.quick,
        "scene": "cumuli.demo.sunset_scene()",
        "threads": THREADS,
        "repeats": repeats,
        "sizes": sizes_out,
        "shadow_map": shadows,
        "targets": targets,
    }
    path = common.write_json(args.out / "air.json", data)
    plot(data, args.out / "air.png")
    common.log(f"wrote {path} and {args.out / 'air.png'}")
    return 0


def plot(data: dict[str, Any], path: Path) -> None:
    plt = common.pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    keys = list(data["sizes"])
    names = ("gl_paper", "gl_physical", "cpu_paper", "cpu_physical")
    width = 0.8 / (len(names) + 1)
    for k, name in enumerate(names):
        vals = [1e3 * data["sizes"][s][name]["wall_s"]["median"] for s in keys]
        ax.bar([i + k * width for i in range(len(keys))], vals, width, label=name)
    vals = [1e3 * data["sizes"][s]["air_pass_s"]["median"] for s in keys]
    ax.bar([i + len(names) * width for i in range(len(keys))], vals, width, label="air pass")
    ax.set_xticks([i + 2 * width for i in range(len(keys))], keys)
    ax.set(ylabel="ms (median wall)", title="demo frame: physical (air, soft shadows) vs paper")
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    m = data["machine"]
    fig.suptitle(f"{m['cpu_model']}, {m['cores']} cores, {m['gl_renderer']}", fontsize=8)
    fig.tight_layout()
    common.save_figure(fig, path)


if __name__ == "__main__":
    sys.exit(main())
