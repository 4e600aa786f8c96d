"""The paper's noise (Jiménez de Parga & Gómez Palomo 2018, §3.1, eq. 1).

A ``size³`` lattice of uniform values in [0, 1) and its fractal Brownian motion,
``fbm(p) = Σ_{i=1..n} wⁱ · lattice(sⁱ · f · p)``, looked up with the GL texel-centre trilinear
convention so that the GLSL twin in ``shaders/noise.glsl`` agrees.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from cumuli import _core
from cumuli import _validate as check

#: Largest lattice edge accepted (512³ float32 = 512 MiB).
MAX_SIZE = 512


class Noise:
    """A seeded ``size³`` uniform lattice and its fBm.

    Parameters
    ----------
    seed:
        Any non-negative integer below 2⁶⁴; the same seed gives the same lattice on every platform.
    size:
        Lattice edge in texels (the paper uses 64).
    """

    def __init__(self, seed: int = 0, size: int = 64) -> None:
        seed = check.integer(seed, "seed", 0, 2**64 - 1)
        size = check.integer(size, "size", 2, MAX_SIZE)
        self._core = _core.Noise(seed, size)

    @property
    def seed(self) -> int:
        return int(self._core.seed)

    @property
    def size(self) -> int:
        return int(self._core.size)

    @property
    def lattice(self) -> np.ndarray:
        """The lattice as a read-only float32 ``(size, size, size)`` view, indexed ``[z, y, x]``."""
        return self._core.lattice

    def __repr__(self) -> str:
        return f"Noise(seed={self.seed}, size={self.size})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Noise) and (self.seed, self.size) == (other.seed, other.size)

    def __hash__(self) -> int:
        return hash((self.seed, self.size))

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
        pts = check.points3(points, "points")
        params = _fbm_params(octaves, gain, lacunarity, frequency)
        return self._core.fbm(pts, *params, check.threads(threads))

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

        ``shape`` is one int (a cube) or ``(D, H, W)``.
        """
        if isinstance(shape, (int, np.integer)) and not isinstance(shape, bool):
            d = h = w = check.integer(shape, "shape", 1, 2048)
        else:
            if not isinstance(shape, Sequence) or len(shape) != 3:
                raise TypeError(f"shape must be an int or (D, H, W), got {shape!r}")
            d, h, w = (check.integer(v, "shape", 1, 2048) for v in shape)
        if d * h * w > check.MAX_POINTS:
            raise ValueError(f"shape {(d, h, w)} has more than {check.MAX_POINTS} voxels")
        lo = np.array(check.vec3(box_min, "box_min"), dtype=np.float64)
        hi = np.array(check.vec3(box_max, "box_max"), dtype=np.float64)
        if not (hi > lo).all():
            raise ValueError("box_max must be greater than box_min on every axis")
        step = (hi - lo) / np.array([w, h, d])
        xs = lo[0] + (np.arange(w) + 0.5) * step[0]
        ys = lo[1] + (np.arange(h) + 0.5) * step[1]
        zs = lo[2] + (np.arange(d) + 0.5) * step[2]
        z, y, x = np.meshgrid(zs, ys, xs, indexing="ij")
        pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
        return self.fbm(pts, octaves, gain, lacunarity, frequency, threads).reshape(d, h, w)


def _fbm_params(
    octaves: int, gain: float, lacunarity: float, frequency: float
) -> tuple[int, float, float, float]:
    return (
        check.integer(octaves, "octaves", 1, 16),
        check.real(gain, "gain", 0.0, lo_open=True),
        check.real(lacunarity, "lacunarity", 0.0, lo_open=True),
        check.real(frequency, "frequency", 0.0, lo_open=True),
    )
