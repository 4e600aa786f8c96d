"""Soft ground shadows in the physical mode (RENDER_CONTRACT "Ground", "Soft shadows").

Two effects the direct ``exp(−τ)`` of a point-like sun misses:

- **Diffuse transmission.** A cloud scatters most of the sunlight it stops onwards, forwards
  more than back: under it the ground receives the sun's light through it diffusely. The
  two-stream estimate of a slab's total transmission, ``1/(1 + ¾(1 − ḡ)τ)`` (ḡ the phase's
  mean cosine), replaces ``exp(−τ)`` for the media's share, the part beyond the direct one
  weighted by the albedo: ``T = e^{−τ} + ϖ·(1/(1 + ¾(1 − ḡ)τ) − e^{−τ})``.
- **Penumbra.** The sun is a disc of angular diameter ``θ`` (``sun_angular_diameter``): a
  caster at distance ``D`` along the light blurs its shadow over ``D·θ`` across the light,
  ``D·θ/sin e`` along the sun's azimuth on the ground (``e`` the sun's elevation). ``D`` is the
  optical-depth-weighted mean over the casters of the midpoint of each one's box chord along
  the ray towards the sun; the map is filtered per texel by two passes of a box of width
  ``0.61·D·θ`` per axis (standard deviation ``D·θ/4``, the disc's), with the widths of the
  ellipse's bounding box along x and z.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

#: Share of the penumbra's width per box pass (two passes: standard deviation ``w/4``).
BOX_SHARE = 0.61


def diffuse_transmittance(tau: np.ndarray, mean_cosine: float, albedo: float) -> np.ndarray:
    """Sunlight reaching the ground through optical depth ``tau``: the direct ``exp(−τ)`` plus
    the two-stream diffuse share, ``albedo·(1/(1 + ¾(1 − ḡ)τ) − exp(−τ))`` (never below the
    direct)."""
    tau = np.asarray(tau, np.float64)
    direct = np.exp(-tau)
    total = 1.0 / (1.0 + 0.75 * (1.0 - mean_cosine) * tau)
    return direct + albedo * np.maximum(total - direct, 0.0)


def chord_midpoints(box: Any, points: np.ndarray, direction: Any) -> np.ndarray:
    """``(N,)``: the distance from each point along ``direction`` to the midpoint of its chord
    through ``box = (lo, hi)`` (``nan`` where the ray misses it)."""
    lo, hi = (np.asarray(v, np.float64) for v in box)
    d = np.asarray(direction, np.float64)
    d = d / np.linalg.norm(d)
    p = np.asarray(points, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        a, b = (lo - p) * inv, (hi - p) * inv
        a = np.where(np.isnan(a), -np.inf, a)
        b = np.where(np.isnan(b), np.inf, b)
        t0 = np.maximum(np.minimum(a, b).max(-1), 0.0)
        t1 = np.maximum(a, b).min(-1)
        return np.where(t1 >= t0, 0.5 * (t0 + t1), np.nan)


def caster_distance(taus: list[np.ndarray], mids: list[np.ndarray]) -> np.ndarray:
    """The optical-depth-weighted mean of the casters' chord midpoints (0 where none shades)."""
    num = np.zeros_like(taus[0], dtype=np.float64)
    den = np.zeros_like(num)
    for tau, mid in zip(taus, mids, strict=True):
        w = np.where(np.isfinite(mid), np.asarray(tau, np.float64), 0.0)
        num += w * np.nan_to_num(mid)
        den += w
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, 0.0)


def _box_1d(values: np.ndarray, width: np.ndarray, axis: int) -> np.ndarray:
    """A box filter of per-element ``width`` (texels, any real ≥ 0) along ``axis``, edges
    clamped: the mean over ``[i − w/2, i + w/2]`` of the piecewise-constant texels, from the
    interpolated running sum."""
    v = np.moveaxis(np.asarray(values, np.float64), axis, -1)
    w = np.moveaxis(np.asarray(width, np.float64), axis, -1)
    n = v.shape[-1]
    pad = int(math.ceil(float(w.max(initial=0.0)) / 2)) + 1
    ends = np.repeat(v[..., :1], pad, -1), np.repeat(v[..., -1:], pad, -1)
    padded = np.concatenate([ends[0], v, ends[1]], -1)
    cum = np.concatenate([np.zeros((*v.shape[:-1], 1)), np.cumsum(padded, -1)], -1)
    half = np.maximum(w, 1e-9) / 2
    centre = np.arange(n) + pad + 0.5  # texel i's centre in the running sum's coordinates
    rows = np.arange(int(np.prod(v.shape[:-1]))).reshape(*v.shape[:-1], 1)
    flat = cum.reshape(-1, cum.shape[-1])

    def at(x: np.ndarray) -> np.ndarray:
        k = np.clip(np.floor(x).astype(np.int64), 0, cum.shape[-1] - 2)
        f = x - k
        r = np.broadcast_to(rows, x.shape)
        return flat[r, k] * (1 - f) + flat[r, k + 1] * f

    out = (at(centre + half) - at(centre - half)) / (2 * half)
    out = np.where(w > 1e-6, out, v)
    return np.moveaxis(out, -1, axis)


def penumbra_widths(
    distance: np.ndarray, sun: Any, angle_deg: float, texel: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """``(wx, wz)`` in texels: the bounding box on the ground of the penumbra's ellipse,
    ``D·θ`` across the sun's azimuth and ``D·θ/sin e`` along it."""
    s = np.asarray(sun, np.float64)
    s = s / np.linalg.norm(s)
    across = np.asarray(distance, np.float64) * math.radians(angle_deg)
    along = across / max(s[1], 1e-3)
    h = math.hypot(s[0], s[2])
    ux, uz = (s[0] / h, s[2] / h) if h > 1e-9 else (1.0, 0.0)
    wx = np.sqrt((along * ux) ** 2 + (across * uz) ** 2) / texel[0]
    wz = np.sqrt((along * uz) ** 2 + (across * ux) ** 2) / texel[1]
    return wx, wz


def spread_distance(distance: np.ndarray, weight: np.ndarray, reach: float) -> np.ndarray:
    """Caster distances carried from the shaded texels to their neighbours within ``reach``
    texels (the weighted mean around each), so that a lit texel next to a shadow blurs it by
    the shadow's own width; 0 far from any shadow."""
    if reach <= 0:
        return distance
    w = np.asarray(weight, np.float64)
    width = np.full(w.shape, 2.0 * reach)
    num = _box_1d(_box_1d(w * distance, width, 0), width, 1)
    den = _box_1d(_box_1d(w, width, 0), width, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        filled = np.where(den > 1e-12, num / den, 0.0)
    return np.where(w > 0, distance, filled)


def penumbra(
    values: np.ndarray,
    distance: np.ndarray,
    weight: np.ndarray,
    sun: Any,
    angle_deg: float,
    extent: tuple[float, float, float, float],
) -> np.ndarray:
    """``values`` ``(nz, nx)`` blurred per texel by the sun disc's penumbra (module doc);
    ``distance`` the caster distance where ``weight`` (the optical depth) is positive."""
    if angle_deg <= 0:
        return np.asarray(values, np.float32)
    nz, nx = values.shape
    x0, z0, x1, z1 = extent
    texel = ((x1 - x0) / nx, (z1 - z0) / nz)
    d_max = float(np.max(distance, initial=0.0))
    wx_max, wz_max = penumbra_widths(np.array(d_max), sun, angle_deg, texel)
    # A blur wider than the map is the map's mean (a grazing sun): widths are capped there.
    limit = 2.0 * max(nx, nz)
    reach = min(float(max(wx_max, wz_max)), limit)
    if reach < 1e-3:
        return np.asarray(values, np.float32)
    d = spread_distance(distance, weight, reach)
    wx, wz = (np.minimum(v, limit) for v in penumbra_widths(d, sun, angle_deg, texel))
    out = np.asarray(values, np.float64)
    for _ in range(2):
        out = _box_1d(out, BOX_SHARE * wx, 1)
        out = _box_1d(out, BOX_SHARE * wz, 0)
    return np.clip(out, 0.0, 1.0).astype(np.float32)
