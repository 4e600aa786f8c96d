"""The physical mode's air between the camera and what it sees (RENDER_CONTRACT "Physical
lighting", "Air"): aerial perspective and the aureole, one numpy pass on the finished image of
either backend (so GL and CPU agree exactly).

- **Aerial perspective.** Along a view ray the air's extinction ``k = air_extinction`` (per
  world unit) hides what lies at distance ``t`` by ``1 − exp(−k·t)`` and puts the sky's horizon
  radiance in its place. A pixel of coverage ``α`` is its clouds' radiance ``C`` (premultiplied)
  over its background ``B`` (:func:`background`, the renderers' own, recomputed here): ``C``
  fades with the clouds' distance ``D`` (:func:`cloud_depth`), ``B`` with its own ``t_bg``
  (:func:`background_distance`: the ground plane's distance where the ray meets it, else the
  path through a layer of hazy air ``air_height`` thick, ``air_height/|d.y|``, so that the sky
  thickens into the horizon's colour towards it as the ground does from below, and the two meet
  without a line).
- **Aureole.** The haze's droplets scatter the sun's light forward with the clouds' phase
  function: ``E_sun · haze · p(c)`` (``c`` the cosine between the ray and the sun, held at the
  disc's rim inside the disc), added in full where the background shows and, in front of a
  cloud, in the share of the air in front of it, ``α·(1 − exp(−k·D))``.

The pass runs before the resolve pass, on the raw image whose background is exactly
:func:`background`.
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


def _ground_distance(scene: Any, camera: Any, dirs: np.ndarray) -> np.ndarray:
    """Distance along each ray to the ground plane, ``inf`` where it misses it (or no ground)."""
    if scene.ground is None:
        return np.full(dirs.shape[:-1], np.inf)
    dy = dirs[..., 1]
    above = float(camera.position[1]) - float(scene.ground.height)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where((dy < 0) & (above > 0), above / -dy, np.inf)


def background_distance(scene: Any, camera: Any, width: int, height: int) -> np.ndarray:
    """``(H, W)`` float64: the distance of the air before each pixel's background: the ground
    plane's where the ray meets it, else ``air_height/|d.y|`` (the hazy layer's path; ``inf``
    along the horizon)."""
    dirs = camera.ray_directions(width, height).astype(np.float64)
    ground = _ground_distance(scene, camera, dirs)
    dy = np.abs(dirs[..., 1])
    with np.errstate(divide="ignore"):
        sky = np.where(dy > 0, scene.settings.air_height / dy, np.inf)
    return np.where(np.isfinite(ground), ground, sky)


def cloud_depth(scene: Any, camera: Any, width: int, height: int) -> np.ndarray:
    """``(H, W)`` float64: the clouds' distance along each pixel's ray, the midpoint of its
    chord through the first drawable box (``layer_box()``) it enters (from the camera when it
    starts inside), ``nan`` where it enters none. A geometric estimate, the same for every
    backend: within a box the cloud's own depth differs from it by at most half the chord."""
    dirs = camera.ray_directions(width, height).astype(np.float64)
    o = np.asarray(camera.position, np.float64)
    depth = np.full(dirs.shape[:-1], np.nan)
    entry = np.full(dirs.shape[:-1], np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / dirs
        for d in scene.clouds:
            lo, hi = (np.asarray(v, np.float64) for v in d.layer_box())
            a, b = (lo - o) * inv, (hi - o) * inv
            a = np.where(np.isnan(a), -np.inf, a)  # a ray parallel to a slab, on its face
            b = np.where(np.isnan(b), np.inf, b)
            t0 = np.maximum(np.minimum(a, b).max(-1), 0.0)
            t1 = np.maximum(a, b).min(-1)
            first = (t1 >= t0) & (t0 < entry)
            entry = np.where(first, t0, entry)
            depth = np.where(first, 0.5 * (t0 + t1), depth)
    return depth


def shadow_lookup(shadow: Any, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The shadow map's transmittance at ground points ``(x, z)``: bilinear between texel
    centres, clamped at its edges, 1 outside its extent (the renderers' ``ground_shadow``)."""
    if shadow is None:
        return np.ones(np.shape(x))
    x0, z0, x1, z1 = shadow.extent
    vals = np.asarray(shadow.values, np.float64)
    nz, nx = vals.shape
    with np.errstate(invalid="ignore"):
        inside = (x >= x0) & (x <= x1) & (z >= z0) & (z <= z1)
    u = np.where(inside, (x - x0) / (x1 - x0) * nx - 0.5, 0.0)
    v = np.where(inside, (z - z0) / (z1 - z0) * nz - 0.5, 0.0)
    fu, fv = np.floor(u), np.floor(v)
    wu, wv = u - fu, v - fv
    i0, i1 = (np.clip(fu + k, 0, nx - 1).astype(np.int64) for k in (0, 1))
    j0, j1 = (np.clip(fv + k, 0, nz - 1).astype(np.int64) for k in (0, 1))
    a = vals[j0, i0] + wu * (vals[j0, i1] - vals[j0, i0])
    b = vals[j1, i0] + wu * (vals[j1, i1] - vals[j1, i0])
    return np.where(inside, a + wv * (b - a), 1.0)


def background(scene: Any, camera: Any, width: int, height: int, shadow: Any = None) -> np.ndarray:
    """``(H, W, 3)`` float32: the background radiance of each pixel's ray (numpy twin of the
    renderers' ``background``, RENDER_CONTRACT "Ground"): the ground lit through ``shadow`` (a
    :class:`cumuli.ShadowMap` or None) where the ray meets it, else the sky with its disc."""
    from cumuli.ground import sky_irradiance

    dirs = camera.ray_directions(width, height)
    out = scene.sky.colour(dirs, scene.sun).astype(np.float64)
    if scene.ground is None:
        return out.astype(np.float32)
    d64 = dirs.astype(np.float64)
    t = _ground_distance(scene, camera, d64)
    hit = np.isfinite(t)
    if hit.any():
        o = np.asarray(camera.position, np.float64)
        x = o[0] + np.where(hit, t, 0.0) * d64[..., 0]
        z = o[2] + np.where(hit, t, 0.0) * d64[..., 2]
        lit = max(float(scene.sun.direction[1]), 0.0) * shadow_lookup(shadow, x, z)
        sun = np.asarray(scene.sun.radiance, np.float64)
        ground = (
            np.asarray(scene.ground.albedo, np.float64)
            / math.pi
            * (sun * lit[..., None] + np.asarray(sky_irradiance(scene.sky), np.float64))
        )
        out = np.where(hit[..., None], ground, out)
    return out.astype(np.float32)


def air_fades(
    scene: Any, camera: Any, width: int, height: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """``(background, clouds)``, each ``(H, W)`` float32: the share of each pixel's background
    hidden by the air, ``1 − exp(−k·t_bg)``, and of its clouds, ``1 − exp(−k·D)`` (0 where the
    ray enters no drawable box); None in the paper mode or with ``air_extinction = 0``."""
    s = scene.settings
    if not s.physical or s.air_extinction == 0.0:
        return None
    k = s.air_extinction
    t_bg = background_distance(scene, camera, width, height)
    depth = np.nan_to_num(cloud_depth(scene, camera, width, height), nan=0.0)
    behind = np.where(np.isfinite(t_bg), -np.expm1(-k * np.where(np.isfinite(t_bg), t_bg, 0)), 1)
    return behind.astype(np.float32), (-np.expm1(-k * depth)).astype(np.float32)


def ground_haze(scene: Any, camera: Any, width: int, height: int) -> np.ndarray | None:
    """``(H, W)`` float32: how much of the ground each pixel sees is hidden by the air,
    ``1 − exp(−air_extinction · t)``, ``t`` the distance to the ground plane along the ray (0
    where the ray misses it); None without a ground, in the paper mode or with
    ``air_extinction = 0``."""
    s = scene.settings
    if scene.ground is None or not s.physical or s.air_extinction == 0.0:
        return None
    dirs = camera.ray_directions(width, height).astype(np.float64)
    t = _ground_distance(scene, camera, dirs)
    hidden = np.where(np.isfinite(t), 1.0 - np.exp(-s.air_extinction * t), 0.0)
    return hidden.astype(np.float32)


def add_air(image: np.ndarray, scene: Any, camera: Any, shadow: Any = None) -> np.ndarray:
    """``image`` seen through the air (module doc); ``shadow`` the ground's shadow map the image
    was drawn with. A new array when anything changes."""
    h, w = image.shape[:2]
    glow = aureole(scene, camera, w, h)
    fades = air_fades(scene, camera, w, h)
    if glow is None and fades is None:
        return image
    out = image.copy()
    alpha = np.clip(image[..., 3:4], 0.0, 1.0)
    clear = 1.0 - alpha
    front = np.zeros_like(alpha)
    if fades is not None:
        behind, front = fades[0][..., None], fades[1][..., None]
        horizon = np.asarray(scene.sky.horizon, np.float32)
        bg = background(scene, camera, w, h, shadow)
        clouds = out[..., :3] - clear * bg  # the clouds' own (premultiplied) radiance
        out[..., :3] = (
            clouds + front * (alpha * horizon - clouds) + clear * (bg + behind * (horizon - bg))
        )
    if glow is not None:
        out[..., :3] += (clear + alpha * front) * glow
    return out
