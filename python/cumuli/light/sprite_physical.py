"""The physical mode's light for sprites: particle clouds (Harris 2002) and billboard clouds
(Torchelsen & Musse 2005) lit with the media's terms (RENDER_CONTRACT "Sprites", "One light").

The sun's direct light comes from the sprite's own light pass, which knows where the sun
reaches it at the sprite's own scale: ``T`` = Harris's light ``i_k`` (particles) or ``H·CAF·D``
at a corner (billboards), the scene's shadows on the cloud included, used as ``e^{−τ_sun}`` in the
marcher's octave sum with the scene's phase. The diffuse sunlight ``F`` and the sky light ``S``
come from the media's own light step: the cloud becomes a *proxy medium* — the extinction its own
light pass sees, on a lattice of :data:`GRID` cells on its longest edge (a particle a ball of
optical depth ``−ln`` of what it passes on, :func:`passed`; a billboard cloud's boxes
:data:`CAF_RATE`/``max_distance``, the CAF's absorption) — lit alone by
:func:`cumuli.light.physical.physical_pass` (SH sky visibility, diffusion, the media's gains).
Each sprite then takes the marcher's source term at its own points,

    J = ϖ·( E_sun·( Σ_n aⁿ·p_{bⁿ}(cos θ)·Pₙ(τ) + B·F/4π ) + Σ_ℓ E_ℓ·p(cos θ_ℓ)·T_ℓ + S/4π )

with the scene's albedo ``ϖ``; ``Pₙ(τ)`` the marcher's Poisson-weighted octaves at
``τ = −ln T`` (``cumuli.light.physical.octave_sum``); the proxy's lattice gains reached within
:data:`PROXY_GAIN_DEPTH` of optical thickness; ``B`` the scene's shadow on the cloud (its light
through the scene over its own, ``ParticleLight.unshadowed``,
``BillboardLighting.unshadowed``); the extra lights ``ℓ`` (``Scene.lights``, which the media do
not take) single-scattered with their own pass's ``T_ℓ``. All of it is numpy and C++ on the
sprite lists both backends draw, so GL and CPU get the same colours.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import numpy as np

from cumuli import _core
from cumuli.light.memo import content_digest
from cumuli.light.particles import particles_digest
from cumuli.light.physical import light_sky, octave_sum, phase_values, physical_light
from cumuli.model.volume import VolumeCloud

#: Cells on the longest edge of a sprite cloud's proxy lattice, and of a field variant's (a
#: field has many).
GRID = 24
FIELD_GRID = 12
#: A billboard cloud's box extinction is ``CAF_RATE/D``, ``D`` its CAF's ``max_distance``: the
#: rate of the CAF's ``"exp"`` curve ``e^{−3L/D}`` (the ``"linear"`` curve ``1 − L/D`` is the
#: same absorption made linear, gone at ``L = D``).
CAF_RATE = 3.0
#: The ``gain_depth`` of a proxy's light (``cumuli.light.physical.lattice_gains``): a proxy's
#: cells are few and thin (a sprite cloud's extinction is its light pass's, spread over cells
#: 1/GRID of its size), and its sprites show their cell's surface like a medium's thick cell does.
PROXY_GAIN_DEPTH = 0.1
#: The weight of a proxy's forward-scattered sun source in its diffusion: none. A proxy's few,
#: thin cells cannot carry the flux source's gradient (``cumuli.light.physical.SUN_FORWARD``):
#: on them it moves the light onto the side away from the sun, and a sprite cloud's shadow side
#: came out brighter than its lit side.
PROXY_FORWARD = 0.0
#: Particle clouds' proxy lattices kept (least recently used dropped first).
MEMO_SIZE = 256
_memo: OrderedDict[tuple, tuple] = OrderedDict()
#: Proxy lights kept (least recently used dropped first).
LIGHT_MEMO_SIZE = 1024
_lights: OrderedDict[tuple, Any] = OrderedDict()
_lock = threading.Lock()


# --- proxy lattices -----------------------------------------------------------------------------
def grid_box(
    lo: Any, hi: Any, cells: int = GRID
) -> tuple[np.ndarray, np.ndarray, tuple[int, int, int]]:
    """A lattice over the box ``lo``–``hi`` padded by one cell: its corners and ``(D, H, W)``,
    ``cells`` cubic cells on the longest edge."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    h = max(float((hi - lo).max()), 1e-6) / (cells - 2)
    size = np.maximum(np.ceil((hi - lo) / h), 1) + 2  # (x, y, z)
    lo = (lo + hi) / 2 - size * h / 2
    return lo, lo + size * h, (int(size[2]), int(size[1]), int(size[0]))


def cell_centres(lo: np.ndarray, hi: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """``(D·H·W, 3)`` world centres of a lattice's cells (x fastest)."""
    d, h, w = shape
    z, y, x = np.meshgrid(*((np.arange(n) + 0.5) / n for n in (d, h, w)), indexing="ij")
    return lo + np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1) * (hi - lo)


def _splat(lo: np.ndarray, hi: np.ndarray, shape: tuple, points: np.ndarray,
           amount: np.ndarray) -> np.ndarray:  # fmt: skip
    """Each point's ``amount`` (extinction × volume) spread trilinearly over the 8 cells around
    it, divided by the cell volume: a ``(D, H, W)`` extinction lattice."""
    d, h, w = shape
    cell = float((hi - lo)[0]) / w
    f = (np.asarray(points, np.float64) - lo) / cell - 0.5
    grid = np.zeros(shape)
    for wgt, index in _trilinear_corners(f, (w, h, d)):
        np.add.at(grid, index, wgt * amount)
    return grid / cell**3


def _trilinear_corners(
    f: np.ndarray, size: tuple[int, int, int]
) -> Iterator[tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]]:
    """The 8 ``(weight (N,), (z, y, x) indices)`` of trilinear interpolation at lattice
    coordinates ``f`` (``(N, 3)``, texel centres at integers, clamped to the lattice)."""
    f = np.clip(f, 0.0, np.asarray(size, np.float64) - 1.0)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, np.asarray(size, np.int64) - 1)
    t = f - i0
    for cz in (0, 1):
        for cy in (0, 1):
            for cx in (0, 1):
                wgt = (np.where(cx, t[:, 0], 1 - t[:, 0]) * np.where(cy, t[:, 1], 1 - t[:, 1])
                       * np.where(cz, t[:, 2], 1 - t[:, 2]))  # fmt: skip
                x = np.where(cx, i1[:, 0], i0[:, 0])
                y = np.where(cy, i1[:, 1], i0[:, 1])
                z = np.where(cz, i1[:, 2], i0[:, 2])
                yield wgt, (z, y, x)


def passed(cloud: Any, settings: Any) -> np.ndarray:
    """``(n,)``: the fraction of the light a particle passes on in its own light pass (Harris
    2002's recurrence with ``settings``, a `SpriteSettings`): ``e^{−τ_k}`` plus what it
    scatters forward, ``g_k = a_k τ_k p_fwd γ/4π`` (0 with ``forward=False``), at most 1."""
    tau = np.asarray(cloud.tau, np.float64)
    keep = np.exp(-tau)
    if not settings.forward:
        return keep
    fwd = float(_core.phase_4pi(settings.phase, settings.hg_g, np.ones(1, np.float32))[0])
    g = np.asarray(cloud.albedo, np.float64) * tau * fwd * settings.solid_angle / (4 * math.pi)
    return np.minimum(keep + g, 1.0)


def particle_extinction(cloud: Any, settings: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(lo, hi, σ)`` the proxy lattice of a particle cloud: every particle a ball of radius
    ``r_k`` whose optical depth through the centre is what its own light pass sees, ``−ln``
    :func:`passed` (Harris's particles scatter most of what they stop forward, on along the
    light), spread over the 8 cells around its centre. Built about the bounding sphere's
    centre (a medium alone is lit the same wherever it is: a moved cloud finds its light
    again); it depends on the shape only up to translation and scale, so it is memoised by
    :func:`cumuli.light.particles.particles_digest` and the light pass's settings."""
    centre, radius = cloud.sphere
    c0, r0 = np.asarray(centre, np.float64), max(float(radius), 1e-30)
    key = (particles_digest(cloud), settings.forward, settings.phase, settings.hg_g,
           settings.solid_angle)  # fmt: skip
    with _lock:
        known = _memo.get(key)
        if known is not None:
            _memo.move_to_end(key)
    if known is None:
        c = np.asarray(cloud.centres, np.float64)
        r = np.asarray(cloud.radii, np.float64)
        lo, hi, shape = grid_box((c - r[:, None]).min(0), (c + r[:, None]).max(0))
        tau = -np.log(np.maximum(passed(cloud, settings), 1e-12))
        sigma = _splat(lo, hi, shape, c, tau / (2 * r) * (4.0 / 3.0) * math.pi * r**3)
        sigma = (sigma * r0).astype(np.float32)  # σ·R: the same for a scaled cloud
        sigma.setflags(write=False)
        known = ((lo - c0) / r0, (hi - c0) / r0, sigma)
        with _lock:
            _memo[key] = known
            while len(_memo) > MEMO_SIZE:
                _memo.popitem(last=False)
    lo_rel, hi_rel, sigma_r = known
    return lo_rel * r0, hi_rel * r0, sigma_r / np.float32(r0)


def box_extinction(boxes: np.ndarray, max_distance: float, cells: int = GRID) -> tuple:
    """``(lo, hi, σ)`` the proxy lattice (``cells`` on the longest edge) of a billboard cloud:
    :data:`CAF_RATE`/``max_distance`` (0 with no absorption) times the fraction of each
    cell inside its boxes ``(M, 2, 3)`` (2³ points a cell)."""
    b = np.asarray(boxes, np.float64)
    lo, hi, shape = grid_box(b[:, 0].min(0), b[:, 1].max(0), cells)
    half = float((hi - lo)[0]) / shape[2] / 2.0  # 2³ points a cell: a lattice twice as fine
    d, h, w = shape
    fine = np.zeros((2 * d, 2 * h, 2 * w), bool)
    first = np.ceil((b[:, 0] - lo) / half - 0.5).astype(np.int64)
    last = np.floor((b[:, 1] - lo) / half - 0.5).astype(np.int64)
    first, last = np.maximum(first, 0), np.minimum(last, np.array([2 * w, 2 * h, 2 * d]) - 1)
    for (x0, y0, z0), (x1, y1, z1) in zip(first.tolist(), last.tolist(), strict=True):
        fine[z0 : z1 + 1, y0 : y1 + 1, x0 : x1 + 1] = True
    inside = fine.reshape(d, 2, h, 2, w, 2).mean(axis=(1, 3, 5))
    k = 0.0 if math.isinf(max_distance) else CAF_RATE / max_distance
    return lo, hi, (k * inside).astype(np.float32)


def proxy_light(lattice: tuple, scene: Any) -> Any:
    """The :class:`cumuli.PhysicalLight` of the proxy medium ``(lo, hi, σ)`` under the scene's
    sun, sky and ground, alone (the other drawables' shadows come through the sprite's own
    light), its sun lattice as fine as its own lattice; one thread (a proxy lattice is small:
    threads cost more than they give), so the same whatever the thread count. Memoised by
    content, apart from the light step's memo (a field has a proxy per variant)."""
    lo, hi, sigma = lattice
    settings = replace(scene.settings, physical_resolution=max(sigma.shape))
    sky = light_sky(scene)
    key = (content_digest(sigma), tuple(np.asarray(lo).tolist()), tuple(np.asarray(hi).tolist()),
           settings, scene.sun, sky)  # fmt: skip
    with _lock:
        known = _lights.get(key)
        if known is not None:
            _lights.move_to_end(key)
            return known
    volume = VolumeCloud(density=sigma, box=(tuple(lo), tuple(hi)), sigma_t=1.0)
    alone = replace(scene, clouds=[volume], lights=(), solids=(), settings=settings, sky=sky)
    light = physical_light(
        volume, alone, threads=1, gain_depth=PROXY_GAIN_DEPTH, forward=PROXY_FORWARD
    )
    with _lock:
        _lights[key] = light
        while len(_lights) > LIGHT_MEMO_SIZE:
            _lights.popitem(last=False)
    return light


def sample(light: Any, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(τ_sun (N,), F (N,), S (N, 3))`` of a physical light at world ``points``: the sun
    lattice as the marcher reads it, the world lattice trilinear between texel centres
    (clamped), as "Light grids"."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    tau = np.asarray(light.sample_depth(pts), np.float64)
    grid = np.asarray(light.grid, np.float64)
    d, h, w = grid.shape[:3]
    lo, hi = (np.asarray(v, np.float64) for v in light.box)
    f = (pts - lo) / (hi - lo) * np.array([w, h, d], np.float64) - 0.5
    out = np.zeros((len(pts), 4))
    for wgt, index in _trilinear_corners(f, (w, h, d)):
        out += wgt[:, None] * grid[index]
    return tau, out[:, 0], out[:, 1:]


# --- the source term ----------------------------------------------------------------------------
def sun_octaves(settings: Any, tau: np.ndarray, cos_theta: np.ndarray, octaves: int) -> np.ndarray:
    """The marcher's octave terms (``cumuli.light.physical.octave_sum``)."""
    return octave_sum(settings, tau, cos_theta, octaves)


def source(
    scene: Any,
    light: Any,
    points: np.ndarray,
    view: np.ndarray,
    sun: np.ndarray,
    shadow: np.ndarray,
    extra: np.ndarray | None,
) -> np.ndarray:
    """``J`` ``(N, 3)`` float64 (the module doc) at world ``points`` (in the proxy's frame) seen
    along the unit ``view`` directions ``(N, 3)``: ``light`` the proxy's physical light,
    ``sun`` ``(N,)`` the sun's transmittance ``T`` from the sprite's own light (the scene's
    shadows included), ``shadow`` ``(N,)`` the factor ``B`` on the diffuse sunlight, ``extra``
    ``(N, L − 1)`` the extra lights' transmittances (None without extra lights)."""
    s = scene.settings
    _, diffuse, sky = sample(light, points)
    tau = -np.log(np.clip(np.asarray(sun, np.float64), 1e-30, 1.0))
    to_sun = np.asarray(scene.sun.direction, np.float64)
    per_sun = sun_octaves(s, tau, view @ to_sun, light.octaves)
    per_sun = per_sun + np.asarray(shadow, np.float64) * diffuse / (4.0 * math.pi)
    j = per_sun[:, None] * np.asarray(scene.sun.radiance) + sky / (4.0 * math.pi)
    for i, other in enumerate(scene.lights):
        cos = view @ np.asarray(other.direction, np.float64)
        t = np.clip(np.asarray(extra, np.float64)[:, i], 0.0, 1.0)
        j = j + (phase_values(s, cos) * t)[:, None] * np.asarray(other.radiance)
    return float(s.albedo) * j


def shadow_factor(shaded: np.ndarray, own: np.ndarray | None) -> np.ndarray:
    """``B``: a sprite's light through the scene over its own light (1 where it has none or
    no own light is kept), clipped to [0, 1]."""
    a = np.asarray(shaded, np.float64)
    if own is None:
        return np.ones_like(a)
    b = np.asarray(own, np.float64)
    return np.clip(np.where(b > 0.0, a / np.where(b > 0.0, b, 1.0), 1.0), 0.0, 1.0)


def particle_colours(scene: Any, cloud: Any, light: Any, index: np.ndarray, eye: Any) -> np.ndarray:
    """``(M, 3)`` float32 premultiplied colours ``J·(1 − e^{−τ_k})`` of the particles ``index``
    of ``cloud`` (``light`` its :class:`~cumuli.light.particles.ParticleLight`) seen from
    ``eye``. ``J`` is taken where a ball of optical depth ``τ_k`` emits on average along the
    view ray through its centre: ``r_k − (1/σ − 2r_k e^{−τ_k}/(1 − e^{−τ_k}))`` before the
    centre, ``σ = τ_k/(2r_k)``."""
    idx = np.asarray(index, np.int64)
    centres = np.asarray(cloud.centres, np.float64)[idx]
    r = np.asarray(cloud.radii, np.float64)[idx]
    tau = np.maximum(np.asarray(cloud.tau, np.float64)[idx], 1e-6)
    view = centres - np.asarray(eye, np.float64)
    view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-30)
    keep = np.exp(-tau)
    thin = tau < 1e-3  # the mean emission depth; the centre as τ → 0
    safe = np.where(thin, 1.0, tau)
    depth = np.where(thin, r, 2.0 * r / safe - 2.0 * r * np.exp(-safe) / -np.expm1(-safe))
    points = centres - view * (r - depth)[:, None]
    rows = np.asarray(light.light, np.float64).reshape(cloud.n, -1)[idx]
    own = light.unshadowed
    own_rows = None if own is None else np.asarray(own.light, np.float64).reshape(cloud.n, -1)
    shadow = shadow_factor(rows[:, 0], None if own_rows is None else own_rows[idx, 0])
    proxy = proxy_light(particle_extinction(cloud, scene.sprite_settings), scene)
    c0 = np.asarray(cloud.sphere[0], np.float64)
    extra = rows[:, 1:] if scene.lights else None
    j = source(scene, proxy, points - c0, view, rows[:, 0], shadow, extra)
    return (j * (1.0 - keep)[:, None]).astype(np.float32)


def corners(centres: np.ndarray, half_sizes: np.ndarray, rotation: np.ndarray | None,
            camera: Any) -> np.ndarray:  # fmt: skip
    """``(N, 4, 3)`` world corners of view-plane-parallel sprites, in the vertex order
    ``(s, t) = (−1,−1), (1,−1), (1,1), (−1,1)`` (RENDER_CONTRACT "Sprites": the inverse of its
    pixel → ``(s, t)`` map)."""
    _, r, u = (np.asarray(v, np.float64) for v in camera.basis())
    n = len(centres)
    psi = np.radians(np.zeros(n) if rotation is None else np.asarray(rotation, np.float64))
    hs = np.asarray(half_sizes, np.float64).reshape(n, -1)
    hx, hy = hs[:, 0], hs[:, -1]
    st = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    a = st[None, :, 0] * hx[:, None]
    b = st[None, :, 1] * hy[:, None]
    c, s = np.cos(psi)[:, None], np.sin(psi)[:, None]
    x = c * a - s * b
    y = s * a + c * b
    return np.asarray(centres, np.float64)[:, None, :] + x[..., None] * r + y[..., None] * u


def billboard_colours(
    scene: Any,
    lights: list[tuple[Any, np.ndarray]],
    instance: np.ndarray,
    points: np.ndarray,
    transmittance: np.ndarray,
    shadow: np.ndarray,
    eye: Any,
) -> np.ndarray:
    """``(N, 4, 3)`` float32 corner colours ``J`` of ``N`` billboards at their world corners
    ``points`` ``(N, 4, 3)`` seen from ``eye``: ``lights[k] = (proxy light, offset)`` of cloud
    ``k`` of the pass (its proxy lattice built about ``offset``), ``instance`` ``(N,)`` each
    billboard's cloud, ``transmittance`` ``(N, 4, L)`` every light's ``H·CAF·D`` at the corners
    (the CAF through the scene), ``shadow`` ``(N, 4)`` the factor ``B``."""
    n = len(instance)
    out = np.zeros((n, 4, 3))
    world = np.asarray(points, np.float64).reshape(n, 4, 3)
    for k in np.unique(instance):
        rows = np.flatnonzero(instance == k)
        p = world[rows].reshape(-1, 3)
        view = p - np.asarray(eye, np.float64)
        view /= np.maximum(np.linalg.norm(view, axis=1, keepdims=True), 1e-30)
        t = np.asarray(transmittance)[rows].reshape(len(p), -1)
        more = t[:, 1:] if t.shape[1] > 1 else None
        light, offset = lights[int(k)]
        b = np.asarray(shadow)[rows].reshape(-1)
        j = source(scene, light, p - offset, view, t[:, 0], b, more)
        out[rows] = j.reshape(len(rows), 4, 3)
    return out.astype(np.float32)
