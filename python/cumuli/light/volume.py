"""Light of density volumes (Iwasaki, Nishino & Dobashi 2011, §3.1–3.2): sun, sky and multiple
scattering from per-volume precomputed optical depths.

:class:`VolumeLighting` precomputes, per database volume, the optical depth towards the sun of
every voxel and the spherical-harmonic projection of the optical depth over all directions (the
sky), and fits the SH-exponential tables (eq. 7). Optical depth is linear in density, so a
blended frame's optical depths are the blend of the precomputed ones (eq. 6): :meth:`light`
blends them and returns the per-voxel light the renderer reads (``τ_sun``, ``E_sky`` RGB).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import progress as _progress
from cumuli._util import validate as check
from cumuli.light.memo import content_digest, remember
from cumuli.model.volume import (
    MAX_SIGMA_T,
    AnimationFrame,
    VolumeCloud,
    VolumeDatabase,
    _box,
    _float_volumes,
)
from cumuli.sky import Sun, as_sky, sky_args

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
    the voxels one slice closer (see ``light/volume.hpp``). ``method="march"`` marches every
    voxel's ray (the brute-force reference, tens of times slower). Against ``"march"``, the swept
    depths of the cumulus database of docs/iwasaki-animation.md differ by a few per cent on
    average (the benchmark states the figures) and the sky visibility error quoted above is
    unchanged.

    Multiple isotropic scattering (§3.2, eq. 8) goes through ``ms_points`` sample points spread
    uniformly over the box (seeded): the optical depth from every voxel to every point is
    precomputed per database volume (linear in ρ, so blended like the others — eq. 9 in log form),
    and ``ms_orders`` orders are summed at each frame,
    ``E_n(x) = Σ_k (V/K)·σ_t·ρ(q_k)·albedo·E_{n−1}(q_k)/4π · e^{−σ_t f(x, q_k)} / max(d², d_min²)``
    starting from ``E_1 = sun·τ_sun + E_sky`` (the sun taken as isotropic beyond the first
    bounce). Unlike the paper the K terms are summed directly rather than through clustered cuts
    (K is small here); ``ms_points=0`` keeps single scattering only.

    The precompute runs volume by volume; when it takes more than a few seconds a progress bar
    shows (``progress=False``: none; ``None``: unless ``CUMULI_PROGRESS=0``).
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
        progress: bool | None = None,
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
        self.sigma_t = check.real(sigma_t, "sigma_t", 0.0, MAX_SIGMA_T)
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
        self.points = np.zeros((0, 3), np.float32)
        self.point_depth: np.ndarray | None = None
        if self.ms_points > 0:
            self.points = _core.volume_sample_points(lo, hi, self.ms_points, self.seed)
        self._precompute(vols, lo, hi, threads, progress)
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
        if self.point_depth is not None:
            self.point_depth.setflags(write=False)
        for arr in (
            self.sun_depth,
            self.sky_depth,
            self.sky_sh,
            self.shexp_a,
            self.shexp_b,
            self.points,
        ):
            arr.setflags(write=False)

    def _precompute(
        self, vols: np.ndarray, lo: Any, hi: Any, threads: int, progress: bool | None
    ) -> None:
        """The optical depths of every volume, one volume at a time (the same values as all at
        once: voxels are independent), with a progress bar for long databases."""
        n, d, h, w = vols.shape
        self.sun_depth = np.empty((n, d, h, w), np.float32)
        self.sky_depth = np.empty((n, d, h, w, self.sh_order**2), np.float32)
        if self.ms_points > 0:
            self.point_depth = np.empty((n, d, h, w, self.ms_points), np.float32)
        steps = _progress.bar(range(n), desc="volume light", unit="volume", progress=progress)
        for i in steps:
            one = vols[i : i + 1]
            sun = self.sun.direction
            m = self.method
            self.sun_depth[i] = _core.sun_optical_depth(one, lo, hi, sun, self.step, threads, m)[0]
            self.sky_depth[i] = _core.sh_optical_depth(
                one, lo, hi, self.sh_order, self.sh_samples, self.step, threads, m
            )[0]
            if self.point_depth is not None:
                self.point_depth[i] = _core.point_optical_depth(
                    one, lo, hi, self.points, self.step, threads, m
                )[0]

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
            frame.check_in(n)
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


# --- the light pass of the kind (cumuli.kinds.volume) ------------------------------------
def volume_light(
    volume: VolumeCloud, scene: Any, given: Any = None, threads: int = 0
) -> np.ndarray:
    """The ``(D, H, W, 4)`` light of a `VolumeCloud` under the scene's sun and sky: its own
    precomputed light (or ``given``) when made for them, else computed by `VolumeLighting`."""
    if given is not None:
        # A copy of a light shaded by particles and billboards: the volume's own underneath.
        own = getattr(given, "shaded_from", None)
        light = np.asarray(given if own is None else own, dtype=np.float32)
        if light.shape != (*volume.shape, 4) or not np.isfinite(light).all():
            raise ValueError(
                f"the light of a VolumeCloud must be a finite {(*volume.shape, 4)} array"
            )
        return light
    if volume.light is not None and (volume.light_sun, volume.light_sky) == (scene.sun, scene.sky):
        return volume.light
    key = (
        "volume",
        content_digest(volume.density),
        volume.box,
        volume.extinction_per_density(scene.settings),
        volume.albedo,
        tuple(sorted(volume.lighting.items())),
        scene.sun,
        scene.sky,
    )

    def make() -> np.ndarray:
        database = VolumeDatabase(volume.density[None], *volume.box)
        lighting = VolumeLighting(
            database, scene.sun, scene.sky, sigma_t=volume.extinction_per_density(scene.settings),
            albedo=volume.albedo,
            threads=threads, **volume.lighting,
        )  # fmt: skip
        light = lighting.light(0, threads=threads)
        light.setflags(write=False)
        return light

    return remember(key, make)
