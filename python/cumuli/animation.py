"""Endless cloud animation (Iwasaki, Nishino & Dobashi 2011): Video Textures over volumes.

A :class:`VolumeDatabase` holds ``N`` successive density volumes ``(N, D, H, W)`` (``[z, y, x]``,
float32) over one world box. :func:`evolving_cloud_volumes` makes one without a fluid solver: a
:class:`~cumuli.Cloud` whose primitives grow and drift while the noise domain is advected by a
wind, voxelised frame by frame in C++.

:class:`EndlessAnimation` walks the paper's Markov chain: the similarity
``D_kl = Σₙ (ρ_k − ρ_l)²``, the transition probability ``P_kl ∝ exp(−D_{k+1,l}/σ)`` and a
cross-dissolve over ``H`` frames at every jump (``ρ = w ρᵢ + (1 − w) ρⱼ``, ``w`` going from 1 to 0).
Dead ends (Video Textures' term: the last frame, and frames from which every path runs into it)
are pruned, so the walk is endless; the RNG is seeded, so a walk is reproducible.

:class:`VolumeLighting` precomputes, per database volume, the optical depth towards the sun of
every voxel and the spherical-harmonic projection of the optical depth over all directions (the
sky), and fits the SH-exponential tables (eq. 7). Optical depth is linear in density, so a
blended frame's optical depths are the blend of the precomputed ones (eq. 6): :meth:`light`
blends them and returns the per-voxel light the renderer reads (``τ_sun``, ``E_sky`` RGB).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli import _core
from cumuli import _validate as check
from cumuli.cloud import Cloud
from cumuli.noise import Noise, _fbm_params
from cumuli.scene import Sky
from cumuli.sun import Sun

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


def similarity_matrix(volumes: Any, threads: int = 0) -> np.ndarray:
    """``D_kl = Σₙ (ρ_k − ρ_l)²`` of ``(N, ...)`` volumes: ``(N, N)`` float64 (C++, threaded)."""
    if isinstance(volumes, VolumeDatabase):
        return volumes.similarity(threads)
    if not isinstance(volumes, np.ndarray):
        volumes = np.asarray(volumes)
    if volumes.ndim < 2:
        raise ValueError(f"volumes must have shape (N, ...), got {volumes.shape}")
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


@dataclass(frozen=True)
class AnimationFrame:
    """One displayed frame: ``density = weight·ρ[source] + (1 − weight)·ρ[target]``."""

    index: int
    source: int
    target: int
    weight: float
    crossfade: bool
    density: np.ndarray | None = None


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

    def frames(self, n: int, densities: bool = True, threads: int = 0) -> list[AnimationFrame]:
        """The next ``n`` frames (with densities unless ``densities=False``)."""
        n = check.integer(n, "n", 0, 1 << 24)
        if densities:
            shape = self.database.shape
            if n * shape[0] * shape[1] * shape[2] > check.MAX_POINTS:
                raise ValueError(f"n={n} frames of {shape} exceed {check.MAX_POINTS} voxels")
            return [self.next(threads) for _ in range(n)]
        return [self.step() for _ in range(n)]

    def __iter__(self) -> EndlessAnimation:
        return self

    def __next__(self) -> AnimationFrame:
        return self.next()


# --- the generator ------------------------------------------------------------------------------


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


# --- light --------------------------------------------------------------------------------------


def as_sky(sky: Any) -> Sky:
    """A :class:`cumuli.Sky` from ``None`` (the default sky), a ``Sky``, one colour (a uniform sky:
    zenith, horizon and ground alike) or a pair ``(zenith, horizon)``."""
    if sky is None:
        return Sky()
    if isinstance(sky, Sky):
        return sky
    try:
        arr = np.asarray(sky, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(
            f"sky must be a cumuli.Sky, a colour or (zenith, horizon), got {sky!r}"
        ) from None
    if arr.shape == (3,):
        c = check.vec3(arr, "sky")
        return Sky(zenith=c, horizon=c, ground=c)
    if arr.shape == (2, 3):
        return Sky(
            zenith=check.vec3(arr[0], "sky zenith"), horizon=check.vec3(arr[1], "sky horizon")
        )
    raise ValueError(
        f"sky must be a colour (3,) or (zenith, horizon) (2, 3), got shape {arr.shape}"
    )


def sky_args(sky: Sky) -> tuple:
    """The core's sky tuple (zenith, horizon, ground, exponent, disc radius, disc intensity)."""
    return (
        sky.zenith, sky.horizon, sky.ground, float(sky.exponent), float(sky.sun_disc_radius),
        float(sky.sun_disc_intensity),
    )  # fmt: skip


#: SH exponential methods of VolumeLighting.
SHEXP_METHODS = ("squaring", "fit")
#: How the optical depths are precomputed: ``"sweep"`` (slice sweeps that reuse each voxel's
#: neighbours, the default) or ``"march"`` (one brute-force march per voxel and direction/point).
DEPTH_METHODS = ("sweep", "march")


def _depth_method(method: Any) -> str:
    if not isinstance(method, str) or method not in DEPTH_METHODS:
        raise ValueError(f"method must be one of {DEPTH_METHODS}, got {method!r}")
    return method


class VolumeLighting:
    """Per-volume precomputed optical depths of a database, and the per-frame light (§3.1).

    For every database volume and voxel: the optical depth towards the sun
    ``f_sun = ∫ ρ du`` (marched to the box exit, trilinear, steps of ``step`` voxels) and the SH
    projection (``sh_order²`` coefficients) of the optical depth ``f(x, ω)`` over the directions of
    a Gauss–Legendre × uniform product quadrature (``sh_samples`` × ``2·sh_samples`` directions,
    exact for constants and every band the order keeps). The sky transmittance's SH vector is
    the SH exponential of ``−σ_t·f``: ``shexp="fit"`` is the paper's eq. (7) with tables ``a, b``
    fitted by least squares on up to ``fit_samples`` voxels taken evenly over the database;
    ``shexp="squaring"`` (the default) is Ren et al.'s scaling and squaring with SH triple
    products, which stays accurate where the optical depth varies strongly with direction. On
    a cumulus database at σ_t·ρ of a few per world unit, the uniform-sky visibility ``∫τ dω``
    against brute-force marching had median relative errors of 11 % (squaring) against 85 %
    (fit) at order 4, 21 % against 100 % at order 3 (``benchmarks/bench_animation.py`` measures
    this); at low optical depth both are within a few per cent. Optical depths are density ×
    length; ``sigma_t`` turns them into transmittance ``exp(−σ_t f)``, and the renderer must use
    the same value.

    ``method="sweep"`` (default) computes the optical depths by sweeping each volume: along the
    sun and along each quadrature direction every sun-parallel line of a grid sheared along the
    direction is integrated once and each voxel reads the four lines around it; towards each
    sample point the volume is swept outwards from the point, each voxel continuing the depth of
    the voxels one slice closer (see ``volume_light.hpp``). ``method="march"`` marches every
    voxel's ray (the brute-force reference, tens of times slower). Against ``"march"``, the swept
    depths of the README's cumulus database differ by a few per cent on average (the benchmark
    states the figures) and the sky visibility error quoted above is unchanged. A tqdm bar shows
    the precompute's progress over the volumes (``progress=False`` hides it; it only appears for
    precomputes longer than half a second).

    Multiple isotropic scattering (§3.2, eq. 8) goes through ``ms_points`` sample points spread
    uniformly over the box (seeded): the optical depth from every voxel to every point is
    precomputed per database volume (linear in ρ, so blended like the others — eq. 9 in log form),
    and ``ms_orders`` orders are summed at each frame,
    ``E_n(x) = Σ_k (V/K)·σ_t·ρ(q_k)·albedo·E_{n−1}(q_k)/4π · e^{−σ_t f(x, q_k)} / max(d², d_min²)``
    starting from ``E_1 = sun·τ_sun + E_sky`` (the sun taken as isotropic beyond the first
    bounce). Unlike the paper the K terms are summed directly rather than through clustered cuts
    (K is small here); ``ms_points=0`` keeps single scattering only.
    """

    def __init__(
        self,
        database: VolumeDatabase,
        sun: Sun,
        sky: Any = None,
        sigma_t: float = 1.0,
        sh_order: int = 4,
        sh_samples: int = 6,
        step: float = 0.5,
        shexp: str = "squaring",
        shexp_bins: int = 32,
        fit_samples: int = 4096,
        ms_points: int = 32,
        ms_orders: int = 2,
        albedo: float = 1.0,
        seed: int = 0,
        threads: int = 0,
        method: str = "sweep",
        progress: bool = True,
    ) -> None:
        if not isinstance(database, VolumeDatabase):
            raise TypeError(
                f"database must be a cumuli.VolumeDatabase, got {type(database).__name__}"
            )
        if not isinstance(sun, Sun):
            raise TypeError(f"sun must be a cumuli.Sun, got {type(sun).__name__}")
        self.database = database
        self.sun = sun
        self.sky = as_sky(sky)
        self.sigma_t = check.real(sigma_t, "sigma_t", 0.0)
        self.sh_order = check.integer(sh_order, "sh_order", 1, 4)
        self.sh_samples = check.integer(sh_samples, "sh_samples", self.sh_order, 64)
        self.step = check.real(step, "step", 1e-3, 64.0)
        if shexp not in SHEXP_METHODS:
            raise ValueError(f"shexp must be one of {SHEXP_METHODS}, got {shexp!r}")
        self.shexp = shexp
        bins = check.integer(shexp_bins, "shexp_bins", 1, 4096)
        fit_samples = check.integer(fit_samples, "fit_samples", 1, 1 << 22)
        threads = check.threads(threads)
        self.ms_points = check.integer(ms_points, "ms_points", 0, 1 << 16)
        self.ms_orders = check.integer(ms_orders, "ms_orders", 0, 16)
        self.albedo = check.real(albedo, "albedo", 0.0, 1.0)
        self.seed = check.integer(seed, "seed", 0, 2**64 - 1)
        self.method = _depth_method(method)
        if not isinstance(progress, bool):
            raise TypeError(f"progress must be a bool, got {type(progress).__name__}")
        nc = self.sh_order**2
        if database.volumes.size * nc > check.MAX_POINTS:
            raise ValueError(f"the SH optical depths would exceed {check.MAX_POINTS} values")
        if database.volumes.size * self.ms_points > check.MAX_POINTS:
            raise ValueError(
                f"ms_points={self.ms_points}: the point optical depths would exceed "
                f"{check.MAX_POINTS} values; use fewer points"
            )
        lo, hi = database.box
        vols = database.volumes
        self.sun_depth = _core.sun_optical_depth(
            vols, lo, hi, sun.direction, self.step, threads, self.method
        )
        self.points = np.zeros((0, 3), np.float32)
        self.point_depth: np.ndarray | None = None
        if self.ms_points > 0:
            self.points = _core.volume_sample_points(lo, hi, self.ms_points, self.seed)
            self.point_depth = np.empty((*vols.shape, self.ms_points), np.float32)
        # Sky and point depths volume by volume (the long steps), with a progress bar.
        self.sky_depth = np.empty((*vols.shape, nc), np.float32)
        from tqdm.auto import tqdm

        for i in tqdm(
            range(database.n),
            desc="VolumeLighting precompute",
            unit="volume",
            disable=not progress,
            delay=0.5,
            leave=False,
        ):
            vol = vols[i : i + 1]
            self.sky_depth[i] = _core.sh_optical_depth(
                vol, lo, hi, self.sh_order, self.sh_samples, self.step, threads, self.method
            )[0]
            if self.point_depth is not None:
                self.point_depth[i] = _core.point_optical_depth(
                    vol, lo, hi, self.points, self.step, threads, self.method
                )[0]
        if self.point_depth is not None:
            self.point_depth.setflags(write=False)
        self.sky_sh = _core.sky_sh(sky_args(self.sky), self.sh_order, self.sh_samples)
        if shexp == "fit":
            flat = self.sky_depth.reshape(-1, nc)
            pick = np.unique(
                np.linspace(0, flat.shape[0] - 1, min(fit_samples, flat.shape[0])).astype(np.int64)
            )
            self.shexp_a, self.shexp_b, self.shexp_max_norm = _core.fit_shexp(
                np.ascontiguousarray(flat[pick]), self.sh_order, self.sigma_t, bins, self.sh_samples
            )
        else:  # no tables: exp* is computed by scaling and squaring
            self.shexp_a = np.ones(1, np.float32)
            self.shexp_b = np.ones(1, np.float32)
            self.shexp_max_norm = 0.0
        for arr in (
            self.sun_depth,
            self.sky_depth,
            self.sky_sh,
            self.shexp_a,
            self.shexp_b,
            self.points,
        ):
            arr.setflags(write=False)

    def optical_depth(
        self, frame: AnimationFrame | int, threads: int = 0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``(f_sun (D, H, W), f_sky (D, H, W, order²), f_points (D, H, W, K) or None)`` of a
        frame: the blend of the precomputed optical depths with the frame's weight (eq. 6)."""
        source, target, w = self._frame(frame)
        threads = check.threads(threads)
        fields = [self.sun_depth, self.sky_depth]
        if self.point_depth is not None:
            fields.append(self.point_depth)
        if w == 1.0:
            out = [f[source].copy() for f in fields]
        else:
            out = [_core.blend_volumes(f[source], f[target], w, threads) for f in fields]
        return out[0], out[1], (out[2] if len(out) > 2 else None)

    def density(self, frame: AnimationFrame | int, threads: int = 0) -> np.ndarray:
        """The frame's density ``(D, H, W)``: the blend of its two database volumes."""
        source, target, w = self._frame(frame)
        vols = self.database.volumes
        if w == 1.0:
            return vols[source].copy()
        return _core.blend_volumes(vols[source], vols[target], w, check.threads(threads))

    def light(self, frame: AnimationFrame | int, threads: int = 0) -> np.ndarray:
        """The frame's light ``(D, H, W, 4)`` float32: ``τ_sun = exp(−σ_t f_sun)`` and the
        isotropic irradiance (RGB): the sky's ``Σ_m L_m τ_m`` with ``τ = exp*(−σ_t f_sky)`` (the
        SH exponential) plus the multiple-scattering orders."""
        f_sun, f_sky, f_points = self.optical_depth(frame, threads)
        density = self.density(frame, threads) if f_points is not None else None
        return self.light_from_depths(f_sun, f_sky, f_points, density, threads)

    def light_from_depths(
        self,
        f_sun: np.ndarray,
        f_sky: np.ndarray,
        f_points: np.ndarray | None = None,
        density: np.ndarray | None = None,
        threads: int = 0,
    ) -> np.ndarray:
        """Light ``(D, H, W, 4)`` from given optical depths (e.g. computed on a blended volume);
        multiple scattering is added when ``f_points`` and the frame's ``density`` are given."""
        lo, hi = self.database.box
        single = _core.light_volume(
            np.ascontiguousarray(f_sun, dtype=np.float32),
            np.ascontiguousarray(f_sky, dtype=np.float32),
            lo,
            hi,
            self.shexp_a,
            self.shexp_b,
            self.shexp_max_norm,
            self.sh_order,
            self.shexp == "squaring",
            self.sky_sh,
            self.sigma_t,
            check.threads(threads),
        )
        if f_points is None or self.ms_orders == 0:
            return single
        if density is None:
            raise ValueError("density is needed with f_points (multiple scattering)")
        return _core.add_multiple_scattering(
            np.ascontiguousarray(density, dtype=np.float32),
            single,
            lo,
            hi,
            np.ascontiguousarray(f_points, dtype=np.float32),
            self.points,
            self.sun.radiance,
            self.sigma_t,
            self.albedo,
            self.ms_orders,
            check.threads(threads),
        )

    def _frame(self, frame: AnimationFrame | int) -> tuple[int, int, float]:
        n = self.database.n
        if isinstance(frame, AnimationFrame):
            if not (0 <= frame.source < n and 0 <= frame.target < n):
                raise ValueError(f"frame refers to volumes outside the database (n={n})")
            return frame.source, frame.target, float(frame.weight)
        i = check.integer(frame, "frame", 0, n - 1)
        return i, i, 1.0


def sun_optical_depth(
    volumes: Any,
    box_min: Sequence[float],
    box_max: Sequence[float],
    to_sun: Sequence[float],
    step: float = 0.5,
    threads: int = 0,
    method: str = "sweep",
) -> np.ndarray:
    """Optical depth ``∫ ρ du`` from every voxel centre towards the sun (``(N, D, H, W)`` or
    ``(D, H, W)`` in, same shape out; trilinear, steps of ``step`` voxels; C++). ``method``:
    ``"sweep"`` (one sweep per volume, as :class:`VolumeLighting`) or ``"march"`` (brute
    force)."""
    arr = np.asarray(volumes)
    single = arr.ndim == 3
    arr = _float_volumes(arr[None] if single else arr, "volumes", 4)
    lo, hi = _box(box_min, box_max)
    out = _core.sun_optical_depth(
        arr,
        lo,
        hi,
        check.direction(to_sun, "to_sun"),
        check.real(step, "step", 1e-3, 64.0),
        check.threads(threads),
        _depth_method(method),
    )
    return out[0] if single else out


def sh_optical_depth(
    volumes: Any,
    box_min: Sequence[float],
    box_max: Sequence[float],
    sh_order: int = 4,
    sh_samples: int = 6,
    step: float = 0.5,
    threads: int = 0,
    method: str = "sweep",
) -> np.ndarray:
    """SH coefficients (``sh_order²``, innermost) of each voxel's optical depth over directions
    (``method`` as :func:`sun_optical_depth`)."""
    arr = np.asarray(volumes)
    single = arr.ndim == 3
    arr = _float_volumes(arr[None] if single else arr, "volumes", 4)
    lo, hi = _box(box_min, box_max)
    order = check.integer(sh_order, "sh_order", 1, 4)
    samples = check.integer(sh_samples, "sh_samples", order, 64)
    out = _core.sh_optical_depth(
        arr,
        lo,
        hi,
        order,
        samples,
        check.real(step, "step", 1e-3, 64.0),
        check.threads(threads),
        _depth_method(method),
    )
    return out[0] if single else out


def sh_basis(order: int, directions: Any) -> np.ndarray:
    """Real orthonormal SH ``y_m(ω)`` of unit ``(N, 3)`` directions: ``(N, order²)`` (C++)."""
    return _core.sh_eval(
        check.integer(order, "order", 1, 4), check.points3(directions, "directions")
    )


def sphere_quadrature(n_theta: int) -> tuple[np.ndarray, np.ndarray]:
    """The product quadrature: directions ``(2·n_theta², 3)`` and weights summing to 4π."""
    return _core.sphere_quadrature(check.integer(n_theta, "n_theta", 1, 64))


def point_optical_depth(
    volumes: Any,
    box_min: Sequence[float],
    box_max: Sequence[float],
    points: Any,
    step: float = 0.5,
    threads: int = 0,
    method: str = "sweep",
) -> np.ndarray:
    """Optical depth ``∫ ρ`` along the segment from every voxel centre to every ``(K, 3)`` point:
    ``(N, D, H, W, K)`` (or ``(D, H, W, K)`` for one volume); C++ (``method`` as
    :func:`sun_optical_depth`)."""
    arr = np.asarray(volumes)
    single = arr.ndim == 3
    arr = _float_volumes(arr[None] if single else arr, "volumes", 4)
    lo, hi = _box(box_min, box_max)
    pts = check.points3(points, "points")
    if arr.size * pts.shape[0] > check.MAX_POINTS:
        raise ValueError(f"volumes × points exceed {check.MAX_POINTS} values")
    out = _core.point_optical_depth(
        arr,
        lo,
        hi,
        pts,
        check.real(step, "step", 1e-3, 64.0),
        check.threads(threads),
        _depth_method(method),
    )
    return out[0] if single else out
