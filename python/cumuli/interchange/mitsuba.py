"""``to_mitsuba``: a cumuli scene as a Mitsuba 3 scene dictionary (``pip install mitsuba``).

Each drawable with a density becomes a ``cube`` with a ``null`` BSDF over its box whose
interior is a ``heterogeneous`` medium: ``sigma_t`` a ``gridvolume`` of the drawable's extinction
field (:func:`cumuli.interchange.volumes.volume_field`, the texel-centre lattice of
:func:`cumuli.density_volume`, mapped onto the box), its albedo and a Henyey–Greenstein phase
with its ``g``. The sun is a ``directional`` emitter (``direction`` is the way light travels,
``−Sun.direction``; ``irradiance = Sun.radiance``), the sky a lat-long ``envmap`` of
``Sky.radiance`` (:func:`sky_environment`), the camera a ``perspective`` sensor (vertical field
of view) with an ``hdrfilm``. The integrator is ``volpath``. Mitsuba has no nested media: the
drawables' boxes must not overlap.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cumuli.camera import Camera
from cumuli.interchange.volumes import volume_field
from cumuli.light.medium import ExtinctionField


def _mitsuba() -> Any:
    try:
        import mitsuba as mi
    except ImportError:
        raise OSError("to_mitsuba needs Mitsuba 3: pip install mitsuba") from None
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    return mi


def sky_environment(scene: Any, width: int = 1024) -> np.ndarray:
    """``Sky.radiance`` as Mitsuba's lat-long environment map ``(width/2, width, 3)``: texel
    ``(i, j)`` shows the direction ``(sinθ·sin φ, cosθ, −sinθ·cos φ)``, ``θ = π(i + ½)/H``,
    ``φ = 2π(j + ½)/W``."""
    height = width // 2
    theta = np.pi * (np.arange(height) + 0.5) / height
    phi = 2 * np.pi * (np.arange(width) + 0.5) / width
    st = np.sin(theta)[:, None]
    d = np.stack(
        [st * np.sin(phi)[None], np.cos(theta)[:, None] * np.ones((1, width)),
         -st * np.cos(phi)[None]], -1,
    ).reshape(-1, 3)  # fmt: skip
    return scene.sky.radiance(d, scene.sun).reshape(height, width, 3)


def _medium(mi: Any, field: ExtinctionField, albedo: float, g: float) -> dict[str, Any]:
    lo, hi = (np.asarray(b, np.float64) for b in field.box)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    grid = mi.VolumeGrid(np.ascontiguousarray(field.values[..., None], np.float32))
    return {
        "type": "cube",
        "bsdf": {"type": "null"},
        "to_world": mi.ScalarTransform4f().translate(centre.tolist()).scale(half.tolist()),
        "interior": {
            "type": "heterogeneous",
            "albedo": float(albedo),
            "phase": {"type": "hg", "g": float(g)},
            "sigma_t": {
                "type": "gridvolume",
                "grid": grid,
                "to_world": mi.ScalarTransform4f().translate(lo.tolist()).scale((hi - lo).tolist()),
            },
            "scale": 1.0,
        },
    }


def to_mitsuba(
    scene: Any,
    camera: Camera,
    width: int = 160,
    height: int = 120,
    *,
    spp: int = 64,
    seed: int = 0,
    max_depth: int = 512,
    rr_depth: int = 512,
    sun: bool = True,
    sky: bool | float = True,
    albedo: float | None = None,
    resolution: Any = None,
    fields: list[ExtinctionField] | None = None,
    env_width: int = 1024,
) -> dict[str, Any]:
    """The Mitsuba 3 scene dictionary of ``scene`` seen by ``camera`` (module docstring): load
    it with ``mitsuba.load_dict`` and render it with ``mitsuba.render``.

    ``sun=False`` leaves the sun out; ``sky`` is ``True`` (the sky's envmap), ``False`` (none)
    or a number (a constant environment of that radiance, e.g. 1 to read the transmittance with
    ``albedo=0``); ``albedo`` overrides every medium's. ``resolution`` is the lattice of the
    drawables without one of their own (see :func:`cumuli.write_volume`); ``fields`` gives the
    extinction fields already made, one per drawable with a density. ``max_depth`` and
    ``rr_depth`` are ``volpath``'s. The Mitsuba variant is set to ``scalar_rgb`` if none is.
    """
    mi = _mitsuba()
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
    shapes: dict[str, Any] = {}
    media = [c for c in scene.clouds if getattr(type(c), "kind", None) is not None]
    if fields is not None and len(fields) != len(media):
        raise ValueError(f"fields: {len(fields)} given for {len(media)} drawables")
    for i, drawable in enumerate(media):
        field, attrs = volume_field(drawable, scene.noise, scene.settings, resolution)
        if fields is not None:
            field = fields[i]
        a = attrs["albedo"] if albedo is None else albedo
        shapes[f"medium_{i}"] = _medium(mi, field, a, attrs["g"])
    emitters: dict[str, Any] = {}
    if sun:
        emitters["sun"] = {
            "type": "directional",
            "direction": (-np.asarray(scene.sun.direction, np.float64)).tolist(),
            "irradiance": {"type": "rgb", "value": list(scene.sun.radiance)},
        }
    if sky is True:
        emitters["sky"] = {"type": "envmap", "bitmap": mi.Bitmap(sky_environment(scene, env_width))}
    elif sky is not False:
        v = float(sky)
        emitters["sky"] = {"type": "constant", "radiance": {"type": "rgb", "value": [v, v, v]}}
    return {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": int(max_depth), "rr_depth": int(rr_depth)},
        **emitters,
        **shapes,
        "sensor": {
            "type": "perspective",
            "fov": float(camera.fov),
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=list(camera.position), target=list(camera.target), up=list(camera.up)
            ),
            "film": {
                "type": "hdrfilm",
                "width": int(width),
                "height": int(height),
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
            },  # fmt: skip
            "sampler": {"type": "independent", "sample_count": int(spp), "seed": int(seed)},
        },
    }
