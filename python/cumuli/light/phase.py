"""The physical mode's phase function as the light step and the drawers use it: the settings'
phase (the approximate Mie phase of water droplets, Jendersie & d'Eon 2023; Henyey-Greenstein;
or a two-lobe HG blend) with its g's scaled for the octaves, and the share of its light in the
forward peak that the diffusion's sun source takes as unscattered (the δ-M similarity
relation)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli import _core

#: The forward cone (``cos θ ≥`` this: within 2.6° of straight on) whose scattered sun light the
#: diffusion's source treats as unscattered (:func:`forward_peak_share`; the δ-M similarity
#: relation): light scattered that little goes on along the sun's ray, it does not diffuse.
PEAK_COS = 0.999


def phase(settings: Any, cos_theta: float, g_scale: float = 1.0) -> float:
    """The settings' phase function (the approximate Mie phase, HG or the two-lobe blend) with
    its g's scaled."""
    return float(phase_values(settings, np.array([cos_theta]), g_scale)[0])


def phase_values(settings: Any, cos_theta: Any, g_scale: float = 1.0) -> np.ndarray:
    """:func:`phase` at an array of cosines (float64; the Mie phase evaluated by the core)."""
    c = np.asarray(cos_theta, np.float64)
    if settings.phase == "mie":
        flat = np.ascontiguousarray(c.ravel(), np.float32)
        out = _core.approx_mie_phase(settings.droplet_diameter, flat, g_scale)
        return np.asarray(out, np.float64).reshape(c.shape)

    def hg(g: float) -> np.ndarray:
        d = 1.0 + g * g - 2.0 * g * c
        return (1.0 - g * g) / (4.0 * math.pi * d * np.sqrt(d))

    if settings.phase == "dual_hg":
        w = settings.hg_blend
        return (1.0 - w) * hg(settings.hg_g * g_scale) + w * hg(settings.hg_g2 * g_scale)
    return hg(settings.hg_g * g_scale)


def forward_peak_share(settings: Any) -> float:
    """``f``: the share of the settings' phase function within the forward cone
    ``cos θ ≥`` :data:`PEAK_COS`, ``2π ∫ p(μ) dμ`` over it (the approximate Mie phase of 20 µm
    droplets puts 0.447 of its light there, its diffraction peak; an HG lobe of g 0.85, 0.04).

    The diffusion's sun source takes that light as unscattered, the δ-M similarity relation
    (Wiscombe, "The Delta–M Method", J. Atmos. Sci. 1977): the sun reaches a point with
    ``e^{−(1 − f·ϖ)·τ}`` and a cell scatters ``(1 − f)`` of what it collides into the diffuse
    field. The reduced extinction, and with it the diffusion coefficient, is the same either
    way, ``σt(1 − ϖḡ)``. The drawers' octaves keep the whole phase."""
    key = (settings.phase, settings.droplet_diameter, settings.hg_g, settings.hg_g2,
           settings.hg_blend)  # fmt: skip
    return _peak_share(*key)


@functools.lru_cache(maxsize=64)
def _peak_share(phase_name: str, diameter: float, g: float, g2: float, blend: float) -> float:
    # Midpoints of 4096 cells over [PEAK_COS, 1]: the Mie peak's tenth within 0.3° spans ~56.
    n = 4096
    mu = PEAK_COS + (np.arange(n) + 0.5) * (1.0 - PEAK_COS) / n
    settings = _PhaseOnly(phase_name, diameter, g, g2, blend)
    p = phase_values(settings, mu)
    return float(2.0 * math.pi * p.mean() * (1.0 - PEAK_COS))


@dataclass(frozen=True)
class _PhaseOnly:
    """The phase function's settings alone (what :func:`phase_values` reads)."""

    phase: str
    droplet_diameter: float
    hg_g: float
    hg_g2: float
    hg_blend: float


def order_phase_table(settings: Any, octaves: int) -> np.ndarray:
    """The angular distribution of the drawn orders ``n = 1 … octaves − 1`` as the drawers read
    it (``PhysicalParams.order_phase``): ``(octaves − 1, ORDER_PHASE_SIZE)`` float32, order
    ``n``'s row at the scattering angles ``sin(θ/2) = k/(ORDER_PHASE_SIZE − 1)`` (entries 1.8°
    apart near the forward direction, where the phase is steepest).

    Light scattered ``n + 1`` times has turned through the phase function ``n + 1`` times: its
    angular distribution is the phase convolved with itself ``n`` times over the sphere, which
    multiplies the phase's Legendre coefficients ``χ_l`` (``p = Σ (2l + 1)/4π·χ_l·P_l``) into
    ``χ_l^{n+1}``. The phase convolved is the δ-M one, without the forward peak (``cos θ ≥``
    :data:`PEAK_COS`, light that goes on along the ray) and renormalised; each row is scaled by
    the ``1 − f`` the peak leaves, as the phase itself away from the peak. For HG lobes this is
    Wrenninge's ``g`` scaled by ``gⁿ``; for the Mie phase it spreads the twice-scattered light
    of a back-lit cloud over a wide cone instead of keeping the phase's narrow lobe."""
    key = (settings.phase, settings.droplet_diameter, settings.hg_g, settings.hg_g2,
           settings.hg_blend)  # fmt: skip
    return _order_phase_table(*key, int(octaves)).copy()


#: Legendre terms and θ quadrature cells of :func:`order_phase_table` (its rows change by < 10⁻⁴
#: relative from 1000 to 4000 terms, but within 3° of straight on, a narrow rise of two nearly
#: opposite ~3° turns that the table's 1.8° spacing there does not resolve anyway).
_LEGENDRE_TERMS = 2000
_QUADRATURE_CELLS = 20000


@functools.lru_cache(maxsize=64)
def _order_phase_table(phase_name: str, diameter: float, g: float, g2: float, blend: float,
                       octaves: int) -> np.ndarray:  # fmt: skip
    size = int(_core.ORDER_PHASE_SIZE)
    if octaves <= 1:
        return np.zeros((0, size), np.float32)
    # Midpoints in θ over the phase outside the forward cone: fine enough near the cone, where
    # the Mie phase is largest and a Legendre term of degree 2000 turns every 0.09°.
    cone = math.acos(PEAK_COS)
    n = _QUADRATURE_CELLS
    theta = cone + (np.arange(n) + 0.5) * (math.pi - cone) / n
    mu = np.cos(theta)
    weight = 2.0 * math.pi * np.sin(theta) * (math.pi - cone) / n
    p = phase_values(_PhaseOnly(phase_name, diameter, g, g2, blend), mu) * weight
    kept = float(p.sum())  # 1 − f
    q = p / kept
    chi = np.empty(_LEGENDRE_TERMS)
    p0, p1 = np.ones_like(mu), mu.copy()
    chi[0], chi[1] = q.sum(), (q * mu).sum()
    for ell in range(2, _LEGENDRE_TERMS):
        p0, p1 = p1, ((2 * ell - 1) * mu * p1 - (ell - 1) * p0) / ell
        chi[ell] = (q * p1).sum()
    at = 1.0 - 2.0 * (np.arange(size) / (size - 1)) ** 2  # cos θ at sin(θ/2) = k/(size − 1)
    lw = (2.0 * np.arange(_LEGENDRE_TERMS) + 1.0) / (4.0 * math.pi)
    rows = [
        kept * np.polynomial.legendre.legval(at, lw * chi ** (k + 1)) for k in range(1, octaves)
    ]
    # A truncated series may dip a hair below 0 where the distribution is near 0 (backwards).
    return np.maximum(np.asarray(rows, np.float32), 0.0)


def order_phase_values(table: np.ndarray, order: int, cos_theta: Any) -> np.ndarray:
    """Order ``order``'s row of :func:`order_phase_table` at ``cos_theta`` (float64), linear in
    ``sin(θ/2) = √((1 − cos θ)/2)`` between its entries as the drawers read it."""
    row = np.asarray(table[order - 1], np.float64)
    size = row.size
    c = np.asarray(cos_theta, np.float64)
    x = np.minimum(np.sqrt(np.maximum(0.5 - 0.5 * c, 0.0)), 1.0) * (size - 1)
    k = np.minimum(x.astype(np.int64), size - 2)
    return row[k] + (x - k) * (row[k + 1] - row[k])


def order_phase_at(settings: Any, cos_theta: Any, order: int, octaves: int, b_power: float,
                   convolved: bool) -> np.ndarray:  # fmt: skip
    """Order ``order``'s phase at ``cos_theta`` (float64) as the drawers read it: the phase
    itself for order 0; else :func:`order_phase_table`'s row where ``convolved``, or the phase
    with its g's scaled by ``b_power`` (``bⁿ``, Wrenninge et al.'s octaves)."""
    if order == 0 or not convolved:
        return phase_values(settings, cos_theta, b_power)
    return order_phase_values(order_phase_table(settings, octaves), order, cos_theta)


#: Whether order 0 (single scattering) reaches a point with the δ-M sun, ``e^{−(1 − f·ϖ)τ}``.
FIRST_ORDER_DELTA_M = True


def first_order_depth_scale(settings: Any) -> float:
    """Order 0's optical-depth scale: ``1 − f·ϖ`` (:func:`forward_peak_share`), the δ-M sun.

    The phase's forward peak scatters light on along the sun's ray: the sun light that has
    only been forward-peak scattered still reaches the point, so single scattering out of the
    peak sees ``e^{−(1 − f·ϖ)τ}``, not ``e^{−τ}`` (the δ-M similarity relation, as the
    diffusion's source)."""
    if not FIRST_ORDER_DELTA_M:
        return 1.0
    return float(1.0 - forward_peak_share(settings) * float(settings.albedo))


#: Whether the camera's rays see the δ-M view (:func:`view_depth_scale`).
VIEW_DELTA_M = True


def view_depth_scale(settings: Any) -> float:
    """The camera ray's optical-depth scale for radiance: ``1 − f·ϖ`` (the δ-M view).

    Light scattered into the phase's forward peak (within 2.6°) goes on to the camera with the
    light that was not scattered: what lies behind a stretch of cloud — the sky, the ground,
    the cloud's own deeper light — reaches the camera with ``e^{−(1 − f·ϖ)τ}``, not ``e^{−τ}``.
    The coverage (alpha, ``1 − e^{−τ}``) is the cloud's geometric one."""
    if not VIEW_DELTA_M:
        return 1.0
    return float(1.0 - forward_peak_share(settings) * float(settings.albedo))


def view_diffuse_share(settings: Any) -> float:
    """The diffuse light's share of what a stretch of cloud sends the camera: ``1 − f`` in the
    δ-M view (the forward peak's share of the scattered diffuse light goes on along the ray, and
    the view's ``e^{−(1 − f·ϖ)τ}`` carries it), 1 without."""
    if not VIEW_DELTA_M:
        return 1.0
    return float(1.0 - forward_peak_share(settings))
