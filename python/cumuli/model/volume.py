"""Density volumes: the database of an endless animation (Iwasaki, Nishino & Dobashi 2011, §3).

A :class:`VolumeDatabase` holds ``N`` successive density volumes ``(N, D, H, W)`` (``[z, y, x]``,
float32) over one world box. :func:`evolving_cloud_volumes` makes one without a fluid solver: a
:class:`~cumuli.Cloud` whose primitives grow and drift while the noise domain is advected by a
wind, voxelised frame by frame in C++.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli import _core
from cumuli import _validate as check
from cumuli.model.cloud import Cloud
from cumuli.noise import Noise, _fbm_params

#: Largest edge of a database volume.
MAX_EDGE = 2048
#: Most volumes a database may hold.
MAX_VOLUMES = 1 << 16


def _box(
    box_min: Any, box_max: Any
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    lo = check.vec3(box_min, "box_min")
    hi = check.vec3(box_max, "box_max")
    if not all(h > lo_ for lo_, h in zip(lo, hi, strict=True)):
        raise ValueError(f"box_max must be greater than box_min on every axis, got {lo}, {hi}")
    return lo, hi


def _volume_shape(value: Any, name: str) -> tuple[int, int, int]:
    """One int (a cube) or ``(D, H, W)``."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        n = check.integer(value, name, 1, MAX_EDGE)
        return (n, n, n)
    if isinstance(value, Sequence) and len(value) == 3:
        d, h, w = (check.integer(v, name, 1, MAX_EDGE) for v in value)
        return (d, h, w)
    raise TypeError(f"{name} must be an int or (D, H, W), got {value!r}")


def _float_volumes(value: Any, name: str, ndim: int) -> np.ndarray:
    """Validate an array of volumes: dtype, shape and size before converting, then finiteness."""
    if not isinstance(value, np.ndarray):
        try:
            value = np.asarray(value)
        except Exception as exc:
            raise TypeError(f"{name} must be a numeric array: {exc}") from None
    if value.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a real numeric array, got dtype {value.dtype}")
    if value.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimensions, got shape {value.shape}")
    if any(s < 1 for s in value.shape):
        raise ValueError(f"{name} must not be empty, got shape {value.shape}")
    if any(s > MAX_EDGE for s in value.shape[-3:]):
        raise ValueError(f"{name}: every edge must be <= {MAX_EDGE}, got shape {value.shape}")
    if int(np.prod(value.shape, dtype=np.int64)) > check.MAX_POINTS:
        raise ValueError(f"{name} has more than {check.MAX_POINTS} values, got shape {value.shape}")
    arr = np.ascontiguousarray(value, dtype=np.float32)
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


class VolumeDatabase:
    """``N`` successive density volumes ``(N, D, H, W)`` float32 over the world box.

    Volumes are indexed ``[z, y, x]``; voxel centres sit at ``box_min + (i + ½)·size/shape``.
    Densities must be finite and non-negative. The similarity matrix is computed on first use.
    """

    def __init__(self, volumes: Any, box_min: Sequence[float], box_max: Sequence[float]) -> None:
        if isinstance(volumes, np.ndarray) and volumes.ndim == 4 and volumes.shape[0] > MAX_VOLUMES:
            raise ValueError(f"volumes: at most {MAX_VOLUMES} volumes, got {volumes.shape[0]}")
        arr = _float_volumes(volumes, "volumes", 4)
        if arr.shape[0] > MAX_VOLUMES:
            raise ValueError(f"volumes: at most {MAX_VOLUMES} volumes, got {arr.shape[0]}")
        if (arr < 0).any():
            raise ValueError("volumes must not hold negative densities")
        arr.setflags(write=False)
        self._volumes = arr
        self.box_min, self.box_max = _box(box_min, box_max)
        self._similarity: np.ndarray | None = None

    @property
    def volumes(self) -> np.ndarray:
        """The read-only ``(N, D, H, W)`` float32 volumes."""
        return self._volumes

    @property
    def n(self) -> int:
        return int(self._volumes.shape[0])

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, i: int) -> np.ndarray:
        return self._volumes[i]

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(D, H, W)`` of one volume."""
        return tuple(int(s) for s in self._volumes.shape[1:])  # type: ignore[return-value]

    @property
    def box(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        return (self.box_min, self.box_max)

    def similarity(self, threads: int = 0) -> np.ndarray:
        """``D_kl = Σₙ (ρ_k − ρ_l)²``: the ``(N, N)`` float64 matrix (C++, cached, read-only)."""
        if self._similarity is None:
            d = _core.similarity_matrix(self._volumes, check.threads(threads))
            d.setflags(write=False)
            self._similarity = d
        return self._similarity

    def __repr__(self) -> str:
        return f"VolumeDatabase(n={self.n}, shape={self.shape}, box={self.box})"


@dataclass(frozen=True)
class AnimationFrame:
    """One displayed frame: ``density = weight·ρ[source] + (1 − weight)·ρ[target]``."""

    index: int
    source: int
    target: int
    weight: float
    crossfade: bool
    density: np.ndarray | None = None


def evolving_cloud_volumes(
    cloud: Cloud,
    noise: Noise | None,
    n_frames: int,
    resolution: int | Sequence[int] = 32,
    *,
    growth: float = 0.2,
    drift: Sequence[float] = (0.0, 0.0, 0.0),
    jitter: float = 0.02,
    wind: Sequence[float] = (0.06, 0.02, 0.0),
    density_scale: float = 1.0,
    box: tuple[Sequence[float], Sequence[float]] | None = None,
    padding: float = 0.05,
    seed: int = 0,
    constant: float | None = None,
    octaves: int = 5,
    gain: float = 0.5,
    lacunarity: float = 2.0,
    frequency: float = 1.0,
    threads: int = 0,
) -> VolumeDatabase:
    """A database of ``n_frames`` volumes of an evolving cumulus, without a fluid solver.

    At frame ``t`` (of ``T = n_frames``) every radius is scaled by ``1 + growth·t/(T − 1)``, each
    primitive moves by ``t·(drift + jitter·uⱼ)`` (``uⱼ`` a seeded standard-normal 3-vector per
    primitive) and the fBm is sampled at ``p − t·wind`` (the noise domain advected by the wind).
    Rates are per frame, in world units, so small rates make successive volumes similar. The
    cloud's own density model (eq. 2 or eqs. 19–21) fills the voxels: each ``x``-row of voxels is a
    ray through the sorted primitive candidates and a voxel takes the largest ``cloud_density``
    of the candidates that contain it. ``resolution`` is one int or ``(D, H, W)``; ``box`` defaults
    to the bounds of every frame, padded by ``padding`` × the extent. ``noise=None`` with
    ``constant`` fills the primitives with a constant density (analytic tests). C++ on
    ``threads`` threads without the GIL; the result does not depend on the thread count.
    """
    if not isinstance(cloud, Cloud):
        raise TypeError(f"cloud must be a cumuli.Cloud, got {type(cloud).__name__}")
    if (noise is None) == (constant is None):
        raise ValueError("give exactly one of noise or constant")
    core_noise = None
    const = -1.0
    if noise is not None:
        if not isinstance(noise, Noise):
            raise TypeError(f"noise must be a cumuli.Noise, got {type(noise).__name__}")
        core_noise = noise._core
    else:
        const = check.real(constant, "constant", 0.0)
    n_frames = check.integer(n_frames, "n_frames", 1, MAX_VOLUMES)
    d, h, w = _volume_shape(resolution, "resolution")
    if n_frames * d * h * w > check.MAX_POINTS:
        raise ValueError(
            f"n_frames × resolution = {n_frames} × {(d, h, w)} exceeds {check.MAX_POINTS} voxels"
        )
    growth = check.real(growth, "growth", -1.0, lo_open=True)
    drift3 = check.vec3(drift, "drift")
    jitter = check.real(jitter, "jitter", 0.0)
    wind3 = check.vec3(wind, "wind")
    density_scale = check.real(density_scale, "density_scale", 0.0)
    padding = check.real(padding, "padding", 0.0, 10.0)
    seed = check.integer(seed, "seed", 0, 2**64 - 1)
    fbm = _fbm_params(octaves, gain, lacunarity, frequency)
    res = [w, h, d]
    evo = (n_frames, res, growth, drift3, jitter, wind3, density_scale, padding, seed)
    if box is None:
        lo, hi = _core.evolving_cloud_box(*cloud.core_args(), *evo)
        lo, hi = _box(lo, hi)
    else:
        if not isinstance(box, Sequence) or len(box) != 2:
            raise TypeError("box must be (box_min, box_max)")
        lo, hi = _box(box[0], box[1])
    vols = _core.evolving_cloud_volumes(
        *cloud.core_args(), core_noise, const, *fbm, *evo, lo, hi, check.threads(threads)
    )
    return VolumeDatabase(vols, lo, hi)
