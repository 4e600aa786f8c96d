"""The physical mode's medium: a drawable's extinction field σt(x) as a grid (RENDER_CONTRACT,
"Physical lighting").

For a 2018 `Cloud` ``σt(x) = settings.extinction_scale · ρ(x)`` with ``ρ`` the cloud's density
field (eq. 2 attributed to the primitive ``x`` is deepest inside, the union march's rule; eqs.
19–21 for metaballs); for a `VolumeCloud` ``σt(x) = sigma_t · density(x)`` (trilinear; its
``extinction_per_density``, the physical mode's ``extinction_scale`` when ``sigma_t`` is None).
:func:`density_volume` samples it on a texel-centre lattice over the drawable's box, so that the
same medium can be handed to another renderer (``tests/references`` gives it to Mitsuba 3);
:func:`extinction_grid` is the light step's cell-averaged version.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from cumuli import _core, registry
from cumuli._util import budget
from cumuli._util import validate as check
from cumuli.model.cloud import Cloud
from cumuli.model.volume import VolumeCloud
from cumuli.noise import Noise
from cumuli.settings import RenderSettings

#: Longest edge of a density volume, and most voxels (the volume-voxel limit of every call,
#: 2²⁸: 1 GiB of float32).
MAX_EDGE = 4096
MAX_VOXELS = check.MAX_POINTS
#: Bytes per voxel while a field is made: a 2018 cloud's (the core's float32 grid and its
#: scaled copy) and a resampled volume's (float64 sums, the sample points in float64 and
#: float32, the samples).
CLOUD_BYTES_PER_VOXEL = 8
VOLUME_BYTES_PER_VOXEL = 80


def check_lattice(what: str, shape: Sequence[int], supersample: int, bytes_per_voxel: int) -> None:
    """Refuse a lattice of ``shape`` beyond MAX_VOXELS, or whose memory (``bytes_per_voxel``
    per voxel) or work (``supersample³`` samples per voxel) is over the budget, before any of
    it is made."""
    voxels = math.prod(shape)
    if voxels > MAX_VOXELS:
        raise ValueError(
            f"{what}: resolution {tuple(shape)} has {voxels} voxels, more than the limit "
            f"{MAX_VOXELS} (2**28, MAX_VOXELS)"
        )
    budget.check_memory(f"{what} at resolution {tuple(shape)}", voxels * bytes_per_voxel)
    budget.check_work(
        f"{what} at resolution {tuple(shape)} × supersample {supersample}³",
        voxels * supersample**3,
    )


class ExtinctionField(NamedTuple):
    """An extinction field ``σt`` per world unit: ``values`` ``[z, y, x]`` float32 over ``box``
    ``(lo, hi)``; voxel ``(i, j, k)``'s value sits at its centre ``lo + ((i, j, k) + ½)·(hi −
    lo)/(W, H, D)`` (the GL texel-centre lattice; trilinear in between, clamped at the edges)."""

    values: np.ndarray
    box: tuple[tuple[float, float, float], tuple[float, float, float]]


def lattice_shape(
    box: tuple[Sequence[float], Sequence[float]], resolution: Any, name: str = "resolution"
) -> tuple[int, int, int]:
    """``(x, y, z)`` voxel counts: three ints as given, or one int for the longest edge with the
    others in proportion to the box (at least 2)."""
    if isinstance(resolution, (int, np.integer)) and not isinstance(resolution, bool):
        n = check.integer(resolution, name, 2, MAX_EDGE)
        ext = [float(h) - float(lo) for lo, h in zip(box[0], box[1], strict=True)]
        longest = max(ext)
        return tuple(max(2, round(n * e / longest)) for e in ext)  # type: ignore[return-value]
    return check.shape3(resolution, name, MAX_EDGE)


def _cloud_grid(
    cloud: Cloud,
    noise: Noise,
    settings: RenderSettings,
    box: tuple[np.ndarray, np.ndarray],
    shape: tuple[int, int, int],
    supersample: int,
    threads: int,
) -> np.ndarray:
    centres, radii, rotations, model, kappa, phi, noise_offset = cloud.core_args()
    if settings.kappa is not None and model == "spheroid":
        kappa = settings.kappa
    rho = _core.density_grid(
        _core.CloudShape(centres, radii, rotations, model, float(kappa), float(phi), noise_offset),
        noise._core, -1.0, _core.FbmParams(**settings.fbm_params()),
        tuple(map(float, box[0])), tuple(map(float, box[1])), shape, supersample, threads,
    )  # fmt: skip
    rho *= np.float32(settings.extinction_scale)
    return rho


def _volume_grid(
    volume: VolumeCloud, shape: tuple[int, int, int] | None, supersample: int, sigma_t: float
) -> np.ndarray:
    dens = volume.density
    if shape is None or tuple(shape) == tuple(dens.shape[::-1]):
        return (dens * np.float32(sigma_t)).astype(np.float32)
    lo, hi = (np.asarray(b, np.float64) for b in volume.box)
    w, h, d = shape
    acc = np.zeros((d, h, w), np.float64)
    offsets = (np.arange(supersample) + 0.5) / supersample
    axes = [lo[a] + (np.arange(n)[:, None] + offsets[None, :]) * (hi[a] - lo[a]) / n
            for a, n in enumerate(shape)]  # fmt: skip
    for oz in range(supersample):
        for oy in range(supersample):
            zz, yy, xx = np.meshgrid(axes[2][:, oz], axes[1][:, oy], axes[0][:, 0], indexing="ij")
            for ox in range(supersample):
                xx = np.broadcast_to(axes[0][None, None, :, ox], zz.shape)
                pts = np.stack([xx, yy, zz], -1).reshape(-1, 3).astype(np.float32)
                acc += _core.sample_volume(dens, volume.box[0], volume.box[1], pts, 0).reshape(
                    acc.shape
                )
    return (acc / supersample**3 * sigma_t).astype(np.float32)


def cloud_extinction(
    cloud: Cloud, noise: Noise, settings: RenderSettings, resolution: Any, supersample: int,
    threads: int,
) -> ExtinctionField:  # fmt: skip
    """A 2018 cloud's extinction field over its ``layer_box()`` (its density times
    ``settings.extinction_scale``)."""
    lo, hi = (np.asarray(b, np.float32) for b in cloud.layer_box())
    box = (tuple(float(v) for v in lo), tuple(float(v) for v in hi))
    if not isinstance(noise, Noise):
        raise TypeError(f"noise must be a cumuli.Noise, got {type(noise).__name__}")
    if resolution is None:
        raise ValueError("resolution=None keeps a lattice's own; give one for a cumuli.Cloud")
    shape = lattice_shape(box, resolution)
    check_lattice("a cloud's extinction field", shape, supersample, CLOUD_BYTES_PER_VOXEL)
    return ExtinctionField(_cloud_grid(cloud, noise, settings, (lo, hi), shape, supersample,
                                       threads), box)  # fmt: skip


def volume_extinction(
    volume: VolumeCloud, noise: Any, settings: Any, resolution: Any, supersample: int,
    threads: int,
) -> ExtinctionField:  # fmt: skip
    """A volume's ``sigma_t·density`` over its box: its own lattice (``resolution=None``) or
    resampled, each voxel the mean of ``supersample³`` trilinear samples."""
    lo, hi = (np.asarray(b, np.float32) for b in volume.layer_box())
    box = (tuple(float(v) for v in lo), tuple(float(v) for v in hi))
    shape = None if resolution is None else lattice_shape(box, resolution)
    if shape is not None and tuple(shape) != tuple(volume.density.shape[::-1]):
        check_lattice("a volume's resampled field", shape, supersample, VOLUME_BYTES_PER_VOXEL)
    sigma_t = volume.extinction_per_density(settings)
    return ExtinctionField(_volume_grid(volume, shape, supersample, sigma_t), box)


def cloud_core_args(cloud: Cloud, settings: Any) -> tuple[list, list]:
    """A 2018 cloud's entry of the core's medium lists: its primitives, density model and the
    extinction per unit density of the mode (:func:`cloud_extinction_scale`)."""
    centres, radii, rotations, model, kappa, phi, noise_offset = cloud.core_args()
    if settings.kappa is not None and model == "spheroid":
        kappa = settings.kappa
    scale = cloud_extinction_scale(settings)
    return [(centres, radii, rotations, model, float(kappa), float(phi), scale, noise_offset)], []


def volume_core_args(volume: VolumeCloud, settings: Any) -> tuple[list, list]:
    """A volume's entry of the core's medium lists: ``(density, lo, hi, σt)`` (σt per unit
    density, :meth:`cumuli.VolumeCloud.extinction_per_density`)."""
    sigma_t = volume.extinction_per_density(settings)
    return [], [(volume.density, volume.box[0], volume.box[1], sigma_t)]


def cloud_extinction_scale(settings: Any) -> float:
    """σt per unit of a 2018 cloud's density: the physical mode's ``extinction_scale``, the paper
    mode's camera-ray ``absorption / step_ref``."""
    if settings.physical:
        return float(settings.extinction_scale)
    return float(settings.absorption / settings.step_ref)


def extinction_grid(
    drawable: Any,
    noise: Noise,
    settings: RenderSettings,
    resolution: Any,
    supersample: int = 1,
    threads: int = 0,
) -> ExtinctionField:
    """The extinction field of a drawable with a medium (:attr:`cumuli.registry.Kind.medium`)
    over its ``layer_box()``, each voxel the mean of ``supersample³`` points (1: the texel
    centre). A kind with a lattice of its own (a `VolumeCloud`) gives it for
    ``resolution=None``."""
    kind = registry.get(getattr(type(drawable), "kind", "")) if drawable is not None else None
    medium = kind.medium if kind is not None and isinstance(drawable, kind.model) else None
    if medium is None:
        names = ", ".join(f"cumuli.{k.model.__name__}" for k in registry.kinds() if k.medium)
        raise TypeError(f"cloud must be one of {names}, got {type(drawable).__name__}")
    threads = check.threads(threads)
    supersample = check.integer(supersample, "supersample", 1, 8)
    return medium.extinction(drawable, noise, settings, resolution, supersample, threads)


def density_volume(
    cloud: Any,
    noise: Noise | None = None,
    settings: RenderSettings | None = None,
    resolution: int | Sequence[int] | None = 128,
    threads: int = 0,
) -> ExtinctionField:
    """The extinction field the physical mode integrates, sampled at texel centres.

    ``cloud`` is a `Cloud` (with the ``noise`` that fills it) or a `VolumeCloud` (``noise`` is
    not used); ``settings`` (default :class:`cumuli.RenderSettings`) gives ``extinction_scale``,
    the fBm and κ. ``resolution`` is ``(x, y, z)`` voxel counts or one int for the longest edge
    of the drawable's ``layer_box()`` (the others in proportion); ``None`` keeps a volume's own
    lattice. Returns an :class:`ExtinctionField` ``(values [z, y, x] float32, box)`` — hand both
    to another renderer with the texel-centre convention (Mitsuba 3's ``gridvolume`` over the
    box, for instance) to render the same medium.
    """
    settings = RenderSettings() if settings is None else settings
    if not isinstance(settings, RenderSettings):
        raise TypeError(f"settings must be a cumuli.RenderSettings, got {type(settings).__name__}")
    if noise is None and getattr(type(cloud), "kind", None) == "cloud":
        raise ValueError("noise is required for a cumuli.Cloud (its density is fBm)")
    return extinction_grid(cloud, noise, settings, resolution, 1, threads)  # type: ignore[arg-type]


def medium_args(drawables: Any, settings: Any) -> tuple[list, list]:
    """The core's ``(clouds, volumes)`` lists of the drawables' extinction (their medium, each
    kind's :attr:`cumuli.registry.Medium.core_args`): the 2018 clouds' density times
    :func:`cloud_extinction_scale`, a lattice's ``sigma_t·density``."""
    clouds: list = []
    volumes: list = []
    for d in drawables:
        # Particle clouds and billboards keep their own light models (Harris 2002, Torchelsen &
        # Musse 2005): they have no extinction field; their shadows on the media are added after
        # the light passes (cumuli.light.between.onto_media).
        medium = registry.of(d).medium
        if medium is not None:
            c, v = medium.core_args(d, settings)
            clouds += c
            volumes += v
    return clouds, volumes


def fbm_args(settings: Any) -> tuple[int, float, float, float]:
    return settings.octaves, settings.gain, settings.lacunarity, settings.frequency


def march_step(drawable: Any, step: float) -> float:
    """The step a drawable's medium is marched at where ``step`` is asked: its own
    (:attr:`cumuli.registry.Medium.step`: a lattice at a scale of its own, like a deck kilometres
    wide) or ``step``."""
    medium = registry.of(drawable).medium
    own = None if medium is None or medium.step is None else medium.step(drawable)
    return float(step) if own is None else float(own)


def optical_depth(
    drawables: Any, scene: Any, points: np.ndarray, direction: Any, step: float, threads: int
) -> np.ndarray | None:
    """``τ`` ``(N,)`` from world ``points`` towards ``direction`` through the media of
    ``drawables``, in segments of at most ``step`` (or a medium's own, :func:`march_step`)
    sampled at their midpoints; None when none is a medium. Media marched at the same step share
    one C++ call; the optical depths of the others add."""
    groups: dict[float, list[Any]] = {}
    for d in drawables:
        if registry.of(d).medium is not None:
            groups.setdefault(march_step(d, step), []).append(d)
    tau = None
    for at, group in groups.items():
        clouds, volumes = medium_args(group, scene.settings)
        part = _core.medium_optical_depth(
            clouds, volumes, scene.noise._core, *fbm_args(scene.settings), points, direction,
            at, threads,
        )  # fmt: skip
        tau = part if tau is None else tau + part
    return tau
