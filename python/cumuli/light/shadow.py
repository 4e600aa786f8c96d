"""Sunlight on the ground: the transmittance of the sun's light through every cloud of a scene
(RENDER_CONTRACT, "Ground").

:func:`shadow_map` marches, from every texel centre of a rectangle of the ground plane, a ray
towards the sun through each drawable's extinction — a 2018 cloud's density field (the union
march's attribution) times ``extinction_scale`` in the physical mode or ``absorption/step_ref``
(the paper mode's camera-ray extinction) in the paper mode; a volume's ``sigma_t·density`` — in
segments of at most ``settings.light_step`` sampled at their midpoints, and returns
``exp(−τ)``, times the transmittance of every particle cloud — Harris 2002's own shadow map, the
final buffer of its light pass for the sun (:func:`cumuli.light.particles.ground_shadow` with
the scene's ``sprite_settings``) — and of every billboard cloud or field — the CAF its own
billboards would get at the ground point (:func:`cumuli.light.caf.ground_caf` with the scene's
``billboard_shading``; beyond Torchelsen & Musse 2005). The light step makes one for a scene
with a ground (:func:`scene_shadow`), over the ground the clouds' boxes can shade.
In the physical mode the map is softened (:mod:`cumuli.light.soft_shadow`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli import registry
from cumuli._util import validate as check
from cumuli.light.footprint import box_corners, footprint
from cumuli.light.physical import optical_depth
from cumuli.light.soft_shadow import (
    caster_distance,
    chord_midpoints,
    diffuse_transmittance,
    penumbra,
)

#: Largest shadow-map edge.
MAX_RESOLUTION = 4096


@dataclass(frozen=True, eq=False)
class ShadowMap:
    """Sunlight transmittance on the ground: ``values`` ``(nz, nx)`` float32 over
    ``extent = (x0, z0, x1, z1)`` of the plane ``y = height``, texel ``(j, i)`` at
    ``x = x0 + (i + ½)(x1 − x0)/nx``, ``z = z0 + (j + ½)(z1 − z0)/nz`` (bilinear in between,
    clamped at the edges, 1 outside)."""

    values: np.ndarray
    extent: tuple[float, float, float, float]
    height: float


def media_transmittance(
    scene: Any, points: np.ndarray, direction: Any, threads: int = 0
) -> np.ndarray | None:
    """``exp(−τ)`` ``(N,)`` float32 from ``(N, 3)`` float32 points towards ``direction`` through
    the scene's media (its 2018 clouds and volumes, :func:`cumuli.light.medium.medium_args`),
    in segments of at most ``settings.light_step`` sampled at their midpoints; None when the
    scene has none."""
    tau = optical_depth(scene.clouds, scene, points, direction, scene.settings.light_step, threads)
    if tau is None:
        return None
    return np.exp(-tau.astype(np.float64)).astype(np.float32)


def shades(d: Any) -> bool:
    """Whether a drawable casts shadows: a medium, or a caster by its own light model."""
    kind = registry.of(d)
    return kind.medium is not None or kind.caster is not None


def caster_sphere(d: Any) -> tuple[np.ndarray, float]:
    """A sphere outside which a caster's shadow is exactly 1 and which holds the points where
    its own light is received (:attr:`cumuli.registry.Caster.sphere`)."""
    caster = registry.of(d).caster
    if caster is None:
        raise TypeError(f"a {type(d).__name__} is not a caster")
    return caster.sphere(d)


@dataclass(frozen=True, eq=False)
class Casters:
    """The particle clouds and billboard clouds or fields of a scene with their bounding
    spheres, to find the ones the sun's rays from a region can cross."""

    index: np.ndarray  # (M,) indices into scene.clouds
    centre: np.ndarray  # (M, 3)
    radius: np.ndarray  # (M,)

    @classmethod
    def of(cls, scene: Any) -> Casters:
        index, centres, radii = [], [], []
        for k, d in enumerate(scene.clouds):
            if registry.of(d).caster is None:
                continue
            c, r = caster_sphere(d)
            index.append(k)
            centres.append(np.asarray(c, np.float64))
            radii.append(float(r))
        return cls(
            np.asarray(index, np.int64),
            np.asarray(centres, np.float64).reshape(-1, 3),
            np.asarray(radii, np.float64),
        )

    def towards_sun(
        self, sun: Any, centre: Any, radius: float, skip: int | None = None
    ) -> list[int]:
        """Indices (into ``scene.clouds``) of the casters, but ``skip``, that the rays from the
        sphere ``(centre, radius)`` towards ``sun`` can cross: ahead of it along the sun and
        within the two radii of its axis."""
        s = np.asarray(sun, np.float64)
        s = s / np.linalg.norm(s)
        d = self.centre - np.asarray(centre, np.float64)[None, :]
        along = d @ s
        lateral = np.linalg.norm(d - along[:, None] * s[None, :], axis=1)
        reach = self.radius + float(radius)
        near = (along > -reach) & (lateral < reach) & (self.index != (-1 if skip is None else skip))
        return [int(k) for k in self.index[near]]


def points_sphere(points: np.ndarray) -> tuple[np.ndarray, float]:
    """A sphere holding ``(N, 3)`` points: their box's centre and the farthest point from it."""
    p = np.asarray(points, np.float64)
    if p.shape[0] == 0:
        return np.zeros(3), 0.0
    centre = (p.min(axis=0) + p.max(axis=0)) / 2
    return centre, float(np.sqrt(((p - centre) ** 2).sum(axis=1).max()))


def caster_transmittance(
    scene: Any,
    points: np.ndarray,
    threads: int = 0,
    lights: Sequence[Any] | None = None,
    among: Sequence[int] | None = None,
    sun: Any = None,
) -> np.ndarray | None:
    """The product over the scene's particle clouds and billboards (those of ``among``, indices
    into ``scene.clouds``, when given) of the transmittance of ``sun``'s light (a `Sun`; the
    scene's sun by default) through each at ``points``, by their own light models, each clipped
    to [0, 1]; None when there are none. A particle cloud's light in ``lights`` (aligned with
    ``scene.clouds``) lends its buffers."""
    out = None
    sun = scene.sun if sun is None else sun
    chosen = range(len(scene.clouds)) if among is None else among
    for k in chosen:
        d = scene.clouds[k]
        caster = registry.of(d).caster
        if caster is None:
            continue
        light = lights[k] if lights is not None else None
        t = caster.transmittance(d, sun, points, scene, light, threads)
        # A transmittance: a particle light with allow_gain can exceed 1 (or overflow).
        t = np.clip(np.nan_to_num(np.asarray(t, np.float32), nan=1.0, posinf=1.0), 0.0, 1.0)
        out = t if out is None else out * t
    return out


def default_extent(scene: Any, height: float) -> tuple[float, float, float, float] | None:
    """The rectangle of the plane ``y = height`` the boxes of the drawables can shade (their
    corners moved along the light onto the plane, padded by 2 %); None when nothing can."""
    s = np.asarray(scene.sun.direction, np.float64)
    media = [d for d in scene.clouds if shades(d)]
    if s[1] <= 1e-3 or not media:
        return None
    feet = np.array([footprint(box_corners(*d.layer_box()), s, (height, height)) for d in media])
    x0, z0 = feet[:, 0].min(), feet[:, 2].min()
    x1, z1 = feet[:, 1].max(), feet[:, 3].max()
    pad = 0.02 * max(x1 - x0, z1 - z0, 1e-3)
    return (x0 - pad, z0 - pad, x1 + pad, z1 + pad)


def _extent(extent: Any) -> tuple[float, float, float, float]:
    if isinstance(extent, (str, bytes)) or not isinstance(extent, Sequence) or len(extent) != 2:
        raise TypeError(f"extent must be ((x0, z0), (x1, z1)), got {extent!r}")
    corners = []
    for k, corner in enumerate(extent):
        if isinstance(corner, (str, bytes)) or not isinstance(corner, Sequence) or len(corner) != 2:
            raise TypeError(f"extent[{k}] must be a pair (x, z), got {corner!r}")
        corners.append(tuple(check.real(v, f"extent[{k}]", -1e6, 1e6) for v in corner))
    (x0, z0), (x1, z1) = corners
    if not (x1 > x0 and z1 > z0):
        raise ValueError(f"extent must have x1 > x0 and z1 > z0, got {extent!r}")
    return (x0, z0, x1, z1)


def _resolution(resolution: Any) -> tuple[int, int]:
    if isinstance(resolution, (int, np.integer)) and not isinstance(resolution, bool):
        n = check.integer(resolution, "resolution", 1, MAX_RESOLUTION)
        return n, n
    if (
        isinstance(resolution, Sequence)
        and not isinstance(resolution, str)
        and len(resolution) == 2
    ):
        nx, nz = (check.integer(v, "resolution", 1, MAX_RESOLUTION) for v in resolution)
        return nx, nz
    raise TypeError(f"resolution must be an int or (nx, nz), got {resolution!r}")


def compute_shadow(
    scene: Any, extent: tuple[float, float, float, float], shape: tuple[int, int], height: float,
    threads: int = 0, lights: Sequence[Any] | None = None,
) -> ShadowMap:  # fmt: skip
    """The :class:`ShadowMap` of ``scene`` over a validated extent and ``(nx, nz)``; ``lights``
    (aligned with ``scene.clouds``, optional) the light step's, whose particle buffers it reuses."""
    x0, z0, x1, z1 = extent
    nx, nz = shape
    xs = x0 + (np.arange(nx) + 0.5) * (x1 - x0) / nx
    zs = z0 + (np.arange(nz) + 0.5) * (z1 - z0) / nz
    zz, xx = np.meshgrid(zs, xs, indexing="ij")
    pts = np.stack([xx, np.full_like(xx, height), zz], -1).reshape(-1, 3).astype(np.float32)
    values = np.ones((nz, nx), np.float32)
    if scene.sun.direction[1] > 0 and soft_shadows(scene.settings):
        values = _soft_values(scene, pts, threads, lights, (x0, z0, x1, z1), (nz, nx))
    elif scene.sun.direction[1] > 0:
        t = media_transmittance(scene, pts, scene.sun.direction, threads)
        if t is not None:
            values = t.reshape(nz, nx)
        own = caster_transmittance(scene, pts, threads, lights)
        if own is not None:
            values = values * own.astype(np.float32).reshape(nz, nx)
    values.setflags(write=False)
    return ShadowMap(values, (float(x0), float(z0), float(x1), float(z1)), float(height))


def soft_shadows(settings: Any) -> bool:
    """Whether ``settings`` soften the ground's shadows (the physical mode with a penumbra or
    the diffuse transmission; :mod:`cumuli.light.soft_shadow`)."""
    return bool(
        settings.physical and (settings.diffuse_shadows or settings.sun_angular_diameter > 0)
    )


def _soft_values(
    scene: Any, pts: np.ndarray, threads: int, lights: Sequence[Any] | None,
    extent: tuple[float, float, float, float], shape: tuple[int, int],
) -> np.ndarray:  # fmt: skip
    """The physical mode's shadow map: every medium's optical depth on its own (for the caster
    distance), the diffuse transmission, the casters' own transmittance, then the penumbra."""
    s = scene.settings
    sun = scene.sun.direction
    taus: list[np.ndarray] = []
    mids: list[np.ndarray] = []
    tau_media = np.zeros(len(pts))
    for d in scene.clouds:
        if registry.of(d).medium is None:
            continue
        tau = optical_depth([d], scene, pts, sun, s.light_step, threads)
        if tau is None:
            continue
        tau = tau.astype(np.float64)
        taus.append(tau)
        mids.append(chord_midpoints(d.layer_box(), pts, sun))
        tau_media += tau
    if s.diffuse_shadows:
        values = diffuse_transmittance(tau_media, s.mean_cosine, s.albedo)
    else:
        values = np.exp(-tau_media)
    for k, d in enumerate(scene.clouds):
        if registry.of(d).caster is None:
            continue
        own = caster_transmittance(scene, pts, threads, lights, among=[k])
        if own is None:
            continue
        own = own.astype(np.float64)
        values = values * own
        taus.append(-np.log(np.maximum(own, 1e-6)))
        mids.append(chord_midpoints(d.layer_box(), pts, sun))
    values = values.reshape(shape)
    if not taus or s.sun_angular_diameter <= 0:
        return values.astype(np.float32)
    distance = caster_distance(taus, mids).reshape(shape)
    weight = np.sum(taus, axis=0).reshape(shape)
    return penumbra(values, distance, weight, sun, s.sun_angular_diameter, extent)


def shadow_map(
    scene: Any,
    extent: Any = None,
    resolution: int | Sequence[int] = 256,
    threads: int = 0,
) -> np.ndarray:
    """Sunlight transmittance on the ground of ``scene``: ``(nz, nx)`` float32 in [0, 1].

    ``extent`` ``((x0, z0), (x1, z1))`` is the rectangle of the plane ``y = scene.ground.height``
    (``y = 0`` without a ground) to cover, by default the part the clouds can shade; texel
    ``(j, i)`` is the ray from ``(x0 + (i + ½)(x1 − x0)/nx, height, z0 + (j + ½)(z1 − z0)/nz)``
    towards the sun. ``resolution`` is one int or ``(nx, nz)``. A sun at or below the horizon
    gives ones (no direct sunlight is shaded). For terrain and solar-irradiance work: multiply
    by ``E_sun·max(sun.y, 0)`` for the sun's irradiance. In the physical mode the map is soft
    (:mod:`cumuli.light.soft_shadow`): the sun disc's penumbra (``sun_angular_diameter``) and
    the light the clouds scatter through (``diffuse_shadows``); turn both off for the direct
    transmittance of a point sun.
    """
    from cumuli.scene import Scene

    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a cumuli.Scene, got {type(scene).__name__}")
    height = 0.0 if scene.ground is None else scene.ground.height
    shape = _resolution(resolution)
    if extent is None:
        ext = default_extent(scene, height)
        if ext is None:
            return np.ones(shape[::-1], np.float32)
    else:
        ext = _extent(extent)
    threads = check.threads(threads)
    if math.prod(shape) > MAX_RESOLUTION**2:
        raise ValueError("resolution is too large")
    return np.array(compute_shadow(scene, ext, shape, height, threads).values)
