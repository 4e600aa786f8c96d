"""How far Harris 2002's approximations are from the volume they stand for ([beyond the paper]).

A particle is the Gaussian blob ``σ(x) = β_k·exp(−|x − p_k|²/(2 s_k²))``, ``s_k = r_k/3``,
``β_k = τ_k/(s_k√(2π))`` (:meth:`cumuli.ParticleCloud.to_volume`). Two measurements:

* :func:`image_fidelity` renders one particle cloud (a) by Harris splatting, (b) as that density
  on a grid with the volume marcher (single scattering of the sun, isotropic phase on both sides,
  black sky, no forward scattering: the same physics, different discretisation) and (c) the
  2018 cloud the particles were filled from with the 2018 marcher (its eq. 2 density cannot hold
  Gaussian blobs, so this compares shapes), and returns the per-pixel relative errors.
* :func:`light_fidelity` compares the light the multiple-forward-scattering pass gives each
  particle, ``i_k`` (eq. (4), solid angle γ), with the exact transmittance of the other blobs
  towards the sun at the particle's centre, ``T_k = exp(−∫σ)`` (closed form: each blob contributes
  ``τ_j/2·exp(−h²/(2s_j²))·(1 + erf(b/(s_j√2)))``, ``b`` and ``h`` the along- and across-ray
  offsets of its centre), and with the continuum limit of the recurrence,
  ``T_k^{1 − a p_fwd γ/4π}`` (spec §3.1: Beer–Lambert with a reduced extinction), over a grid of
  τ and γ.

These run the library's own renderers and light passes; the closed-form transmittance is a
float64 reference of a few thousand particles (O(N²)).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli._util import validate as check
from cumuli.camera import Camera
from cumuli.light.particles import particle_light
from cumuli.light.sprite_settings import SpriteSettings
from cumuli.light.volume import VolumeLighting
from cumuli.model.cloud import Cloud
from cumuli.model.particles import ParticleCloud
from cumuli.model.volume import VolumeCloud, VolumeDatabase
from cumuli.noise import PAPER_VERSION, Noise
from cumuli.scene import Scene
from cumuli.settings import RenderSettings
from cumuli.sky import Sky, Sun

#: A black sky: no background and no sky light, so only the sun lights both sides.
BLACK_SKY = Sky(zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0), sun_disc_intensity=0.0)
#: The lighting these comparisons are made in (each kind's own light model).
PAPER = RenderSettings(lighting="paper")
#: Most particles :func:`light_fidelity` takes (its reference is O(N²)).
MAX_REFERENCE_PARTICLES = 8192


def _relative(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> dict[str, float]:
    la, lb = a[..., :3].mean(axis=-1), b[..., :3].mean(axis=-1)
    rel = np.abs(la - lb)[mask] / np.maximum(lb[mask], 1e-6)
    return {
        "median_relative": float(np.median(rel)) if rel.size else 0.0,
        "mean_relative": float(rel.mean()) if rel.size else 0.0,
        "ratio_of_means": float(la[mask].mean() / max(lb[mask].mean(), 1e-12)) if rel.size else 0,
        "alpha_mean_abs": float(np.abs(a[..., 3] - b[..., 3]).mean()),
        "pixels": int(mask.sum()),
    }


def image_fidelity(
    cloud: ParticleCloud,
    sun: Sun,
    camera: Camera,
    width: int,
    height: int,
    *,
    shape: Cloud | None = None,
    resolution: int = 48,
    backend: str = "cpu",
    threads: int = 0,
) -> dict[str, Any]:
    """Images and per-pixel errors of the three renderings of ``cloud`` (module docstring).

    Returns ``images`` (``splat``, ``volume`` and, with ``shape``, ``marched``: ``(H, W, 4)``)
    and ``errors``: ``splat_vs_volume`` (and ``splat_vs_marched``) with the median and mean
    relative error of the radiance on the reference's cloud pixels (alpha > 0.05), the ratio of
    mean radiances and the mean |Δalpha|.
    """
    from cumuli.rendering.compositor import render

    if not isinstance(cloud, ParticleCloud):
        raise TypeError(f"cloud must be a ParticleCloud, got {type(cloud).__name__}")
    resolution = check.integer(resolution, "resolution", 4, 256)
    albedo = float(cloud.albedo.mean())
    # Single scattering, isotropic phase, no ambient: the volume marcher's physics.
    settings = SpriteSettings(phase="isotropic", forward=False)
    splat = render(
        Scene([cloud], sun=sun, sky=BLACK_SKY, sprite_settings=settings, settings=PAPER),
        camera, width, height, backend=backend,
    )  # fmt: skip
    density, box = cloud.to_volume(resolution, threads=threads)
    database = VolumeDatabase(density[None], *box)
    # The sky is black: the SH sky terms are zero whatever their order (the smallest is made).
    lighting = VolumeLighting(
        database, sun, BLACK_SKY, sigma_t=1.0, albedo=albedo, ms_points=0, sh_order=1,
        sh_samples=1, threads=threads,
    )  # fmt: skip
    volume = VolumeCloud(
        density=density, box=box, sigma_t=1.0, albedo=albedo, g=0.0,
        light=lighting.light(0, threads=threads), light_sun=sun, light_sky=BLACK_SKY,
    )  # fmt: skip
    vol = render(
        Scene([volume], sun=sun, sky=BLACK_SKY, settings=PAPER),
        camera,
        width,
        height,
        backend=backend,
    )
    images = {"splat": splat, "volume": vol}
    errors = {"splat_vs_volume": _relative(splat, vol, vol[..., 3] > 0.05)}
    if shape is not None:
        marched = render(
            Scene([shape], sun=sun, sky=BLACK_SKY,
                  noise=Noise(seed=7, size=32, version=PAPER_VERSION),  # the paper mode's noise
                  settings=RenderSettings(hg_g=0.0, lighting="paper")),
            camera, width, height, backend=backend,
        )  # fmt: skip
        images["marched"] = marched
        errors["splat_vs_marched"] = _relative(splat, marched, marched[..., 3] > 0.05)
    return {"images": images, "errors": errors}


def blob_transmittance(
    cloud: ParticleCloud, direction: Sequence[float], include_self: bool = False
) -> np.ndarray:
    """``T_k = exp(−∫σ)`` from each particle centre towards ``direction`` through the Gaussian
    blobs (closed form, float64). Without ``include_self`` particle k's own blob is left out:
    the light *incident on* the particle, which is what [H]'s read-back before splatting it
    measures (its own blob would dim its centre by a further e^{−τ_k/2})."""
    from math import erf

    s = np.asarray(check.direction(direction, "direction"), np.float64)
    p = cloud.centres.astype(np.float64)
    if cloud.n > MAX_REFERENCE_PARTICLES:
        raise ValueError(f"at most {MAX_REFERENCE_PARTICLES} particles, got {cloud.n}")
    sk = cloud.radii.astype(np.float64) / 3.0
    tau = cloud.tau.astype(np.float64)
    rel = p[None, :, :] - p[:, None, :]  # [k, j]: blob j seen from point k
    b = rel @ s
    h2 = np.maximum((rel * rel).sum(axis=-1) - b * b, 0.0)
    verf = np.vectorize(erf)
    depth = (
        0.5
        * tau[None, :]
        * np.exp(-h2 / (2 * sk[None, :] ** 2))
        * (1.0 + verf(b / (sk[None, :] * math.sqrt(2.0))))
    )
    if not include_self:
        np.fill_diagonal(depth, 0.0)
    return np.exp(-depth.sum(axis=1))


def light_fidelity(
    cloud: ParticleCloud,
    sun: Sun,
    taus: Sequence[float] = (1.0, 2.0, 4.0, 8.0),
    gammas: Sequence[float] = (1e-4, 0.09, 0.5, 1.0),
    settings: SpriteSettings | None = None,
) -> dict[str, Any]:
    """Error of the light pass against the blobs' exact transmittance, over ``taus`` (every
    particle's τ set to it) and ``gammas`` (the solid angle; γ = 0 is ``forward=False``).

    Per ``(τ, γ)``: ``gain`` = median of i_k/T_k (how much light forward scattering adds over
    Beer–Lambert), ``error`` = median |i_k − T_k|/T_k, ``continuum_error`` = median
    |i_k − T_k^{1−f}|/T_k^{1−f} with ``f = a p_fwd γ/4π`` (how well the continuum limit of §3.1
    describes the discrete pass), on the particles with T_k > 1e−6. Pairs that break the energy
    condition (``f > 1 − e^{−τ}``) are skipped (``None``).
    """
    base = SpriteSettings() if settings is None else settings
    out: dict[str, Any] = {"taus": list(taus), "gammas": [0.0, *gammas], "cases": []}
    for tau in taus:
        pc = ParticleCloud(cloud.centres, cloud.radii, tau, cloud.albedo)
        exact = blob_transmittance(pc, sun.direction)
        keep = exact > 1e-6
        for gamma in [0.0, *gammas]:
            s = SpriteSettings.from_dict(
                {**base.to_dict(), "forward": gamma > 0, "solid_angle": gamma if gamma > 0 else 1.0}
            )
            try:
                light = particle_light(pc, sun, s).light[:, 0].astype(np.float64)
            except ValueError:
                out["cases"].append({"tau": tau, "gamma": gamma, "skipped": "energy"})
                continue
            p_fwd = {"rayleigh": 1.5, "isotropic": 1.0}.get(
                s.phase, (1 + s.hg_g) / (1 - s.hg_g) ** 2
            )
            f = float(cloud.albedo.mean()) * p_fwd * gamma / (4 * math.pi)
            limit = exact ** (1.0 - f)
            out["cases"].append(
                {
                    "tau": tau,
                    "gamma": gamma,
                    "gain": float(np.median(light[keep] / exact[keep])),
                    "error": float(np.median(np.abs(light[keep] - exact[keep]) / exact[keep])),
                    "continuum_error": float(
                        np.median(np.abs(light[keep] - limit[keep]) / limit[keep])
                    ),
                    "mean_light": float(light.mean()),
                    "mean_exact": float(exact.mean()),
                }
            )
    return out
