"""Endless cloud animation (Iwasaki, Nishino & Dobashi 2011, §3): Video Textures over volumes.

:class:`EndlessAnimation` walks the paper's Markov chain over a :class:`~cumuli.VolumeDatabase`:
the similarity ``D_kl = Σₙ (ρ_k − ρ_l)²``, the transition probability ``P_kl ∝ exp(−D_{k+1,l}/σ)``
and a cross-dissolve over ``H`` frames at every jump (``ρ = w ρᵢ + (1 − w) ρⱼ``, ``w`` going from
1 to 0). Dead ends (Video Textures' term: the last frame, and frames from which every path runs
into it) are pruned, so the walk is endless; the RNG is seeded, so a walk is reproducible.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import progress as _progress
from cumuli._util import validate as check
from cumuli.model import volume as _volume
from cumuli.model.volume import AnimationFrame, VolumeDatabase, _float_volumes

#: Most frames :meth:`EndlessAnimation.frames` returns in one list (each is a Python object;
#: iterate the animation for longer walks).
MAX_FRAME_LIST = 1 << 18


def similarity_matrix(volumes: Any, threads: int = 0) -> np.ndarray:
    """``D_kl = Σₙ (ρ_k − ρ_l)²`` of ``(N, ...)`` volumes: ``(N, N)`` float64 (C++, threaded)."""
    if isinstance(volumes, VolumeDatabase):
        return volumes.similarity(threads)
    if not isinstance(volumes, np.ndarray):
        volumes = np.asarray(volumes)
    if volumes.ndim < 2:
        raise ValueError(f"volumes must have shape (N, ...), got {volumes.shape}")
    _volume.check_similarity_size(volumes.shape[0])
    arr = _float_volumes(volumes, "volumes", volumes.ndim)
    return _core.similarity_matrix(arr, check.threads(threads))


def default_sigma(similarity: np.ndarray, fraction: float = 0.1) -> float:
    """``fraction`` × the mean of the non-zero off-diagonal ``D_kl`` (1 when all are zero)."""
    d = np.asarray(similarity, dtype=np.float64)
    off = d[~np.eye(d.shape[0], dtype=bool)]
    off = off[off > 0]
    return float(fraction * off.mean()) if off.size else 1.0


def _similarity(value: Any) -> np.ndarray:
    if isinstance(value, VolumeDatabase):
        return value.similarity()
    d = np.asarray(value)
    if d.dtype.kind not in "fiu":
        raise TypeError(f"similarity must be a real numeric array, got dtype {d.dtype}")
    if d.ndim != 2 or d.shape[0] != d.shape[1] or d.shape[0] < 1:
        raise ValueError(f"similarity must be a non-empty square (N, N) matrix, got {d.shape}")
    d = np.ascontiguousarray(d, dtype=np.float64)
    if not np.isfinite(d).all() or (d < 0).any():
        raise ValueError("similarity must be finite and non-negative")
    return d


def transition_matrix(similarity: Any, sigma: float | None = None) -> np.ndarray:
    """The paper's ``P_kl = exp(−D_{k+1,l}/σ) / Σ_l exp(−D_{k+1,l}/σ)``: ``(N, N)``, rows sum to 1.

    ``similarity`` is a ``(N, N)`` matrix or a :class:`VolumeDatabase`; ``sigma`` defaults to
    :func:`default_sigma`. The last frame has no successor ``k + 1``; its row uses the equivalent
    predecessor form ``P_{N−1,l} ∝ exp(−D_{N−1,l−1}/σ)`` (go to ``l`` when the frame before ``l``
    resembles the last one), with ``P_{N−1,0} = 0``. This is the raw matrix; the walk's own
    (:attr:`EndlessAnimation.transition_matrix`) also removes transitions that cannot
    cross-dissolve or lead into dead ends.
    """
    d = _similarity(similarity)
    sigma = default_sigma(d) if sigma is None else check.real(sigma, "sigma", 0.0, lo_open=True)
    return _core.transition_matrix(d, sigma)


def crossfade_weights(frames: int) -> np.ndarray:
    """The ``H`` cross-dissolve weights ``w_t = 1 − (t + 1)/(H + 1)`` (float32), from ~1 to ~0."""
    frames = check.integer(frames, "crossfade_frames", 0, 1 << 20)
    return np.array([_core.crossfade_weight(t, frames) for t in range(frames)], dtype=np.float32)


def blend_volumes(a: Any, b: Any, w: float, threads: int = 0) -> np.ndarray:
    """``w·a + (1 − w)·b`` (float32, C++): the cross-dissolve of two volumes or per-voxel fields."""
    a = np.ascontiguousarray(a, dtype=np.float32)
    b = np.ascontiguousarray(b, dtype=np.float32)
    if a.shape != b.shape:
        raise ValueError(f"a and b must have the same shape, got {a.shape} and {b.shape}")
    w = check.real(w, "w", 0.0, 1.0)
    return _core.blend_volumes(a, b, w, check.threads(threads))


class EndlessAnimation:
    """An endless random walk over a :class:`VolumeDatabase` (Video Textures over volumes).

    Parameters
    ----------
    database:
        The volumes.
    sigma:
        σ of ``P_kl ∝ exp(−D_{k+1,l}/σ)``; ``None`` takes :func:`default_sigma` (0.1 × the mean
        non-zero ``D``). Smaller σ jumps less often and only between very similar volumes.
    crossfade_frames:
        ``H``: frames of cross-dissolve at a jump (0 cuts). From frame ``c`` a jump to ``l`` shows
        ``w_t·ρ[c+1+t] + (1 − w_t)·ρ[l+t]``, ``t = 0..H−1``, ``w_t = 1 − (t+1)/(H+1)``, then goes
        on from ``l + H − 1``; the natural successor ``c + 1`` is shown as is.
    seed:
        Seeds the walk (cumuli's SplitMix64): the same seed gives the same frames.
    start:
        The first frame (must not be a dead end).

    Frames whose every path reaches the database's end are pruned (:attr:`live`), and the walk's
    :attr:`transition_matrix` keeps only transitions whose cross-dissolve windows fit and that
    land on live frames, so :meth:`next` never runs out of frames.
    """

    def __init__(
        self,
        database: VolumeDatabase,
        sigma: float | None = None,
        crossfade_frames: int = 4,
        seed: int = 0,
        start: int = 0,
    ) -> None:
        if not isinstance(database, VolumeDatabase):
            raise TypeError(
                f"database must be a cumuli.VolumeDatabase, got {type(database).__name__}"
            )
        _volume.check_similarity_size(database.n, "database")
        self.database = database
        d = database.similarity()
        self.sigma = (
            default_sigma(d) if sigma is None else check.real(sigma, "sigma", 0.0, lo_open=True)
        )
        self.crossfade_frames = check.integer(crossfade_frames, "crossfade_frames", 0, 1 << 20)
        self.seed = check.integer(seed, "seed", 0, 2**64 - 1)
        self.start = check.integer(start, "start", 0, database.n - 1)
        self._walk = _core.EndlessWalk(d, self.sigma, self.crossfade_frames, self.seed, self.start)
        self._count = 0

    @property
    def transition_matrix(self) -> np.ndarray:
        """The walk's ``(N, N)`` matrix: the paper's P restricted to feasible, live transitions."""
        return self._walk.matrix

    @property
    def live(self) -> np.ndarray:
        """``(N,)`` bool: frames the walk may visit (the others run into the end)."""
        return self._walk.live

    @property
    def current(self) -> int:
        """The database frame the walk continues from."""
        return int(self._walk.current)

    def step(self) -> AnimationFrame:
        """Advance one frame without computing its density."""
        source, target, weight, fade = self._walk.next()
        frame = AnimationFrame(self._count, int(source), int(target), float(weight), bool(fade))
        self._count += 1
        return frame

    def density(self, frame: AnimationFrame, threads: int = 0) -> np.ndarray:
        """The frame's density volume ``(D, H, W)`` float32 (a copy when not blended)."""
        if not isinstance(frame, AnimationFrame):
            raise TypeError(f"frame must be a cumuli.AnimationFrame, got {type(frame).__name__}")
        frame.check_in(self.database.n)
        vols = self.database.volumes
        if frame.weight == 1.0:
            return vols[frame.source].copy()
        return _core.blend_volumes(
            vols[frame.source], vols[frame.target], frame.weight, check.threads(threads)
        )

    def next(self, threads: int = 0) -> AnimationFrame:
        """The next frame, with its blended density."""
        frame = self.step()
        return AnimationFrame(
            frame.index,
            frame.source,
            frame.target,
            frame.weight,
            frame.crossfade,
            self.density(frame, threads),
        )

    def frames(
        self, n: int, densities: bool = True, threads: int = 0, progress: bool | None = None
    ) -> list[AnimationFrame]:
        """The next ``n`` frames (with densities unless ``densities=False``): at most
        :data:`MAX_FRAME_LIST` frames, and with densities at most ``MAX_POINTS`` voxels in all
        (checked before walking; iterate the animation for longer walks)."""
        if isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n > MAX_FRAME_LIST:
            raise ValueError(
                f"n={n} frames in one list is more than MAX_FRAME_LIST={MAX_FRAME_LIST}; "
                "iterate the animation (for frame in anim) for longer walks"
            )
        n = check.integer(n, "n", 0, MAX_FRAME_LIST)
        if densities:
            shape = self.database.shape
            if n * shape[0] * shape[1] * shape[2] > check.MAX_POINTS:
                raise ValueError(f"n={n} frames of {shape} exceed {check.MAX_POINTS} voxels")
            steps = _progress.bar(range(n), desc="frames", unit="frame", progress=progress)
            return [self.next(threads) for _ in steps]
        return [self.step() for _ in range(n)]

    def __iter__(self) -> EndlessAnimation:
        return self

    def __next__(self) -> AnimationFrame:
        return self.next()
