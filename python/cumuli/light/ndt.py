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
(not the per-voxel definition; its difference from ``"ndt"`` is stated in docs/clouds-2018.md).
See ``cpp/include/cumuli/light/ndt.hpp`` for the exact definition.

A grid is a :class:`LightGrid`: the values, the world box they span, the sun direction and the
:class:`LightRecord` of what they were made from. Its parameters have one home,
:class:`LightParams`, which `light_grid` takes, `cumuli.RenderSettings.light_params` makes and
the record keeps.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal, overload

import numpy as np

from cumuli import _core
from cumuli._util import progress as _progress
from cumuli._util import validate as check
from cumuli.light.grid import (
    DEFAULT_EXTINCTION,
    DEFAULT_SOLID_ANGLE,
    MAX_RESOLUTION,
    MAX_STEPS_PER_RAY,
    METHODS,
    LightGrid,
    LightParams,
    LightRecord,
    primitives_digest,
)
from cumuli.light.memo import remember
from cumuli.light.moved import moved_box
from cumuli.model.cloud import Cloud
from cumuli.noise import Noise
from cumuli.sky import Sun

__all__ = [
    "DEFAULT_EXTINCTION", "DEFAULT_SOLID_ANGLE", "MAX_RESOLUTION", "MAX_STEPS_PER_RAY", "METHODS",
    "LightGrid", "LightParams", "LightRecord", "LightStats", "light_grid", "light_params",
    "primitives_digest",
]  # fmt: skip


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


def _sun_direction(sun: Any) -> tuple[float, float, float]:
    if isinstance(sun, Sun):
        return check.direction(sun.direction, "sun.direction")
    if isinstance(sun, (Sequence, np.ndarray)) and not isinstance(sun, str):
        return check.direction(sun, "sun")
    raise TypeError(f"sun must be a cumuli.Sun or a direction (x, y, z), got {type(sun).__name__}")


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
) -> LightRecord:
    """The :class:`LightRecord` of the grid `light_grid` makes with these arguments."""
    params = LightParams(
        resolution, method, step, extinction, solid_angle, octaves, gain, lacunarity, frequency,
        density_override, kappa,
    )  # fmt: skip
    return LightRecord.of(cloud, noise, params)


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
    *,
    params: LightParams | None = ...,
    progress: bool | None = ...,
) -> LightGrid: ...


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
    params: LightParams | None = ...,
    progress: bool | None = ...,
) -> tuple[LightGrid, LightStats]: ...


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
    *,
    params: LightParams | None = None,
    progress: bool | None = None,
) -> LightGrid | tuple[LightGrid, LightStats]:
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
    resolution, method, step, extinction, solid_angle, octaves, gain, lacunarity, frequency,
    density_override:
        The fields of :class:`LightParams` (ignored when ``params`` is given): voxels per axis (one
        int or ``(x, y, z)``, each in ``[2, MAX_RESOLUTION]``); ``"ndt"`` (no duplicate tracing,
        default), ``"naive"`` (every candidate interval in full) or ``"shared"`` (samples shared
        along sun-parallel lines: each line of a grid sheared along the sun is marched once with a
        step ``Δ' = λ/round(λ/Δ)`` that puts a sample boundary on every voxel layer, ``λ`` the layer
        spacing along the line; a voxel's ``L`` is the bilinear blend of the four lines around it on
        its layer; on the default cumulus it differs from ``"ndt"``'s grid by a mean ``|ΔL|`` ≈
        0.01–0.02 and at most ≈ 0.2–0.3 at sharp shadow edges); the march step Δ (the light-box
        diagonal / step must not exceed ``MAX_STEPS_PER_RAY``); ``A`` of eq. (3), ``σ = ρ·A`` per
        world unit (:data:`DEFAULT_EXTINCTION`); ``γ`` of eq. (6) in steradians (``C = ½·γ/4π``);
        the fBm ``n, w, s, f`` of eq. (1) — the defaults are those of :meth:`cumuli.Noise.fbm` (``f
        = 1`` texel per unit), not :class:`cumuli.RenderSettings`' (``f = 0.3``, ``A = 1``): for the
        grid a scene renders with, pass ``params=settings.light_params()``; and a constant density
        ``≥ 0`` replacing fBm (a test/analysis hook; eq. 2's gating still applies to spheroids).
    return_stats:
        Also return a :class:`LightStats` (samples marched, total and per voxel; seconds).
    threads:
        Threads for the march (0 = all cores). The grid does not depend on it.
    params:
        A :class:`LightParams` (its ``kappa``, when set, overrides the cloud's κ).
    progress:
        A progress bar when the march takes more than a few seconds (``None``: unless
        ``CUMULI_PROGRESS=0``; ``False``: never). See docs/conventions.md, "Progress".

    Returns
    -------
    A :class:`LightGrid` (an ``(Rz, Ry, Rx)`` float32 array indexed ``[z, y, x]`` with its ``box``,
    ``sun`` and ``record``; and the stats if asked). The grid covers the cloud's primitives grown
    by the candidate scale (1 for spheroids, √N for metaballs), padded by half a voxel so that the
    outermost voxel centres lie on that box. Nothing is stored on the cloud.
    """
    if not isinstance(cloud, Cloud):
        raise TypeError(f"cloud must be a cumuli.Cloud, got {type(cloud).__name__}")
    sun_dir = _sun_direction(sun)
    if noise is not None and not isinstance(noise, Noise):
        raise TypeError(f"noise must be a cumuli.Noise or None, got {type(noise).__name__}")
    if params is None:
        params = LightParams(
            resolution, method, step, extinction, solid_angle, octaves, gain, lacunarity,
            frequency, density_override,
        )  # fmt: skip
    elif not isinstance(params, LightParams):
        raise TypeError(f"params must be a cumuli.LightParams, got {type(params).__name__}")
    if params.density_override is None and noise is None:
        raise ValueError("noise is required unless density_override is given")
    nthreads = check.threads(threads)
    target = cloud
    if params.kappa is not None and cloud.model == "spheroid" and params.kappa != cloud.kappa:
        target = cloud.with_model("spheroid", kappa=params.kappa)
    p = params
    constant = -1.0 if p.density_override is None else p.density_override
    with _progress.core("light grid", progress):
        out = _core.light_grid(
            _core.CloudShape(*target.core_args()),
            noise._core if noise is not None else None,
            sun_dir,
            p.resolution,
            p.method,
            p.step,
            p.extinction,
            p.solid_angle,
            _core.FbmParams(p.octaves, p.gain, p.lacunarity, p.frequency),
            constant,
            nthreads,
        )
    values, samples, lo, hi, total, seconds = out
    grid = LightGrid(values, (tuple(lo), tuple(hi)), sun_dir, LightRecord.of(cloud, noise, p))
    if return_stats:
        return grid, LightStats(p.method, int(total), samples, float(seconds))
    return grid


# --- the light pass of the kind (cumuli.kinds.cloud) -------------------------------------
def cloud_light(cloud: Cloud, scene: Any, given: Any = None, threads: int = 0) -> LightGrid:
    """The NDT light grid `cloud` renders with in ``scene`` (see the module docstring)."""
    params = scene.settings.light_params()
    sun = scene.sun.direction
    if given is not None:
        if not isinstance(given, LightGrid):
            raise TypeError(
                f"the light of a Cloud must be a cumuli.LightGrid, got {type(given).__name__}"
            )
        if given.record is None:
            # Made by hand: trusted as it is, unless it says it was made for another sun.
            if given.sun is None or np.allclose(given.sun, sun, rtol=0, atol=1e-6):
                return given
        elif np.allclose(given.sun, sun, rtol=0, atol=1e-6) and given.record == LightRecord.of(
            cloud, scene.noise, params
        ):
            return given
    record = LightRecord.of(cloud, scene.noise, params)
    if any(cloud.offset):
        # The wind carries the cloud with its noise: its grid is its still self's, moved (one
        # light pass for every time of it).
        grid = cloud_light(cloud.still(), scene, None, threads)
        box = moved_box(grid.box, cloud.offset)
        return LightGrid(np.asarray(grid), box, grid.sun, record)
    return remember(
        ("cloud", record, sun),
        lambda: light_grid(cloud, scene.sun, scene.noise, params=params, threads=threads),
    )
