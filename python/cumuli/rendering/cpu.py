"""The CPU reference marcher: ``render(..., backend="cpu")`` (RENDER_CONTRACT, DESIGN §4).

The same render pass as the GLSL marcher (Algorithms 1 and 3 of Jiménez de Parga & Gómez Palomo
2018), run by the C++ core on all cores without the GIL. It is slow next to the GPU but exact and
independent of any driver: the parity tests hold the GLSL marcher to it, and it renders where no
OpenGL context can be made.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cumuli import _core
from cumuli import _validate as check

#: Largest image edge the CPU marcher accepts.
MAX_EDGE = 1 << 14
#: Largest image in pixels (the core's own limit, checked here before any light grid is made).
MAX_PIXELS = 1 << 26


def cloud_core_dict(cloud: Any, kappa: float | None = None) -> dict[str, Any]:
    """The dict ``_core.render_cpu`` takes for one cloud (its light grid must be present).

    ``kappa`` overrides the cloud's own κ when given (``RenderSettings.kappa``).
    """
    if cloud.light is None or cloud.light_box is None:
        raise ValueError("cloud has no light grid (cloud.light / light_box); see prepare_light")
    centres, radii, rotations, model, cloud_kappa, phi = cloud.core_args()
    lo, hi = cloud.light_box
    return {
        "centres": centres,
        "radii": radii,
        "rotations": rotations,
        "model": model,
        "kappa": float(cloud_kappa if kappa is None else kappa),
        "phi": float(phi),
        "light": np.ascontiguousarray(cloud.light, dtype=np.float32),
        "light_lo": check.vec3(lo, "cloud.light_box[0]"),
        "light_hi": check.vec3(hi, "cloud.light_box[1]"),
    }


def render_cpu_args(
    scene: Any, camera: Any, width: int, height: int, threads: int = 0
) -> dict[str, Any]:
    """Keyword arguments of ``_core.render_cpu`` for a scene whose clouds carry light grids.

    Exposed for tests and tools that want to change one knob of the core call (for example
    ``density_constant``, a constant density in place of fBm for analytic checks).
    """
    width = check.integer(width, "width", 1, MAX_EDGE)
    height = check.integer(height, "height", 1, MAX_EDGE)
    threads = check.threads(threads)
    s = scene.settings
    sky = scene.sky
    sun = scene.sun
    return {
        "camera_position": camera.position,
        "camera_target": camera.target,
        "camera_up": camera.up,
        "fov": float(camera.fov),
        "width": width,
        "height": height,
        "clouds": [cloud_core_dict(c, s.kappa) for c in scene.clouds],
        "sun_direction": sun.direction,
        "sun_radiance": sun.radiance,
        "sky_zenith": sky.zenith,
        "sky_horizon": sky.horizon,
        "sky_ground": sky.ground,
        "sky_exponent": float(sky.exponent),
        "sun_disc_radius": float(sky.sun_disc_radius),
        "sun_disc_intensity": float(sky.sun_disc_intensity),
        "absorption": float(s.absorption),
        "lod_a": float(s.lod_a),
        "lod_delta": float(s.lod_delta),
        "ref_step": float(s.step_ref),
        "step_min": float(s.step_min),
        "step_max": float(s.step_max),
        "fixed_step": float(s.fixed_step),
        "hg_g": float(s.hg_g),
        "max_steps": int(s.max_steps),
        "max_candidates": int(s.max_candidates),
        "march": s.march,
        # The GL sorts all give the (t_in, primitive) order the core's insertion sort gives.
        "sort_candidates": s.candidate_sort != "none",
        "octaves": int(s.octaves),
        "gain": float(s.gain),
        "lacunarity": float(s.lacunarity),
        "frequency": float(s.frequency),
        "noise": scene.noise._core,
        "threads": threads,
    }


def render_cpu(scene: Any, camera: Any, width: int, height: int, threads: int = 0) -> np.ndarray:
    """Render ``scene`` seen by ``camera`` on the CPU; returns ``(height, width, 4)`` float32.

    Linear RGBA, row 0 at the top; alpha is ``1 − T``. Clouds without a (current) light grid get
    one first, by the same helper the GL renderer uses (:func:`cumuli.prepare_light`).
    ``threads=0`` uses every core; the image does not depend on the thread count.
    """
    from cumuli.camera import Camera
    from cumuli.rendering.renderer import prepare_light
    from cumuli.scene import Scene

    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a cumuli.Scene, got {type(scene).__name__}")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
    # Arguments are checked before the (possibly long) light pass runs.
    width = check.integer(width, "width", 1, MAX_EDGE)
    height = check.integer(height, "height", 1, MAX_EDGE)
    if width * height > MAX_PIXELS:
        raise ValueError(
            f"image of {width}x{height} pixels is larger than the limit of {MAX_PIXELS} pixels"
        )
    threads = check.threads(threads)
    prepare_light(scene)
    return _core.render_cpu(**render_cpu_args(scene, camera, width, height, threads))
