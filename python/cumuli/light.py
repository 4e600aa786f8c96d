"""Light pass: the per-cloud voxel grid of precomputed sun light (Jiménez de Parga 2018, §3.3–3.5).

For every voxel centre ``v`` a ray leaves ``v`` towards the sun and marches the cloud's candidate
intervals (the primitives it meets, sorted by entry) with step ``Δ``. Each sample sits at the
midpoint of its segment ``[t, min(t + Δ, t_out)]`` (the last segment of an interval is truncated,
so the segments tile the intervals exactly). With ``σ = ρ·A`` (eq. 3), ``T_i`` the transmittance
from ``v`` to the far end of segment ``i`` (``T_0 = 1``) and ``C = ½·γ_solid/4π`` (eq. 6)::

    L(v) = Σ_{i: ρ_i > 0} C · (ℓ_i/Δ) · T_{i−1}  +  I₀ · T_D        (eq. 7, I₀ = 1)

``method="ndt"`` (Algorithm 2, "no duplicate tracing") marches every point of the union of the
intervals once, attributing a sample to the covering primitive with the smallest ``|q|``;
``method="naive"`` marches every interval in full, overlaps twice, as the paper's baseline;
``method="shared"`` shares samples between voxels: each sun-parallel line of a grid sheared along
the sun is marched once (as NDT marches a ray) and every voxel blends the four lines around it
(not the per-voxel definition; its difference from ``"ndt"`` is stated in the README).
See ``cpp/include/cumuli/lighting.hpp`` for the exact definition.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal, overload

import numpy as np

from cumuli import _core
from cumuli import _validate as check
from cumuli.cloud import Cloud
from cumuli.noise import Noise, _fbm_params
from cumuli.sun import Sun

#: Largest grid edge along any axis.
MAX_RESOLUTION: int = int(_core.LIGHT_MAX_RESOLUTION)
#: A ray may need at most this many steps (light-box diagonal / step); smaller steps are refused.
MAX_STEPS_PER_RAY: int = int(_core.LIGHT_MAX_STEPS_PER_RAY)
#: Default extinction A of eq. (3), per world unit at density 1. Inside a pseudo-spheroid the fBm
#: densities that pass eq. (2)'s gating are ≈ 0.3–0.6, so A = 0.3 gives a mean free path of about
#: 5–10 units: the default cumulus (`gaussian_cumulus`, ≈ 26 units wide, 17 tall) is then 1–3
#: optical depths thick along a sun ray, and its grid spans bright sunlit tops (L ≈ 1) to dim
#: cores (L ≈ 0.1) instead of saturating black (A = 1 leaves most of the interior below 0.01).
DEFAULT_EXTINCTION: float = 0.3
#: Default γ of eq. (6) in steradians (the paper's ≈ 1e-4); the renderer's grids use it too.
DEFAULT_SOLID_ANGLE: float = 1e-4
METHODS = ("ndt", "naive", "shared")


@dataclass(frozen=True)
class LightStats:
    """What a light-grid computation cost."""

    method: str
    #: Samples marched in total (every step inside a candidate interval, empty or not; for
    #: ``"shared"`` every sample once, however many voxels read it).
    samples_total: int
    #: Samples marched for each voxel, ``[z, y, x]`` uint32.
    samples: np.ndarray
    #: Wall time of the C++ march in seconds (validation and allocation excluded).
    seconds: float

    @property
    def samples_per_voxel(self) -> float:
        """Mean samples marched per voxel."""
        return self.samples_total / max(self.samples.size, 1)


def _resolution(value: Any) -> tuple[int, int, int]:
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        n = check.integer(value, "resolution", 2, MAX_RESOLUTION)
        return (n, n, n)
    if isinstance(value, Sequence) and not isinstance(value, str) and len(value) == 3:
        x, y, z = (check.integer(v, "resolution", 2, MAX_RESOLUTION) for v in value)
        return (x, y, z)
    raise TypeError(f"resolution must be an int or three ints (x, y, z), got {value!r}")


def _sun_direction(sun: Any) -> tuple[float, float, float]:
    if isinstance(sun, Sun):
        return check.direction(sun.direction, "sun.direction")
    if isinstance(sun, (Sequence, np.ndarray)) and not isinstance(sun, str):
        return check.direction(sun, "sun")
    raise TypeError(f"sun must be a cumuli.Sun or a direction (x, y, z), got {type(sun).__name__}")


def _f32(value: float) -> float:
    # The core takes float32: record what it was given, so that 0.1 and np.float32(0.1) agree.
    return float(np.float32(value))


def primitives_digest(cloud: Cloud) -> str:
    """A short hash of the cloud's primitive arrays (a grid belongs to these primitives)."""
    h = hashlib.blake2b(digest_size=16)
    for a in (cloud.centres, cloud.radii, cloud.rotations):
        h.update(np.ascontiguousarray(a, dtype=np.float32).tobytes())
    return h.hexdigest()


def light_params(
    cloud: Cloud,
    noise: Noise | None,
    resolution: int | Sequence[int] = 20,
    method: str = "ndt",
    step: float = 0.1,
    extinction: float = DEFAULT_EXTINCTION,
    solid_angle: float = DEFAULT_SOLID_ANGLE,
    octaves: int = 5,
    gain: float = 0.5,
    lacunarity: float = 2.0,
    frequency: float = 1.0,
    density_override: float | None = None,
    kappa: float | None = None,
) -> dict[str, Any]:
    """The record :func:`light_grid` stores as ``cloud.light_params``: what the grid depends on.

    Everything that changes ``L(v)`` except the sun (``cloud.light_sun``): the noise lattice
    (seed, size), fBm ``n, w, s, f``, extinction ``A``, step, method, resolution ``(x, y, z)``,
    solid angle, the density model with its parameter (κ for spheroids, taken from ``kappa`` when
    given, else the cloud's; φ for metaballs), ``density_override`` and a digest of the
    primitives. Only JSON types, so the record survives :meth:`Cloud.save` / :func:`load_cloud`
    unchanged; float parameters are rounded to float32, as the core sees them. The renderer
    compares it with the record its settings would produce (:func:`cumuli.prepare_light`).
    """
    spheroid = cloud.model == "spheroid"
    return {
        "noise_seed": None if noise is None else int(noise.seed),
        "noise_size": None if noise is None else int(noise.size),
        "octaves": int(octaves),
        "gain": _f32(gain),
        "lacunarity": _f32(lacunarity),
        "frequency": _f32(frequency),
        "extinction": _f32(extinction),
        "step": _f32(step),
        "method": str(method),
        "resolution": list(_resolution(resolution)),
        "solid_angle": _f32(solid_angle),
        "model": cloud.model,
        "kappa": _f32(cloud.kappa if kappa is None else kappa) if spheroid else None,
        "phi": None if spheroid else _f32(cloud.phi),
        "density_override": None if density_override is None else _f32(density_override),
        "primitives": primitives_digest(cloud),
    }


@overload
def light_grid(
    cloud: Cloud,
    sun: Sun | Sequence[float],
    noise: Noise | None,
    resolution: int | Sequence[int] = ...,
    method: str = ...,
    step: float = ...,
    extinction: float = ...,
    solid_angle: float = ...,
    octaves: int = ...,
    gain: float = ...,
    lacunarity: float = ...,
    frequency: float = ...,
    density_override: float | None = ...,
    return_stats: Literal[False] = ...,
    threads: int = ...,
    store: bool = ...,
) -> np.ndarray: ...


@overload
def light_grid(
    cloud: Cloud,
    sun: Sun | Sequence[float],
    noise: Noise | None,
    resolution: int | Sequence[int] = ...,
    method: str = ...,
    step: float = ...,
    extinction: float = ...,
    solid_angle: float = ...,
    octaves: int = ...,
    gain: float = ...,
    lacunarity: float = ...,
    frequency: float = ...,
    density_override: float | None = ...,
    *,
    return_stats: Literal[True],
    threads: int = ...,
    store: bool = ...,
) -> tuple[np.ndarray, LightStats]: ...


def light_grid(
    cloud: Cloud,
    sun: Sun | Sequence[float],
    noise: Noise | None,
    resolution: int | Sequence[int] = 20,
    method: str = "ndt",
    step: float = 0.1,
    extinction: float = DEFAULT_EXTINCTION,
    solid_angle: float = DEFAULT_SOLID_ANGLE,
    octaves: int = 5,
    gain: float = 0.5,
    lacunarity: float = 2.0,
    frequency: float = 1.0,
    density_override: float | None = None,
    return_stats: bool = False,
    threads: int = 0,
    store: bool = True,
) -> np.ndarray | tuple[np.ndarray, LightStats]:
    """Precompute the light grid ``L(v)`` of a cloud (first pass of §3.5, Algorithm 2).

    Parameters
    ----------
    cloud:
        The cloud (``"spheroid"`` model with κ, or ``"metaball"``; ellipsoids may be rotated).
    sun:
        A :class:`cumuli.Sun` or a direction towards the sun. Only the direction is used: the grid
        holds light relative to ``I₀ = 1``; the renderer multiplies by the sun's radiance.
    noise:
        The :class:`cumuli.Noise` whose fBm (eq. 1) is the density. May be ``None`` only with
        ``density_override``.
    resolution:
        Voxels per axis: one int (a cube) or ``(x, y, z)``, each in ``[2, MAX_RESOLUTION]``.
    method:
        ``"ndt"`` (no duplicate tracing, default), ``"naive"`` (every candidate interval in full)
        or ``"shared"`` (samples shared along sun-parallel lines: each line of a grid sheared
        along the sun is marched once with a step ``Δ' = λ/round(λ/Δ)`` that puts a sample
        boundary on every voxel layer, ``λ`` the layer spacing along the line; a voxel's ``L`` is
        the bilinear blend of the four lines around it on its layer. On the default cumulus the
        grid differs from ``"ndt"``'s by a mean ``|ΔL|`` ≈ 0.01–0.02 and at most ≈ 0.2–0.3 at
        sharp shadow edges; ``stats.samples`` then counts, per voxel, the samples of its nearest
        line from the voxel towards the sun).
    step:
        March step ``Δ`` in world units (``> 0``; the light-box diagonal / step must not exceed
        ``MAX_STEPS_PER_RAY``).
    extinction:
        ``A`` of eq. (3), ``σ = ρ·A`` per world unit; see :data:`DEFAULT_EXTINCTION`.
    solid_angle:
        ``γ`` of eq. (6) in steradians (the paper's ≈ 1e-4); the scattering constant is
        ``C = ½·γ/4π``.
    octaves, gain, lacunarity, frequency:
        fBm parameters ``n, w, s, f`` of eq. (1). The defaults (and ``extinction``'s) are those
        of :meth:`cumuli.Noise.fbm` and :meth:`cumuli.Cloud.density` (``f = 1`` texel per
        unit), not :class:`cumuli.RenderSettings`' (``f = 0.3``, ``A = 1``): this is the
        low-level light pass, and the same arguments here and there sample the same density.
        A grid meant for rendering should use the scene's values,
        ``light_grid(cloud, sun, noise, **settings.light_grid_kwargs())`` (or let the renderer
        make it): a grid whose recorded parameters differ from the settings' is recomputed by
        the renderer, never used as it is.
    density_override:
        Test/analysis hook: a constant density ``≥ 0`` replacing fBm everywhere (eq. 2's gating
        still applies to spheroids). Not for rendering.
    return_stats:
        Also return a :class:`LightStats` (samples marched, total and per voxel; seconds).
    threads:
        Threads for the march (0 = all cores). The grid does not depend on it.
    store:
        Record the result on the cloud: ``cloud.light`` (the grid), ``cloud.light_box``
        (``(lo, hi)``; voxel ``(i, j, k)``'s centre is ``lo + ((i, j, k) + 0.5)·(hi − lo)/R``),
        ``cloud.light_sun`` (the normalised sun direction used) and ``cloud.light_params``
        (everything else the grid depends on, see :func:`light_params`); the renderer
        recomputes a grid whose sun or parameters differ from the scene's.

    Returns
    -------
    ``(Rz, Ry, Rx)`` float32 array indexed ``[z, y, x]`` (and the stats if asked). The grid covers
    the cloud's primitives grown by the candidate scale (1 for spheroids, √N for metaballs),
    padded by half a voxel so that the outermost voxel centres lie on that box.
    """
    if not isinstance(cloud, Cloud):
        raise TypeError(f"cloud must be a cumuli.Cloud, got {type(cloud).__name__}")
    sun_dir = _sun_direction(sun)
    if noise is not None and not isinstance(noise, Noise):
        raise TypeError(f"noise must be a cumuli.Noise or None, got {type(noise).__name__}")
    res = _resolution(resolution)
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    step = check.real(step, "step", 0.0, lo_open=True)
    extinction = check.real(extinction, "extinction", 0.0)
    solid_angle = check.real(solid_angle, "solid_angle", 0.0, 4.0 * np.pi)
    fbm = _fbm_params(octaves, gain, lacunarity, frequency)
    if density_override is None:
        constant = -1.0
        if noise is None:
            raise ValueError("noise is required unless density_override is given")
    else:
        constant = check.real(density_override, "density_override", 0.0)
    nthreads = check.threads(threads)
    if not isinstance(store, bool):
        raise TypeError(f"store must be a bool, got {type(store).__name__}")

    grid, samples, lo, hi, total, seconds = _core.light_grid(
        *cloud.core_args(),
        noise._core if noise is not None else None,
        sun_dir,
        res,
        method,
        step,
        extinction,
        solid_angle,
        *fbm,
        constant,
        nthreads,
    )
    if store:
        cloud.light = grid
        cloud.light_box = (tuple(lo), tuple(hi))
        cloud.light_sun = sun_dir
        # Last: assigning light / light_box clears the record (a hand-set grid has none).
        cloud.light_params = light_params(
            cloud,
            noise,
            res,
            method,
            step,
            extinction,
            solid_angle,
            *fbm,
            None if density_override is None else constant,
        )
    if return_stats:
        return grid, LightStats(method, int(total), samples, float(seconds))
    return grid
