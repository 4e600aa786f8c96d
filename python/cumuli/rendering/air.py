"""The physical mode's air between the camera and the background (RENDER_CONTRACT "Physical
lighting", "Air"): the aureole, the sun's light scattered forward by the haze's droplets with
the settings' phase function, added where the background shows, and the ground's fade into the
horizon's sky with its distance (aerial perspective of the ground).

Applied by the compositor to the finished image of either backend (numpy, the same for GL and
CPU): ``rgb += (1 − α) · E_sun · haze · p(c)``, ``α`` the clouds' coverage, ``p`` the
phase of the clouds (:func:`cumuli.light.physical.phase_values`) at the cosine between the ray
and the sun, held at its value on the sun disc's rim inside the disc (the disc itself is the
sky's), ``haze`` the settings' optical depth of the haze along a view ray.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cumuli.light.physical import phase_values


def aureole(scene: Any, camera: Any, width: int, height: int) -> np.ndarray | None:
    """``(H, W, 3)`` float32: the aureole's radiance per pixel of ``camera``'s image, or None
    where there is none (the paper mode, ``haze = 0``, a black sun)."""
    s = scene.settings
    if not s.physical or s.haze == 0.0:
        return None
    radiance = np.asarray(scene.sun.radiance, np.float64)
    if not radiance.any():
        return None
    dirs = camera.ray_directions(width, height).astype(np.float64)
    c = dirs @ np.asarray(scene.sun.direction, np.float64)
    rim = math.cos(math.radians(scene.sky.sun_disc_radius))
    p = phase_values(s, np.minimum(c, rim))
    return (p[..., None] * (s.haze * radiance)).astype(np.float32)


def ground_haze(scene: Any, camera: Any, width: int, height: int) -> np.ndarray | None:
    """``(H, W)`` float32: how much of the ground each pixel sees is hidden by the air,
    ``1 − exp(−air_extinction · t)``, ``t`` the distance to the ground plane along the ray (0
    where the ray misses it); None without a ground, in the paper mode or with
    ``air_extinction = 0``."""
    s = scene.settings
    if scene.ground is None or not s.physical or s.air_extinction == 0.0:
        return None
    dirs = camera.ray_directions(width, height).astype(np.float64)
    dy = dirs[..., 1]
    above = float(camera.position[1]) - float(scene.ground.height)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where((dy < 0) & (above > 0), above / -dy, np.inf)
    hidden = np.where(np.isfinite(t), 1.0 - np.exp(-s.air_extinction * t), 0.0)
    return hidden.astype(np.float32)


def add_air(image: np.ndarray, scene: Any, camera: Any) -> np.ndarray:
    """``image`` with the air added where its background shows: the ground fades into the
    horizon's sky radiance with its distance (:func:`ground_haze`), then the aureole
    (:func:`aureole`). A new array when anything changes."""
    h, w = image.shape[:2]
    glow = aureole(scene, camera, w, h)
    fade = ground_haze(scene, camera, w, h)
    if glow is None and fade is None:
        return image
    out = image.copy()
    clear = 1.0 - np.clip(image[..., 3:4], 0.0, 1.0)
    if fade is not None:
        horizon = np.asarray(scene.sky.horizon, np.float32)
        out[..., :3] += clear * fade[..., None] * (horizon - out[..., :3])
    if glow is not None:
        out[..., :3] += clear * glow
    return out
