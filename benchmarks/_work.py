"""Work per pixel of the 2018 marcher, shared by ``bench_render_cpu.py`` and
``bench_render.py``.

Three settings per scene: ``off`` (the march without empty-space skipping, early
exit at T < 1e-6), ``skip`` (the default: empty-space skipping, the same image bit for bit) and
``fast`` (skipping and the early exit at ``T < FAST_MIN_TRANSMITTANCE``). The CPU marcher
counts the fBm evaluations (``render_cpu(..., return_stats=True)``); the issue's targets are
reported as ``{limit, comparison, reached, met}``: fBm evaluations per pixel off / fast ≥ 2 and
mean |fast − off| ≤ 2e-3.
"""

from __future__ import annotations

from typing import Any

import _common as common
import numpy as np

import cumuli as cu

#: The early exit of the ``fast`` setting.
FAST_MIN_TRANSMITTANCE = 0.2
VARIANTS = {
    "off": {"empty_space_skipping": False, "min_transmittance": 1e-6},
    "skip": {"empty_space_skipping": True, "min_transmittance": 1e-6},
    "fast": {"empty_space_skipping": True, "min_transmittance": FAST_MIN_TRANSMITTANCE},
}
FBM_LIMIT = 2.0
DIFF_LIMIT = 2e-3


def variants(scene: cu.Scene) -> dict[str, cu.Scene]:
    """The scene under each setting of :data:`VARIANTS`."""
    return {k: scene.replace(settings=scene.settings.replace(**v)) for k, v in VARIANTS.items()}


def gl_frame_times(
    renderer: Any, scene: cu.Scene, camera: cu.Camera, width: int, height: int, repeats: int
) -> dict[str, Any]:
    """GL wall time per frame of each variant (interleaved), and off / variant ratios."""
    lit = {k: cu.prepare_light(s) for k, s in variants(scene).items()}
    fns = {k: (lambda s=s: renderer.render(s, camera, width, height)) for k, s in lit.items()}
    times = common.interleaved_repeats(fns, repeats)
    out: dict[str, Any] = {f"gl_{k}_wall_s": common.spread(v[0]) for k, v in times.items()}
    for k in ("skip", "fast"):
        out[f"gl_off_over_{k}"] = out["gl_off_wall_s"]["median"] / out[f"gl_{k}_wall_s"]["median"]
    return out


def work_per_pixel(
    scenes: dict[str, cu.Scene], width: int, height: int, repeats: int, renderer: Any = None
) -> dict[str, Any]:
    """Per scene: fBm evaluations and steps per pixel, CPU (and GL) time of each variant, the
    image differences and the targets."""
    out: dict[str, Any] = {}
    for name, base in scenes.items():
        camera = base.default_camera()
        lit = {k: cu.prepare_light(s) for k, s in variants(base).items()}
        entry: dict[str, Any] = {}
        images = {}
        for k, s in lit.items():
            images[k], stats = cu.render_cpu(s, camera, width, height, return_stats=True)
            entry[k] = {
                "fbm_per_pixel": stats.fbm_per_pixel,
                "steps_per_pixel": stats.steps_per_pixel,
                "skipped_per_pixel": stats.skipped / stats.pixels,
            }
        fns = {
            k: (lambda s=s, c=camera: cu.render_cpu(s, c, width, height)) for k, s in lit.items()
        }
        for k, v in common.interleaved_repeats(fns, repeats).items():
            entry[k]["cpu_wall_s"] = common.spread(v[0])
        for k in ("skip", "fast"):
            entry[f"cpu_off_over_{k}"] = (
                entry["off"]["cpu_wall_s"]["median"] / entry[k]["cpu_wall_s"]["median"]
            )
            entry[f"mean_abs_diff_{k}"] = float(np.abs(images[k] - images["off"]).mean())
        if renderer is not None:
            entry.update(gl_frame_times(renderer, base, camera, width, height, repeats))
        ratio = entry["off"]["fbm_per_pixel"] / max(entry["fast"]["fbm_per_pixel"], 1e-12)
        diff = entry["mean_abs_diff_fast"]
        entry["fbm_reduction"] = {"limit": FBM_LIMIT, "comparison": ">=", "reached": ratio,
                                  "met": bool(ratio >= FBM_LIMIT)}  # fmt: skip
        entry["image_difference"] = {"limit": DIFF_LIMIT, "comparison": "<=", "reached": diff,
                                     "met": bool(diff <= DIFF_LIMIT)}  # fmt: skip
        out[name] = entry
        common.log(
            f"{name} work per pixel: fBm/px off {entry['off']['fbm_per_pixel']:.2f} "
            f"fast {entry['fast']['fbm_per_pixel']:.2f} (÷{ratio:.2f}), mean |Δ| {diff:.1e}, "
            f"CPU off/skip {entry['cpu_off_over_skip']:.2f} "  # fmt: skip
            f"off/fast {entry['cpu_off_over_fast']:.2f}"
            + (
                f", GL off/fast {entry['gl_off_over_fast']:.2f}"
                if "gl_off_over_fast" in entry
                else ""
            )
        )
    return out
