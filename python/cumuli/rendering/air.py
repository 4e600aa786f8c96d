"""The physical mode's air between the camera and what it sees (RENDER_CONTRACT "Physical
lighting", "Air"): aerial perspective and the aureole, one pass on the finished image of
either backend (so GL and CPU agree exactly): :func:`finish` runs it with the resolve pass in
the core, threaded; :func:`add_air` is its numpy reference.

- **Aerial perspective.** Along a view ray the air's extinction ``k = air_extinction`` (per
  world unit) hides what lies at distance ``t`` by ``1 − exp(−k·t)`` and puts the sky's horizon
  radiance in its place. A pixel of coverage ``α`` is its clouds' radiance ``C`` (premultiplied)
  over its background ``B`` (:func:`background`, the renderers' own, recomputed here), seen
  through the clouds' δ-M view, ``(1 − α)^v`` with ``v`` =
  :func:`cumuli.light.physical.view_depth_scale` (the drawers' own; ``α`` is the geometric
  coverage ``1 − e^{−τ}``), the clouds covering the rest, ``α_v = 1 − (1 − α)^v``: ``C``
  fades with the clouds' distance ``D`` (:func:`cloud_depth`), ``B`` with its own ``t_bg``
  (:func:`background_distance`: the ground plane's distance where the ray meets it, else the
  path through a layer of hazy air ``air_height`` thick, ``air_height/|d.y|``, so that the sky
  thickens into the horizon's colour towards it as the ground does from below, and the two meet
  without a line).
- **Aureole.** The haze's droplets scatter the sun's light forward with the clouds' phase
  function: ``E_sun · haze · p(c)`` (``c`` the cosine between the ray and the sun, held at the
  disc's rim inside the disc), added in full where the background shows and, in front of a
  cloud, in the share of the air in front of it, ``α_v·(1 − exp(−k·D))``.

The pass runs before the resolve pass, on the raw image whose background is exactly
:func:`background`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cumuli.light.physical import phase_values, view_depth_scale


def _aureole_at(scene: Any, dirs: np.ndarray) -> np.ndarray | None:
    s = scene.settings
    if not s.physical or s.haze == 0.0:
        return None
    radiance = np.asarray(scene.sun.radiance, np.float64)
    if not radiance.any():
        return None
    c = dirs.astype(np.float64) @ np.asarray(scene.sun.direction, np.float64)
    rim = math.cos(math.radians(scene.sky.sun_disc_radius))
    p = phase_values(s, np.minimum(c, rim))
    return (p[..., None] * (s.haze * radiance)).astype(np.float32)


def aureole(scene: Any, camera: Any, width: int, height: int) -> np.ndarray | None:
    """``(H, W, 3)`` float32: the aureole's radiance per pixel of ``camera``'s image, or None
    where there is none (the paper mode, ``haze = 0``, a black sun)."""
    return _aureole_at(scene, camera.ray_directions(width, height))


def _ground_distance(scene: Any, camera: Any, dirs: np.ndarray) -> np.ndarray:
    """Distance along each ray to the ground plane, ``inf`` where it misses it (or no ground)."""
    if scene.ground is None:
        return np.full(dirs.shape[:-1], np.inf)
    dy = dirs[..., 1].astype(np.float64)
    above = float(camera.position[1]) - float(scene.ground.height)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where((dy < 0) & (above > 0), above / -dy, np.inf)


def _background_distance_at(scene: Any, camera: Any, dirs: np.ndarray) -> np.ndarray:
    ground = _ground_distance(scene, camera, dirs)
    dy = np.abs(dirs[..., 1].astype(np.float64))
    with np.errstate(divide="ignore"):
        sky = np.where(dy > 0, scene.settings.air_height / dy, np.inf)
    return np.where(np.isfinite(ground), ground, sky)


def background_distance(scene: Any, camera: Any, width: int, height: int) -> np.ndarray:
    """``(H, W)`` float64: the distance of the air before each pixel's background: the ground
    plane's where the ray meets it, else ``air_height/|d.y|`` (the hazy layer's path; ``inf``
    along the horizon)."""
    return _background_distance_at(scene, camera, camera.ray_directions(width, height))


def _cloud_depth_at(scene: Any, camera: Any, dirs: np.ndarray) -> np.ndarray:
    o = np.asarray(camera.position, np.float64)
    d = [dirs[..., k].astype(np.float64) for k in range(3)]
    depth = np.full(dirs.shape[:-1], np.nan)
    entry = np.full(dirs.shape[:-1], np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = [1.0 / v for v in d]
        for drawable in scene.clouds:
            lo, hi = (np.asarray(v, np.float64) for v in drawable.layer_box())
            t0 = np.zeros(dirs.shape[:-1])
            t1 = np.full(dirs.shape[:-1], np.inf)
            for k in range(3):
                a, b = (lo[k] - o[k]) * inv[k], (hi[k] - o[k]) * inv[k]
                # A ray parallel to a slab's faces: inside it (nan on a face) or not at all.
                a = np.where(np.isnan(a), -np.inf, a)
                b = np.where(np.isnan(b), np.inf, b)
                t0 = np.maximum(t0, np.minimum(a, b))
                t1 = np.minimum(t1, np.maximum(a, b))
            first = (t1 >= t0) & (t0 < entry)
            entry = np.where(first, t0, entry)
            depth = np.where(first, 0.5 * (t0 + t1), depth)
    return depth


def cloud_depth(scene: Any, camera: Any, width: int, height: int) -> np.ndarray:
    """``(H, W)`` float64: the clouds' distance along each pixel's ray, the midpoint of its
    chord through the first drawable box (``layer_box()``) it enters (from the camera when it
    starts inside), ``nan`` where it enters none. A geometric estimate, the same for every
    backend: within a box the cloud's own depth differs from it by at most half the chord."""
    return _cloud_depth_at(scene, camera, camera.ray_directions(width, height))


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


def _background_at(scene: Any, camera: Any, dirs: np.ndarray, shadow: Any) -> np.ndarray:
    from cumuli.ground import sky_irradiance

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


def background(scene: Any, camera: Any, width: int, height: int, shadow: Any = None) -> np.ndarray:
    """``(H, W, 3)`` float32: the background radiance of each pixel's ray (numpy twin of the
    renderers' ``background``, RENDER_CONTRACT "Ground"): the ground lit through ``shadow`` (a
    :class:`cumuli.ShadowMap` or None) where the ray meets it, else the sky with its disc."""
    return _background_at(scene, camera, camera.ray_directions(width, height), shadow)


def air_fades(
    scene: Any, camera: Any, width: int, height: int
) -> tuple[np.ndarray, np.ndarray] | None:
    """``(background, clouds)``, each ``(H, W)`` float32: the share of each pixel's background
    hidden by the air, ``1 − exp(−k·t_bg)``, and of its clouds, ``1 − exp(−k·D)`` (0 where the
    ray enters no drawable box); None in the paper mode or with ``air_extinction = 0``."""
    s = scene.settings
    if not s.physical or s.air_extinction == 0.0:
        return None
    dirs = camera.ray_directions(width, height)
    behind = _fade(s.air_extinction, _background_distance_at(scene, camera, dirs))
    depth = np.nan_to_num(_cloud_depth_at(scene, camera, dirs), nan=0.0)
    return behind, _fade(s.air_extinction, depth)


def _fade(k: float, t: np.ndarray) -> np.ndarray:
    """``1 − exp(−k·t)`` in float32, 1 where ``t`` is infinite."""
    with np.errstate(invalid="ignore", over="ignore"):
        return np.where(
            np.isfinite(t), -np.expm1(-k * np.where(np.isfinite(t), t, 0.0)), 1.0
        ).astype(np.float32)


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
    was drawn with. A new array when anything changes. The clouds' depth is found only where
    a pixel has coverage, the background only where it is partial (elsewhere it is the pixel
    itself or hidden)."""
    s = scene.settings
    fading = s.physical and s.air_extinction > 0.0
    glowing = s.physical and s.haze > 0.0 and any(scene.sun.radiance)
    if not (fading or glowing):
        return image
    h, w = image.shape[:2]
    dirs = camera.ray_directions(w, h).reshape(-1, 3)
    flat = image.reshape(-1, 4)
    rgb = np.ascontiguousarray(flat[:, :3], np.float32)
    alpha = np.clip(flat[:, 3], 0.0, 1.0)
    # The background's share: (1 − α)^{view scale}, the δ-M view's transmittance (the clouds'
    # forward peak carries what lies behind on to the camera); the clouds' share the rest.
    clear = (1.0 - alpha) ** np.float32(view_depth_scale(s))
    cover = 1.0 - clear
    front = np.zeros_like(alpha)
    if fading:
        k = s.air_extinction
        horizon = np.asarray(scene.sky.horizon, np.float32)
        behind = _fade(k, _background_distance_at(scene, camera, dirs))[:, None]
        # Where nothing covers the pixel, its colour is its background.
        bg = rgb.copy()
        covered = np.nonzero(alpha > 0)[0]
        partial = covered[alpha[covered] < 1]
        bg[partial] = _background_at(scene, camera, dirs[partial], shadow)
        depth = np.nan_to_num(_cloud_depth_at(scene, camera, dirs[covered]), nan=0.0)
        front[covered] = _fade(k, depth)
        # Everywhere: the background faded by its distance (where nothing covers the pixel,
        # exactly the pixel); where something does, its clouds faded by theirs on top.
        faded = bg + behind * (horizon - bg)
        a, c = cover[covered, None], clear[covered, None]
        f = front[covered, None]
        clouds = rgb[covered] - c * bg[covered]  # the clouds' own (premultiplied) radiance
        faded[covered] = clouds + f * (a * horizon - clouds) + c * faded[covered]
        rgb = faded
    if glowing:
        glow = _aureole_at(scene, dirs)
        glow *= (clear + cover * front)[:, None]
        rgb = rgb + glow
    out = np.concatenate([rgb, flat[:, 3:]], axis=1).astype(np.float32)
    return out.reshape(image.shape)


def finish(
    image: np.ndarray, scene: Any, camera: Any, shadow: Any = None, threads: int = 0,
    unfiltered: np.ndarray | None = None, in_place: bool = False,
) -> Any:  # fmt: skip
    """``image`` seen through the air, then resolved (``resolve(add_air(image, …), scene)``) in
    one threaded pass of the core (``_core.finish_physical``): the same formulas per pixel as
    :func:`add_air` and :func:`cumuli.rendering.resolve.tent_filter`, which stay their numpy
    reference (the tent is bit for bit the same; the air agrees to float rounding). ``image``
    itself when neither applies (the paper mode). The pixels of ``unfiltered`` (``(H, W)``
    bool, the edge pass's supersampled pixels) see the air but not the tent. ``in_place``:
    ``image`` is the caller's to spend, and a writable float32 one is finished where it lies
    (the same values, without a second image's memory)."""
    from cumuli import _core
    from cumuli.ground import ground_args
    from cumuli.rendering.params import camera_params, physical_params, sky_params, sun_params

    s = scene.settings
    fading = s.physical and s.air_extinction > 0.0
    glowing = s.physical and s.haze > 0.0 and any(scene.sun.radiance)
    resolving = s.physical and s.resolve and not scene.solids
    if not (fading or glowing or resolving):
        return image
    boxes = np.array([c.layer_box() for c in scene.clouds], np.float32).reshape(-1, 2, 3)
    air = (
        float(s.air_extinction) if fading else 0.0,
        float(s.air_height),
        float(s.haze) if glowing else 0.0,
    )
    source = np.ascontiguousarray(image, np.float32)
    out = source if in_place and source.flags.writeable else None
    return _core.finish_physical(
        source, camera_params(camera), sky_params(scene.sky), sun_params(scene.sun),
        ground_args(scene.ground, scene.sky, shadow), boxes, air, physical_params(s, 1),
        bool(resolving), int(threads), unfiltered, out,
    )  # fmt: skip
