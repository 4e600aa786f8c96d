"""The paper's noise (Jiménez de Parga & Gómez Palomo 2018, §3.1, eq. 1).

A ``size³`` lattice of uniform values in [0, 1) and its fractal Brownian motion,
``fbm(p) = Σ_{i=1..n} wⁱ · lattice(sⁱ · f · p)``, looked up with the GL texel-centre trilinear
convention so that the GLSL twin in ``shaders/common/noise.glsl`` agrees. The lattice's values
come from the seed in one of two ways (`NOISE_VERSIONS`): version 2, the hash, is the default;
version 1, the table, is the paper's noise (`PAPER_VERSION`).
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Sequence

import numpy as np

from cumuli import _core
from cumuli._util import budget
from cumuli._util import validate as check

#: Largest lattice edge accepted: 512³ float32 is 512 MiB, and the core keeps a second,
#: padded (size + 1)³ copy for its lookups, so about 1 GiB in all.
MAX_SIZE = 512
#: Largest edge of a `Noise.fbm_grid` volume.
MAX_GRID_EDGE = 2048
#: Voxels `Noise.fbm_grid` evaluates per call of the core (whole z planes, at least one): bounds
#: its float32 point buffer to ~48 MiB, however large the volume.
GRID_SLAB_VOXELS = 1 << 22
#: SIMD levels the core knows, narrowest first (see :func:`simd_level`).
SIMD_LEVELS = ("scalar", "avx2", "avx512")
#: How the wide kernels can read the lattice (see :func:`simd_fetch`).
SIMD_FETCHES = ("gather", "loads", "cells")

#: The noise versions (how the lattice's values are made from the seed; see docs/clouds-2018.md,
#: "Noise versions"): 1 draws them from the seed's random stream and the fast kernels read them
#: from a table (the paper's noise); 2 hashes each texel's index with a key of the seed, which the
#: fast kernels compute instead of reading.
NOISE_VERSIONS = {1: "table", 2: "hash"}
#: The version `Noise` makes when none is given: 2, the hash (the faster fBm).
DEFAULT_VERSION = 2
#: The paper's noise, version 1 (the table): the paper's figures, benchmarks and reference images
#: pin it, and scene and light-grid files written before noise versions existed hold it.
PAPER_VERSION = 1

#: Largest magnitude allowed for the lattice coordinates ``p · f · sⁱ`` and for the fBm sum: the
#: core works in float32, where they overflow to inf (and the lookup gives NaN) at 3.4e38.
MAX_FBM_MAGNITUDE = 1e37


def simd_level() -> str:
    """The SIMD level the core's bulk fBm uses now: ``"scalar"``, ``"avx2"`` or ``"avx512"``.

    Chosen at run time from the CPU (the widest it supports), unless the environment variable
    ``CUMULI_SIMD`` (read at first use) or :func:`set_simd_level` says otherwise. Every level gives
    bit-identical results; only the speed differs.
    """
    return str(_core.simd_level())


def simd_levels() -> list[str]:
    """The SIMD levels this CPU and build support, narrowest first (``"scalar"`` always)."""
    return [str(v) for v in _core.simd_levels()]


def set_simd_level(level: str) -> None:
    """Make the core's bulk fBm use ``level`` from now on (all threads), e.g. to compare paths.

    ``"auto"`` goes back to ``CUMULI_SIMD`` or the widest supported level. A level this CPU
    lacks raises ``ValueError``.
    """
    if not isinstance(level, str) or level not in (*SIMD_LEVELS, "auto"):
        raise ValueError(f"level must be one of {(*SIMD_LEVELS, 'auto')}, got {level!r}")
    _core.set_simd_level(level)


def simd_fetch() -> str:
    """How the wide fBm kernels read a cell's lattice values now: ``"gather"``, ``"loads"`` or
    ``"cells"``.

    All three give the same bits. ``"gather"`` reads each row's corner pairs with the CPU's gather
    instructions, ``"loads"`` with plain 64-bit loads from an index array, ``"cells"`` reads a
    cell's eight corners as one 32-byte load from a table that stores every cell whole (4.4 MB at
    size 64; lattices above 64 have none and read as ``"loads"``). The default is
    :func:`preferred_simd_fetch` (``"cells"`` on AMD, ``"gather"`` elsewhere), unless
    ``CUMULI_SIMD_FETCH`` (read at first use) or :func:`set_simd_fetch` says otherwise.
    """
    return str(_core.simd_fetch())


def preferred_simd_fetch() -> str:
    """The lattice fetch this CPU runs fastest where measured (``benchmarks/bench_noise.py``):
    ``"cells"`` on AMD (slow gathers, near L3), ``"gather"`` elsewhere (Intel: fast gathers from a
    lattice that stays in L2)."""
    return str(_core.simd_fetch_preferred())


def set_simd_fetch(fetch: str) -> None:
    """Make the wide fBm kernels read the lattice with ``fetch`` from now on (all threads).

    ``"auto"`` goes back to ``CUMULI_SIMD_FETCH`` or :func:`preferred_simd_fetch`.
    """
    if not isinstance(fetch, str) or fetch not in (*SIMD_FETCHES, "auto"):
        raise ValueError(f"fetch must be one of {(*SIMD_FETCHES, 'auto')}, got {fetch!r}")
    _core.set_simd_fetch(fetch)


_env_fetch = os.environ.get("CUMULI_SIMD_FETCH", "")
if _env_fetch not in ("", "auto", *SIMD_FETCHES):
    warnings.warn(
        f"CUMULI_SIMD_FETCH={_env_fetch!r} is not one of {('auto', *SIMD_FETCHES)}; "
        f"using {simd_fetch()!r}",
        RuntimeWarning,
        stacklevel=2,
    )

_env_simd = os.environ.get("CUMULI_SIMD", "")
if _env_simd not in ("", "auto", *SIMD_LEVELS):
    warnings.warn(
        f"CUMULI_SIMD={_env_simd!r} is not one of {('auto', *SIMD_LEVELS)}; using {simd_level()!r}",
        RuntimeWarning,
        stacklevel=2,
    )


class Noise:
    """A seeded ``size³`` uniform lattice and its fBm.

    Parameters
    ----------
    seed:
        Any non-negative integer below 2⁶⁴; the same seed gives the same lattice on every platform.
    size:
        Lattice edge in texels (the paper uses 64).
    version:
        How the lattice values are made (`NOISE_VERSIONS`): 2, the hash and the default (each
        texel's value hashed from the seed and its index; the faster fBm on AVX2 / AVX-512 CPUs),
        or 1, the table (drawn from the seed's random stream: the paper's noise, which its figures
        and every result made before version 2 became the default use). Both are the same
        uniform distribution with different values. A version outside `NOISE_VERSIONS` raises
        ``ValueError``.
    """

    def __init__(self, seed: int = 0, size: int = 64, version: int = DEFAULT_VERSION) -> None:
        seed = check.integer(seed, "seed", 0, 2**64 - 1)
        size = check.integer(size, "size", 2, MAX_SIZE)
        if isinstance(version, bool) or not isinstance(version, (int, np.integer)):
            raise TypeError(f"version must be an int, got {type(version).__name__}")
        if int(version) not in NOISE_VERSIONS:
            raise ValueError(
                f"version must be one of {sorted(NOISE_VERSIONS)} "
                f"({', '.join(f'{k}: {v}' for k, v in NOISE_VERSIONS.items())}), got {version}"
            )
        budget.check_memory(f"Noise(size={size})'s lattice", 4 * size**3)  # float32
        self._core = _core.Noise(seed, size, int(version))

    @property
    def seed(self) -> int:
        return int(self._core.seed)

    @property
    def size(self) -> int:
        return int(self._core.size)

    @property
    def version(self) -> int:
        """The noise version (`NOISE_VERSIONS`): 1 table, 2 hash."""
        return int(self._core.version)

    @property
    def key(self) -> int:
        """The 32-bit key version 2 hashes texel indices with (derived from the seed; the GLSL
        twin receives it as a uniform)."""
        return int(self._core.key)

    @property
    def has_cells(self) -> bool:
        """Whether the wide kernels can read this lattice's cells whole (the ``"cells"`` fetch,
        :func:`simd_fetch`): power-of-two sizes up to 64; others read as ``"loads"``."""
        return bool(self._core.has_cells)

    @property
    def lattice(self) -> np.ndarray:
        """The lattice as a read-only float32 ``(size, size, size)`` view, indexed ``[z, y, x]``."""
        return self._core.lattice

    def __repr__(self) -> str:
        return f"Noise(seed={self.seed}, size={self.size}, version={self.version})"

    @property
    def identity(self) -> tuple[int, int, int]:
        """``(seed, size, version)``: what fixes the lattice (for cache keys)."""
        return (self.seed, self.size, self.version)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Noise) and self.identity == other.identity

    def __hash__(self) -> int:
        return hash(self.identity)

    def fbm(
        self,
        points: np.ndarray,
        octaves: int = 5,
        gain: float = 0.5,
        lacunarity: float = 2.0,
        frequency: float = 1.0,
        threads: int = 0,
    ) -> np.ndarray:
        """fBm (eq. 1) at ``(N, 3)`` world points; returns ``(N,)`` float32.

        ``frequency`` is in lattice texels per world unit. Runs on ``threads`` threads
        (0 = all cores) without the GIL; the result does not depend on the thread count.
        """
        pts = check.points3_unscanned(points, "points")
        params = _fbm_params(octaves, gain, lacunarity, frequency)
        # The core reports the points' largest |coordinate| (NaN: one is not finite) from the
        # pass that evaluates them; bad input has then cost one evaluation and is refused here.
        out, biggest = self._core.fbm_scan(pts, *params, check.threads(threads))
        if not math.isfinite(biggest):
            raise ValueError("points contains NaN or infinite values")
        check_fbm_reach(biggest, params, "points")
        return out

    def fbm_grid(
        self,
        shape: int | Sequence[int],
        box_min: Sequence[float],
        box_max: Sequence[float],
        octaves: int = 5,
        gain: float = 0.5,
        lacunarity: float = 2.0,
        frequency: float = 1.0,
        threads: int = 0,
    ) -> np.ndarray:
        """fBm at the voxel centres of a box: a ``(D, H, W)`` float32 volume indexed ``[z, y, x]``.

        ``shape`` is one int (a cube) or ``(D, H, W)``, each edge at most `MAX_GRID_EDGE` and at
        most ``MAX_POINTS`` voxels in all (checked before anything is allocated); the box's voxel
        centres must be finite in float32. Memory is the
        output plus a fixed-size buffer: the volume is filled in slabs of whole z planes
        (`GRID_SLAB_VOXELS` voxels a slab), each one call of the core.
        """
        if isinstance(shape, (int, np.integer)) and not isinstance(shape, bool):
            d = h = w = check.integer(shape, "shape", 1, MAX_GRID_EDGE)
        else:
            if not isinstance(shape, Sequence) or len(shape) != 3:
                raise TypeError(f"shape must be an int or (D, H, W), got {shape!r}")
            d, h, w = (check.integer(v, "shape", 1, MAX_GRID_EDGE) for v in shape)
        if d * h * w > check.MAX_POINTS:
            raise ValueError(f"shape {(d, h, w)} has more than {check.MAX_POINTS} voxels")
        budget.check_memory(f"fbm_grid of shape {(d, h, w)}", 4 * d * h * w)  # float32 out
        lo = np.array(check.vec3(box_min, "box_min"), dtype=np.float64)
        hi = np.array(check.vec3(box_max, "box_max"), dtype=np.float64)
        if not (hi > lo).all():
            raise ValueError("box_max must be greater than box_min on every axis")
        params = _fbm_params(octaves, gain, lacunarity, frequency)
        threads = check.threads(threads)
        # Voxel centres per axis, in float64 then rounded once to float32: the same values as
        # rounding a float64 meshgrid of them, without its (D, H, W, 3) float64 arrays.
        step = (hi - lo) / np.array([w, h, d])
        with np.errstate(over="ignore", invalid="ignore"):
            xs, ys, zs = (
                (lo[k] + (np.arange(n) + 0.5) * step[k]).astype(np.float32)
                for k, n in enumerate((w, h, d))
            )
        if not all(np.isfinite(a).all() for a in (xs, ys, zs)):
            raise ValueError("box_min and box_max must lie within the float32 range")
        corners = np.array([[xs[0], ys[0], zs[0]], [xs[-1], ys[-1], zs[-1]]], dtype=np.float32)
        check_fbm_reach(float(np.abs(corners).max()), params, "box_min/box_max")
        out = np.empty((d, h, w), dtype=np.float32)
        planes = max(1, min(d, GRID_SLAB_VOXELS // (h * w)))
        pts = np.empty((planes, h, w, 3), dtype=np.float32)
        pts[..., 0] = xs
        pts[..., 1] = ys[:, None]
        for z0 in range(0, d, planes):
            n = min(planes, d - z0)
            pts[:n, ..., 2] = zs[z0 : z0 + n, None, None]
            slab = self._core.fbm(pts[:n].reshape(-1, 3), *params, threads)
            out[z0 : z0 + n] = slab.reshape(n, h, w)
        return out


def _log10_max_scale(octaves: int, factor: float) -> float:
    """log10 of the largest ``factorⁱ`` for i = 1..octaves (the first or the last one)."""
    return max(math.log10(factor), octaves * math.log10(factor))


def _fbm_params(
    octaves: int, gain: float, lacunarity: float, frequency: float
) -> tuple[int, float, float, float]:
    """Checked ``(octaves, gain, lacunarity, frequency)``; refuses combinations whose octave
    weights or scales (``gainⁱ``, ``frequency · lacunarityⁱ``) overflow float32."""
    octaves = check.integer(octaves, "octaves", 1, 16)
    gain = check.real(gain, "gain", 0.0, lo_open=True)
    lacunarity = check.real(lacunarity, "lacunarity", 0.0, lo_open=True)
    frequency = check.real(frequency, "frequency", 0.0, lo_open=True)
    limit = math.log10(MAX_FBM_MAGNITUDE)
    # The sum of the weights is at most octaves times the largest.
    if math.log10(octaves) + _log10_max_scale(octaves, gain) > limit:
        raise ValueError(
            f"gain {gain} over {octaves} octaves weights the sum beyond {MAX_FBM_MAGNITUDE:g} "
            "(float32 overflow)"
        )
    if math.log10(frequency) + _log10_max_scale(octaves, lacunarity) > limit:
        raise ValueError(
            f"frequency {frequency} * lacunarity {lacunarity}**{octaves} exceeds "
            f"{MAX_FBM_MAGNITUDE:g} (float32 overflow)"
        )
    return octaves, gain, lacunarity, frequency


def check_fbm_reach(biggest: float, params: tuple[int, float, float, float], name: str) -> None:
    """Refuse points whose largest coordinate magnitude ``biggest`` would overflow float32 in
    the lattice coordinates ``p · frequency · lacunarityⁱ``: the fBm would come out NaN for
    finite input."""
    if biggest == 0.0:
        return
    octaves, _, lacunarity, frequency = params
    reach = math.log10(biggest) + math.log10(frequency) + _log10_max_scale(octaves, lacunarity)
    if reach > math.log10(MAX_FBM_MAGNITUDE):
        raise ValueError(
            f"{name}: a coordinate of magnitude {biggest:.3g} times frequency * "
            f"lacunarity**{octaves} reaches 1e{reach:.1f}, beyond {MAX_FBM_MAGNITUDE:g} "
            "(float32 overflow)"
        )
