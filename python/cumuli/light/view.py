"""The camera's view of the physical light's diffuse sun light: the part of the light that
depends on where the camera is, applied per frame to the light step's camera-independent result.

The diffusion solves for the fluence ``φ``, the diffuse light summed over every direction; the
radiance it stands for is not the same every way. Its first moment is the diffuse flux
``E = −D∇φ + 3D·Q1`` (``Q1`` the first moment of the collided sun light, times the diffusion's
``SUN_FORWARD``), and to first order (the P1 approximation, Ishimaru 1978, §9.2) the radiance
is ``(φ + 3E·ω)/4π``: at a cloud's shadowed side, where the light leaves, more of it runs
outwards than inwards, and where the light has not yet diffused (thin strands, a lit surface)
it streams on away from the sun. Scattered once more by a phase function of mean cosine ``ḡ``
towards the camera, direction ``d``, it gives ``φ·(1 + ḡ·r·d)/4π`` with ``r = 3E/φ`` the light
step's ``PhysicalLight.anisotropy``. P1 overstates the anisotropy where the light streams (a thin
strand, the first mean free path), so the term is clamped to ``±``
:data:`~cumuli.light.physical.FLUX_LIMIT`, a constant fitted with the others against Mitsuba 3
(docs/fidelity.md).

:func:`seen_from` returns a scene's lights with each drawable's sun channel so weighted for the
camera's position, cell by cell (the direction from a cell's centre to the camera); the light
step itself, memoised, is not redone when the camera moves. The same values reach the GL
marcher and the CPU twin (both draw the lattice they are given).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from cumuli.light import physical

#: The last views made: (light id, camera position) → (light, its view). A still camera, as a
#: viewer or a frame redrawn, gets the same objects back (the GL atlases are then not repacked).
_views: dict[tuple, tuple[Any, Any]] = {}
_KEEP = 64


def seen_from(lit: Any, camera: Any) -> Any:
    """``lit`` (a :class:`cumuli.LitScene`) with each physical light replaced by
    :func:`view_light` from ``camera``'s position (``lit`` itself when it holds none)."""
    settings = lit.scene.settings
    lights = tuple(
        view_light(light, camera.position, settings.mean_cosine)
        if isinstance(light, physical.PhysicalLight)
        else light
        for light in lit.lights
    )
    if all(a is b for a, b in zip(lights, lit.lights, strict=True)):
        return lit
    return dataclasses.replace(lit, lights=lights)


def view_light(light: Any, position: Any, mean_cosine: float) -> Any:
    """``light`` (a :class:`~cumuli.light.physical.PhysicalLight`) as the camera at
    ``position`` sees it: its grid's sun channel times ``1 + ḡ·clamp(r·d, ±FLUX_LIMIT)``, ``d``
    the unit vector from each cell's centre to the camera. A light without an anisotropy (no
    multiple scattering, or already a view) is returned as it is."""
    if light.anisotropy is None or light.seen_from is not None:
        return light
    key = (id(light), tuple(float(v) for v in position), float(mean_cosine),
           float(physical.FLUX_LIMIT))  # fmt: skip
    known = _views.get(key)
    if known is not None and known[0] is light:
        return known[1]
    weight = view_weights(light.anisotropy, light.box, position, mean_cosine, physical.FLUX_LIMIT)
    grid = np.array(light.grid, np.float32)
    grid[..., 0] *= weight
    grid.setflags(write=False)
    view = dataclasses.replace(light, grid=grid, anisotropy=None, seen_from=light)
    if len(_views) >= _KEEP:
        _views.clear()
    _views[key] = (light, view)
    return view


def view_weights(
    anisotropy: np.ndarray, box: Any, position: Any, mean_cosine: float, limit: float
) -> np.ndarray:
    """``(D, H, W)`` float32: ``1 + ḡ·clamp(r·d, ±limit)`` of an anisotropy lattice
    ``(D, H, W, 3)`` over ``box`` seen from ``position`` (its numpy definition)."""
    r = np.asarray(anisotropy, np.float32)
    d, h, w = r.shape[:3]
    lo, hi = (np.asarray(v, np.float64) for v in box)
    cell = (hi - lo) / (w, h, d)
    axes = [lo[a] + (np.arange(n) + 0.5) * cell[a] for a, n in enumerate((w, h, d))]
    to_cam = [np.float32(position[a] - axes[a]) for a in range(3)]  # x (W), y (H), z (D)
    dx, dy, dz = to_cam[0][None, None, :], to_cam[1][None, :, None], to_cam[2][:, None, None]
    norm = np.sqrt(dx * dx + dy * dy + dz * dz)
    norm = np.maximum(norm, np.float32(1e-12))
    dot = (r[..., 0] * dx + r[..., 1] * dy + r[..., 2] * dz) / norm
    return (1.0 + np.float32(mean_cosine) * np.clip(dot, -limit, limit)).astype(np.float32)
