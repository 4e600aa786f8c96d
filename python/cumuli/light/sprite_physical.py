"""The physical mode's light for sprites: particle clouds (Harris 2002) and billboard clouds
(Torchelsen & Musse 2005) lit like the marched media (RENDER_CONTRACT "Sprites", "One light").

The media's source term is ``J = ϖ·(E_sun·(Σ_n w_n·e^{−k_n τ} + F/4π) + S/4π)``. A sprite has no
light lattice; it takes the same terms from what its own light pass knows:

- the sun: ``T`` the sun's transmittance to the sprite — Harris's light ``i_k`` (clipped to
  [0, 1]) for a particle, ``H·CAF·D`` for a billboard corner — as ``e^{−τ}`` in the octave
  sum ``Σ_n aⁿ·p_{bⁿ}(cos θ)·T^{cⁿ}`` with the scene's phase (:func:`sun_octaves`): single
  scattering plus the octaves' multiple scattering, no diffusion term ``F``;
- the sky: ``S = SKY_GAIN·Σ_j L_j·Δω·e^{−σ̄·ℓ_j}``, the sky's radiance (:func:`light_sky`, the
  ground's below the horizon) over :data:`SKY_DIRECTIONS` directions, each seen through the
  cloud's bounding sphere with a mean extinction ``σ̄`` along the chord ``ℓ_j`` from the sprite
  to the sphere's surface (:func:`sky_fluence`).

Every function is numpy on the sprite lists both backends draw, so GL and CPU get the same
colours.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cumuli.light.physical import (
    OCTAVE_A,
    OCTAVE_B,
    OCTAVE_C,
    OCTAVES,
    SKY_GAIN,
    SUN_GAIN,
    light_sky,
    phase_values,
)

#: Directions of the sky quadrature (a Fibonacci sphere, equal solid angles).
SKY_DIRECTIONS = 64


def sky_directions(n: int = SKY_DIRECTIONS) -> np.ndarray:
    """``(n, 3)`` float64 unit vectors spread evenly over the sphere (Fibonacci lattice)."""
    k = np.arange(n, dtype=np.float64) + 0.5
    y = 1.0 - 2.0 * k / n
    r = np.sqrt(np.maximum(0.0, 1.0 - y * y))
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=1)


def sky_quadrature(scene: Any) -> tuple[np.ndarray, np.ndarray]:
    """The sky the media are lit by as ``(directions (M, 3), L·Δω (M, 3))``: its radiance
    towards each direction times the direction's solid angle ``4π/M``."""
    dirs = sky_directions()
    radiance = light_sky(scene).radiance(dirs.astype(np.float32)).astype(np.float64)
    return dirs, radiance * (4.0 * math.pi / len(dirs))


#: Cells on the longest edge of a sprite cloud's extinction grid (the sky's visibility).
GRID = 16
#: The mean of ``1 − d/D`` over ``[0, D]`` equals that of ``e^{−k d/D}`` for this ``k``: a
#: billboard cloud's box extinction ``k/D`` with ``D`` its CAF's ``max_distance``.
LINEAR_CAF_K = 1.5936


def grid_box(lo: Any, hi: Any) -> tuple[np.ndarray, np.ndarray, tuple[int, int, int]]:
    """The extinction grid over the box ``lo``–``hi`` (padded by one cell): its corners and
    shape, :data:`GRID` cells on the longest edge, cubic cells."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    h = max(float((hi - lo).max()), 1e-6) / (GRID - 2)
    shape = tuple(int(v) for v in np.maximum(np.ceil((hi - lo) / h), 1) + 2)
    lo = (lo + hi) / 2 - np.asarray(shape[::-1]) * h / 2
    return lo, lo + np.asarray(shape[::-1]) * h, shape  # type: ignore[return-value]


def cell_centres(lo: np.ndarray, hi: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """``(D·H·W, 3)`` world centres of a grid's cells (x fastest)."""
    d, h, w = shape
    z, y, x = np.meshgrid(*((np.arange(n) + 0.5) / n for n in (d, h, w)), indexing="ij")
    f = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    return lo + f * (hi - lo)


def visibility(sigma: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``(cells, M)``: the transmittance ``e^{−∫σ}`` from every cell centre of the extinction
    grid ``sigma`` ``(D, H, W)`` towards every :func:`sky_directions` direction, marched in
    steps of one cell from one cell out (a sprite's own cell does not hide its sky; nearest
    cell, sampled at the step's midpoint) until it leaves the grid."""
    shape = sigma.shape
    h = float((hi - lo)[0]) / shape[2]
    dirs = sky_directions()
    start = cell_centres(lo, hi, shape)
    n_steps = int(math.ceil(math.sqrt(sum(v * v for v in shape)))) + 1
    tau = np.zeros((len(start), len(dirs)))
    for k in range(1, n_steps):  # from the cell's face: a cell does not shade itself
        p = start[:, None, :] + ((k + 0.5) * h) * dirs[None, :, :]
        idx = np.floor((p - lo) / h).astype(np.int64)  # (x, y, z)
        inside = np.all((idx >= 0) & (idx < np.asarray(shape[::-1])), axis=2)
        if not inside.any():
            break
        i = np.where(inside[..., None], idx, 0)
        tau += np.where(inside, sigma[i[..., 2], i[..., 1], i[..., 0]], 0.0) * h
    return np.exp(-tau)


def sky_at(points: np.ndarray, grid: tuple, quadrature: tuple) -> np.ndarray:
    """``(N, 3)``: the visible sky's fluence ``Σ_j L_j·Δω·V_j`` at ``points``, ``V`` the
    :func:`visibility` of ``grid = (lo, hi, V)``, trilinear between cell centres (clamped)."""
    lo, hi, vis = grid
    d, h, w = vis.shape[:3]
    cells = vis.reshape(-1, vis.shape[-1]) @ quadrature[1]
    cells = cells.reshape(d, h, w, 3)
    f = (np.asarray(points, np.float64) - lo) / (hi - lo) * np.array([w, h, d]) - 0.5
    f = np.clip(f, 0.0, np.array([w, h, d]) - 1.0)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, np.array([w, h, d]) - 1)
    t = f - i0
    out = np.zeros((len(f), 3))
    for cz in (0, 1):
        for cy in (0, 1):
            for cx in (0, 1):
                wgt = (np.where(cx, t[:, 0], 1 - t[:, 0]) * np.where(cy, t[:, 1], 1 - t[:, 1])
                       * np.where(cz, t[:, 2], 1 - t[:, 2]))  # fmt: skip
                x = np.where(cx, i1[:, 0], i0[:, 0])
                y = np.where(cy, i1[:, 1], i0[:, 1])
                z = np.where(cz, i1[:, 2], i0[:, 2])
                out += wgt[:, None] * cells[z, y, x]
    return out


def _splat(lo: np.ndarray, hi: np.ndarray, shape: tuple, points: np.ndarray,
           amount: np.ndarray) -> np.ndarray:  # fmt: skip
    """``amount`` (extinction × volume) of each point added to its cell, divided by the cell's
    volume: a ``(D, H, W)`` extinction grid."""
    h = float((hi - lo)[0]) / shape[2]
    idx = np.clip(np.floor((points - lo) / h).astype(np.int64), 0, np.asarray(shape[::-1]) - 1)
    grid = np.zeros(shape)
    np.add.at(grid, (idx[:, 2], idx[:, 1], idx[:, 0]), amount)
    return grid / h**3


def particle_grid(cloud: Any) -> tuple:
    """``(lo, hi, V)`` of a particle cloud: every particle a ball of radius ``r_k`` and
    extinction ``τ_k/(2 r_k)`` (``τ_k`` its optical depth through the centre), summed into the
    cell of its centre; ``V`` the :func:`visibility` ``(D, H, W, M)``."""
    c = np.asarray(cloud.centres, np.float64)
    r = np.asarray(cloud.radii, np.float64)
    lo, hi, shape = grid_box((c - r[:, None]).min(0), (c + r[:, None]).max(0))
    tau = np.asarray(cloud.tau, np.float64)
    sigma = _splat(lo, hi, shape, c, tau / (2 * r) * (4.0 / 3.0) * math.pi * r**3)
    return lo, hi, visibility(sigma, lo, hi).reshape(*shape, -1)


def billboard_grid(boxes: np.ndarray, max_distance: float) -> tuple:
    """``(lo, hi, V)`` of a billboard cloud: extinction :data:`LINEAR_CAF_K`/``max_distance``
    inside its boxes ``(M, 2, 3)`` (0 with no absorption), the cells whose centre lies in a
    box."""
    b = np.asarray(boxes, np.float64)
    lo, hi, shape = grid_box(b[:, 0].min(0), b[:, 1].max(0))
    centres = cell_centres(lo, hi, shape)
    inside = np.zeros(len(centres), bool)
    for box in b:
        inside |= np.all((centres >= box[0]) & (centres <= box[1]), axis=1)
    k = 0.0 if math.isinf(max_distance) else LINEAR_CAF_K / max_distance
    sigma = np.where(inside, k, 0.0).reshape(shape)
    return lo, hi, visibility(sigma, lo, hi).reshape(*shape, -1)


def sun_octaves(settings: Any, transmittance: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
    """``Σ_n aⁿ·p_{bⁿ}(cos θ)·T^{cⁿ}`` (the media's octaves, one without multiple
    scattering) for arrays of the same shape."""
    t = np.clip(np.asarray(transmittance, np.float64), 0.0, 1.0)
    c = np.clip(np.asarray(cos_theta, np.float64), -1.0, 1.0)
    octaves = OCTAVES if settings.multiple_scattering else 1
    out = np.zeros(np.broadcast_shapes(t.shape, c.shape))
    for n in range(octaves):
        out += OCTAVE_A**n * phase_values(settings, c, OCTAVE_B**n) * t ** (OCTAVE_C**n)
    return out


def diffuse(settings: Any, transmittance: np.ndarray) -> np.ndarray:
    """The sun's diffuse fluence per unit irradiance at a sprite the sun reaches with
    ``T = e^{−τ}`` (the media's ``φ_sun``): ``T^c``, 1 at the lit surface, falling like the
    first octave (``c`` = ``OCTAVE_C``). A deep uniform half-space's diffusion would fall as
    ``e^{−κτ}``, ``κ = √(3(1 − ϖ)(1 − ϖḡ)) ≈ 0.06``, but a finite cloud loses its diffuse light
    through its sides: with that ``κ`` a particle cloud's shadow side is as bright as its lit
    side."""
    t = np.clip(np.asarray(transmittance, np.float64), 1e-30, 1.0)
    return t**OCTAVE_C


def source(
    settings: Any,
    transmittance: np.ndarray,
    cos_theta: np.ndarray,
    radiance: np.ndarray,
    sky: np.ndarray | None,
) -> np.ndarray:
    """``J = ϖ·(Σ_ℓ E_ℓ·octaves_ℓ + S/4π)`` ``(N, 3)`` float64: ``transmittance`` and
    ``cos_theta`` ``(N, L)``, ``radiance`` ``(L, 3)`` (colour·intensity of each light), ``sky``
    ``(N, 3)`` the visible sky's fluence (None or ``settings.sky_light`` off: no sky term)."""
    sun = sun_octaves(settings, transmittance, cos_theta)
    if settings.multiple_scattering:
        sun = sun + SUN_GAIN * diffuse(settings, transmittance) / (4.0 * math.pi)
    j = sun @ np.asarray(radiance, np.float64)
    if sky is not None and settings.sky_light:
        j = j + SKY_GAIN * np.asarray(sky, np.float64) / (4.0 * math.pi)
    return float(settings.albedo) * j


def particle_colours(
    scene: Any, cloud: Any, light: np.ndarray, index: np.ndarray, eye: Any, quadrature: tuple
) -> np.ndarray:
    """``(M, 3)`` float32 premultiplied colours ``J·(1 − e^{−τ_k})`` of the particles ``index``
    of ``cloud`` (their rows of the light pass's ``light``, ``(n, L)``) seen from ``eye``."""
    lights = (scene.sun, *scene.lights)
    centres = np.asarray(cloud.centres, np.float64)[index]
    view = centres - np.asarray(eye, np.float64)
    view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-30)
    dirs = np.array([s.direction for s in lights], np.float64).reshape(-1, 3)
    radiance = np.array([s.radiance for s in lights], np.float64).reshape(-1, 3)
    trans = np.asarray(light, np.float64).reshape(cloud.n, -1)[index]
    sky = sky_at(centres, particle_grid(cloud), quadrature)
    j = source(scene.settings, trans, view @ dirs.T, radiance, sky)
    alpha = 1.0 - np.exp(-np.asarray(cloud.tau, np.float64)[index])
    return (j * alpha[:, None]).astype(np.float32)


def billboard_colours(
    scene: Any, transmittance: np.ndarray, centres: np.ndarray, sky: np.ndarray, eye: Any
) -> np.ndarray:
    """``(N, 4, 3)`` float32 corner colours ``J`` of ``N`` billboards: ``transmittance``
    ``(N, 4, L)`` the sun's ``H·CAF·D`` at each corner, ``centres`` ``(N, 3)`` the billboards'
    world centres (the phase angle is taken there), ``sky`` ``(N, 3)`` the visible sky's
    fluence there (:func:`sky_at`)."""
    lights = (scene.sun, *scene.lights)
    n = len(centres)
    c = np.asarray(centres, np.float64).reshape(n, 3)
    view = c - np.asarray(eye, np.float64)
    view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-30)
    dirs = np.array([s.direction for s in lights], np.float64).reshape(-1, 3)
    radiance = np.array([s.radiance for s in lights], np.float64).reshape(-1, 3)
    cos = np.repeat((view @ dirs.T)[:, None, :], 4, axis=1)
    t = np.asarray(transmittance, np.float64).reshape(n * 4, -1)
    j = source(scene.settings, t, cos.reshape(n * 4, -1), radiance, np.repeat(sky, 4, axis=0))
    return j.reshape(n, 4, 3).astype(np.float32)
