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
