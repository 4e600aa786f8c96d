"""Density volumes: the database of an endless animation (Iwasaki, Nishino & Dobashi 2011, §3).

A :class:`VolumeDatabase` holds ``N`` successive density volumes ``(N, D, H, W)`` (``[z, y, x]``,
float32) over one world box. :func:`evolving_cloud_volumes` makes one without a fluid solver: a
:class:`~cumuli.Cloud` whose primitives grow and drift while the noise domain is advected by a
wind, voxelised frame by frame in C++.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, ClassVar

import numpy as np

from cumuli import _core
from cumuli._util import progress as _progress
from cumuli._util import validate as check
from cumuli._util.structs import core_struct
from cumuli.io.jsonable import array_from_json, array_to_json, jsonable
from cumuli.model.cloud import Cloud
from cumuli.noise import Noise, _fbm_params
from cumuli.sky import Sky, Sun

#: Largest edge of a database volume.
MAX_EDGE = 2048
#: Most volumes a database may hold.
MAX_VOLUMES = 1 << 16
#: Most volumes whose (N, N) float64 similarity matrix is computed (512 MiB at the limit; the
#: endless walk holds a few matrices of that size).
MAX_SIMILARITY_VOLUMES = 1 << 13
#: Largest extinction coefficient of a volume (per world unit).
MAX_SIGMA_T = 1e12
#: The physical mode's sharp-volume reading of a VolumeCloud (cumuli.rendering.volume_detail):
#: the default erosion strength, its largest value, and the density reconstructions.
DEFAULT_DETAIL = 0.5
MAX_DETAIL = 0.95
RECONSTRUCTIONS = ("cubic", "linear")
#: The largest ``settings.extinction_scale`` (what ``sigma_t=None`` may stand for).
MAX_EXTINCTION_SCALE = 1e6
#: Largest ``sigma_t × density``: an optical depth over a path of MAX_COORD world units then
#: stays below 1e27, far inside float32 (3.4e38), on both backends.
MAX_EXTINCTION = 1e12


def check_similarity_size(n: int, name: str = "volumes") -> None:
    """Refuse an (N, N) similarity matrix beyond :data:`MAX_SIMILARITY_VOLUMES` before it is
    allocated."""
    if n > MAX_SIMILARITY_VOLUMES:
        raise ValueError(
            f"{name}: the (N, N) similarity of {n} volumes would need {8 * n * n / 2**30:.1f} "
            f"GiB; at most {MAX_SIMILARITY_VOLUMES} volumes (MAX_SIMILARITY_VOLUMES)"
        )


def _box(
    box_min: Any, box_max: Any
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    lo = check.vec3(box_min, "box_min", bound=check.MAX_COORD)
    hi = check.vec3(box_max, "box_max", bound=check.MAX_COORD)
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
    with np.errstate(over="ignore"):  # beyond float32: inf, refused just below
        arr = np.ascontiguousarray(value, dtype=np.float32)
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or infinite values (or values beyond float32)")
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

    def similarity(self, threads: int = 0, progress: bool | None = None) -> np.ndarray:
        """``D_kl = Σₙ (ρ_k − ρ_l)²``: the ``(N, N)`` float64 matrix (C++, cached, read-only;
        at most :data:`MAX_SIMILARITY_VOLUMES` volumes, checked before allocating)."""
        if self._similarity is None:
            check_similarity_size(self.n)
            with _progress.core("similarity", progress):
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

    def __post_init__(self) -> None:
        s = object.__setattr__
        s(self, "index", check.integer(self.index, "frame.index", 0))
        s(self, "source", check.integer(self.source, "frame.source", 0))
        s(self, "target", check.integer(self.target, "frame.target", 0))
        # A weight outside [0, 1] extrapolates beyond both volumes (densities above the
        # database's maximum, or negative); NaN would make NaN light.
        s(self, "weight", check.real(self.weight, "frame.weight", 0.0, 1.0))
        s(self, "crossfade", check.flag(self.crossfade, "frame.crossfade"))

    def check_in(self, n: int) -> None:
        """Refuse a frame that refers to volumes outside a database of ``n``."""
        for name in ("source", "target"):
            if getattr(self, name) >= n:
                raise ValueError(
                    f"frame.{name}={getattr(self, name)} is outside the database (n={n})"
                )


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
    progress: bool | None = None,
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
    evo = core_struct(
        _core.EvolutionParams, frames=n_frames, res=res, growth=growth, drift=drift3,
        jitter=jitter, wind=wind3, density_scale=density_scale, padding=padding, seed=seed,
    )  # fmt: skip
    if box is None:
        lo, hi = _core.evolving_cloud_box(_core.CloudShape(*cloud.core_args()), evo)
        lo, hi = _box(lo, hi)
    else:
        if not isinstance(box, Sequence) or len(box) != 2:
            raise TypeError("box must be (box_min, box_max)")
        lo, hi = _box(box[0], box[1])
    with _progress.core("cloud volumes", progress):  # a bar when it takes long
        vols = _core.evolving_cloud_volumes(
            _core.CloudShape(*cloud.core_args()), core_noise, const, _core.FbmParams(*fbm), evo,
            lo, hi, check.threads(threads),
        )  # fmt: skip
    return VolumeDatabase(vols, lo, hi)


#: VolumeLighting keyword arguments a VolumeCloud may carry for computing its light.
VOLUME_LIGHTING_KEYS = (
    "sh_order", "sh_samples", "step", "shexp", "shexp_bins", "fit_samples", "ms_points",
    "ms_orders", "seed", "method",
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class VolumeCloud:
    """A density volume in a world box: the drawable of kind ``"volume"`` (a frame of an endless
    animation, or any voxelised cloud), drawn by the volume marcher (RENDER_CONTRACT, volumes).

    ``density`` is ``(D, H, W)`` (``[z, y, x]``, ≥ 0) over ``box = (lo, hi)``; ``sigma_t``,
    ``albedo``, ``g`` and ``step`` are the marcher's (see :func:`cumuli.render_volume`). ``light``
    is an optional precomputed ``(D, H, W, 4)`` light volume (``τ_sun``, ``E_sky`` RGB, as
    :meth:`cumuli.VolumeLighting.light` makes) with the ``light_sun`` and ``light_sky`` it was made
    for: the light stage uses it while the scene's sun and sky are those, and otherwise computes
    the light itself with :class:`cumuli.VolumeLighting` and the ``lighting`` keywords
    (``sh_order``, ``sh_samples``, ``step``, ``ms_points``, ...). Arrays are copied and read-only.

    ``sigma_t`` None (the default) is the mode's extinction per unit density
    (:meth:`extinction_per_density`): ``settings.extinction_scale`` in the physical mode, as for
    a 2018 cloud of the same density, and 1 in the paper mode. ``detail``, ``detail_frequency``
    and ``reconstruction`` are the physical mode's sharp-volume reading of the density
    (:mod:`cumuli.rendering.volume_detail`): the tricubic B-spline of the voxels
    (``"cubic"``, or ``"linear"``: trilinear) eroded at its edges by the scene's fBm with
    strength ``detail`` in ``[0, 0.95]`` (0: none) at ``detail_frequency`` lattice texels per
    world unit (None: half a texel per voxel). The paper mode reads neither.
    """

    #: Scene-file tag of this kind of drawable.
    kind: ClassVar[str] = "volume"

    density: np.ndarray
    box: tuple[Sequence[float], Sequence[float]]  # (lo, hi), kept as float tuples
    sigma_t: float | None = None
    albedo: float = 1.0
    g: float = 0.2
    step: float | None = None
    light: np.ndarray | None = None
    light_sun: Sun | None = None
    light_sky: Sky | None = None
    lighting: dict[str, Any] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    detail: float = DEFAULT_DETAIL
    detail_frequency: float | None = None
    reconstruction: str = "cubic"

    def __post_init__(self) -> None:
        s = object.__setattr__
        dens = np.array(_float_volumes(self.density, "density", 3), copy=True)
        if (dens < 0).any():
            raise ValueError("density must not hold negative values")
        dens.setflags(write=False)
        s(self, "density", dens)
        if not isinstance(self.box, Sequence) or len(self.box) != 2:
            raise TypeError(f"box must be (box_min, box_max), got {self.box!r}")
        s(self, "box", _box(self.box[0], self.box[1]))
        if self.sigma_t is not None:
            s(self, "sigma_t", check.real(self.sigma_t, "sigma_t", 0.0, MAX_SIGMA_T))
        biggest = float(dens.max()) if dens.size else 0.0
        # sigma_t None stands for extinction_scale, which may be up to MAX_EXTINCTION_SCALE.
        worst = self.sigma_t if self.sigma_t is not None else MAX_EXTINCTION_SCALE
        if worst * biggest > MAX_EXTINCTION:
            raise ValueError(
                f"sigma_t × the largest density ({worst:g} × {biggest:g}) must be at most "
                f"{MAX_EXTINCTION:g} (MAX_EXTINCTION: beyond it the marchers' optical depths "
                "overflow float32)"
            )
        s(self, "albedo", check.real(self.albedo, "albedo", 0.0, 1.0))
        s(self, "g", check.real(self.g, "g", -1.0, 1.0, lo_open=True, hi_open=True))
        s(self, "detail", check.real(self.detail, "detail", 0.0, MAX_DETAIL))
        if self.detail_frequency is not None:
            s(self, "detail_frequency", check.real(
                self.detail_frequency, "detail_frequency", 0.0, 1e6, lo_open=True))  # fmt: skip
        if self.reconstruction not in RECONSTRUCTIONS:
            raise ValueError(
                f"reconstruction must be one of {RECONSTRUCTIONS}, got {self.reconstruction!r}"
            )
        if self.step is not None:
            s(self, "step", check.real(self.step, "step", 0.0, lo_open=True))
        if self.light is not None:
            light = np.array(_float_volumes(self.light, "light", 4), copy=True)
            if light.shape != (*dens.shape, 4):
                raise ValueError(f"light must have shape {(*dens.shape, 4)}, got {light.shape}")
            if float(np.abs(light).max()) > check.MAX_RADIANCE:
                raise ValueError(f"light values must be within ±{check.MAX_RADIANCE:g}")
            light.setflags(write=False)
            s(self, "light", light)
            if not isinstance(self.light_sun, Sun) or not isinstance(self.light_sky, Sky):
                raise TypeError("a light volume needs light_sun (a Sun) and light_sky (a Sky)")
        elif self.light_sun is not None or self.light_sky is not None:
            raise ValueError("light_sun and light_sky describe a light volume: give light too")
        if not isinstance(self.lighting, Mapping):
            raise TypeError(f"lighting must be a mapping, got {type(self.lighting).__name__}")
        unknown = sorted(set(self.lighting) - set(VOLUME_LIGHTING_KEYS))
        if unknown:
            raise ValueError(
                f"lighting has unknown key(s) {unknown}; known: {', '.join(VOLUME_LIGHTING_KEYS)}"
            )
        s(self, "lighting", dict(self.lighting))
        s(self, "params", dict(self.params))

    @classmethod
    def from_frame(cls, lighting: Any, frame: Any, **render: Any) -> VolumeCloud:
        """The displayed volume of an endless animation's ``frame`` (an `AnimationFrame` or a
        database index) with its light from ``lighting`` (a :class:`cumuli.VolumeLighting` of the
        same database): blended density and blended optical depths, as the paper does.

        ``render`` sets ``g``, ``step`` and the sharp-volume fields (``detail``, ...);
        ``sigma_t`` and ``albedo`` are the lighting's, its default ``sigma_t`` of 1 kept as None:
        the mode's extinction, 1 in the paper mode (the same light) and ``extinction_scale`` in
        the physical mode, which lights the frame anew as thick as the cloud it came from.
        """
        if not all(callable(getattr(lighting, k, None)) for k in ("density", "light")):
            raise TypeError(
                f"lighting must be a cumuli.VolumeLighting, got {type(lighting).__name__}"
            )
        if not isinstance(frame, AnimationFrame):
            frame = check.integer(frame, "frame", 0, len(lighting.database) - 1)
        density = lighting.density(frame)
        index = frame.index if isinstance(frame, AnimationFrame) else int(frame)
        return cls(
            density=density,
            box=lighting.database.box,
            sigma_t=None if lighting.sigma_t == 1.0 else lighting.sigma_t,
            albedo=lighting.albedo,
            light=lighting.light(frame),
            light_sun=lighting.sun,
            light_sky=lighting.sky,
            params={"frame": index},
            **render,
        )

    def extinction_per_density(self, settings: Any) -> float:
        """σt per unit density under ``settings`` (a :class:`cumuli.RenderSettings`): ``sigma_t``
        when given, else the physical mode's ``extinction_scale`` (1 in the paper mode)."""
        if self.sigma_t is not None:
            return float(self.sigma_t)
        return float(settings.extinction_scale) if settings.physical else 1.0

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(D, H, W)`` of the density."""
        return tuple(int(v) for v in self.density.shape)  # type: ignore[return-value]

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The volume's box as float32 ``(lo, hi)`` (what a camera frames)."""
        return self.layer_box()

    def layer_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The volume's box (float32): the compositor orders it by a ray's entry into it."""
        lo, hi = self.box
        return np.asarray(lo, np.float32), np.asarray(hi, np.float32)

    def translated(self, offset: Sequence[float] | np.ndarray) -> VolumeCloud:
        """A copy moved by ``offset`` (a precomputed light stays valid: it moves with it)."""
        off = check.vec3(offset, "offset")
        lo, hi = self.box
        box = (
            tuple(a + o for a, o in zip(lo, off, strict=True)),
            tuple(a + o for a, o in zip(hi, off, strict=True)),
        )
        return dataclasses.replace(self, box=box)

    # --- scene files --------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The volume as JSON types for scene files (arrays as exact base64 float32)."""
        return {
            "kind": self.kind,
            "density": array_to_json(self.density),
            "box": [list(self.box[0]), list(self.box[1])],
            "sigma_t": self.sigma_t,
            "albedo": self.albedo,
            "g": self.g,
            "step": self.step,
            "light": None if self.light is None else array_to_json(self.light),
            "light_sun": None if self.light_sun is None else jsonable(asdict(self.light_sun)),
            "light_sky": None if self.light_sky is None else jsonable(asdict(self.light_sky)),
            "lighting": jsonable(self.lighting),
            "params": jsonable(self.params),
            "detail": self.detail,
            "detail_frequency": self.detail_frequency,
            "reconstruction": self.reconstruction,
        }

    @classmethod
    def from_dict(cls, data: Any, where: str = "volume") -> VolumeCloud:
        """Inverse of :meth:`to_dict`; missing or unknown fields raise ValueError naming them."""
        if not isinstance(data, Mapping):
            raise ValueError(f"{where} must be a JSON object, got {type(data).__name__}")
        known = {f.name for f in dataclasses.fields(cls)} | {"kind"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"{where} has unknown field(s): {', '.join(unknown)}")
        missing = [k for k in ("density", "box") if k not in data]
        if missing:
            raise ValueError(f"{where} is missing field(s): {', '.join(missing)}")
        light = data.get("light")
        sun, sky = data.get("light_sun"), data.get("light_sky")
        try:
            return cls(
                density=array_from_json(data["density"], f"{where}.density"),
                box=tuple(data["box"]),
                sigma_t=data.get("sigma_t", 1.0),
                albedo=data.get("albedo", 1.0),
                g=data.get("g", 0.2),
                step=data.get("step"),
                light=None if light is None else array_from_json(light, f"{where}.light"),
                light_sun=None if sun is None else Sun(**sun),
                light_sky=None if sky is None else Sky(**sky),
                lighting=data.get("lighting") or {},
                params=data.get("params") or {},
                detail=data.get("detail", DEFAULT_DETAIL),
                detail_frequency=data.get("detail_frequency"),
                reconstruction=data.get("reconstruction", "cubic"),
            )
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{where}: {exc}") from None

    def __repr__(self) -> str:
        lo, hi = self.box
        light = "yes" if self.light is not None else "no"
        return f"VolumeCloud(shape={self.shape}, box=({list(lo)}, {list(hi)}), light={light})"
