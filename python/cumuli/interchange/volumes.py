"""``write_volume`` and ``read_volume``: a drawable's extinction field to and from the volume
files of :mod:`cumuli.io.volumes` (``.vdb``, ``.vol``, ``.nc``, ``.zarr``).

What is stored is the extinction coefficient ``σt`` per world unit on the texel-centre lattice
of :func:`cumuli.density_volume`: a 2018 ``Cloud`` (``extinction_scale·ρ`` with the noise that
fills it), a ``VolumeCloud`` (``sigma_t·density``), a ``CloudDeck`` (its baked volume), a
``ParticleCloud`` (its Gaussian-blob extinction, ``to_volume``), a ``BillboardCloud`` (through
``to_cloud``) or an ``ExtinctionField`` / ``(values, box)`` pair as it is. What is read comes
back as a ``VolumeCloud`` with ``sigma_t = 1`` (its density is the extinction), and the albedo
and phase ``g`` the file carries (else the arguments' or the defaults).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cumuli import registry
from cumuli._version import __version__
from cumuli.io import volumes as files
from cumuli.light.medium import ExtinctionField, extinction_grid
from cumuli.model.volume import VolumeCloud
from cumuli.noise import Noise
from cumuli.settings import RenderSettings

#: Longest edge of the lattice a drawable without one of its own is sampled on.
DEFAULT_RESOLUTION = 128
UNITS = "extinction coefficient per world unit"


def _kind(source: Any) -> str | None:
    return getattr(type(source), "kind", None)


def _provenance(source: Any) -> dict[str, Any]:
    params = getattr(source, "params", None) or {}
    out: dict[str, Any] = {}
    for key in ("generator", "seed"):
        value = params.get(key) if isinstance(params, dict) else None
        if isinstance(value, (str, int, float)) and not isinstance(value, bool):
            out[key] = value
    return out


def volume_field(
    source: Any,
    noise: Noise | None = None,
    settings: RenderSettings | None = None,
    resolution: int | Sequence[int] | None = None,
    threads: int = 0,
) -> tuple[ExtinctionField, dict[str, Any]]:
    """The extinction field of ``source`` (see the module docstring) and the attributes a file
    of it carries (units, extinction scale, albedo, g, kind, generator, seed, cumuli version)."""
    settings = RenderSettings() if settings is None else settings
    if not isinstance(settings, RenderSettings):
        raise TypeError(f"settings must be a cumuli.RenderSettings, got {type(settings).__name__}")
    attrs: dict[str, Any] = {"units": UNITS, "cumuli_version": __version__}
    kind = _kind(source)
    albedo, g = float(settings.albedo), float(settings.hg_g)
    if kind == "billboards":
        attrs["kind"] = "billboards"
        attrs.update(_provenance(source))
        source = source.to_cloud()
        kind = "cloud"
    if isinstance(source, tuple) and len(source) == 2 and kind is None:
        field = ExtinctionField(*source)
        attrs["extinction_scale"] = 1.0
    elif kind == "particles":
        values, box = source.to_volume(resolution or 64, threads=threads)
        field = ExtinctionField(values, box)
        attrs |= {"kind": kind, "extinction_scale": 1.0, **_provenance(source)}
    else:
        entry = registry.get(kind) if isinstance(kind, str) else None
        if entry is None or entry.medium is None:
            raise TypeError(
                "source must be a drawable with a density (Cloud, VolumeCloud, CloudDeck, "
                "ParticleCloud, BillboardCloud) or an ExtinctionField, "
                f"got {type(source).__name__}"
            )
        if kind == "cloud":
            noise = Noise() if noise is None else noise
            resolution = DEFAULT_RESOLUTION if resolution is None else resolution
            attrs["extinction_scale"] = float(settings.extinction_scale)
        else:
            attrs["extinction_scale"] = float(getattr(source, "sigma_t", 1.0))
            albedo = float(getattr(source, "albedo", albedo))
            g = float(getattr(source, "g", g))
        field = extinction_grid(source, noise, settings, resolution, 1, threads)  # type: ignore[arg-type]
        attrs.setdefault("kind", kind)
        attrs |= {k: v for k, v in _provenance(source).items() if k not in attrs}
    attrs |= {"albedo": albedo, "g": g}
    return field, attrs


def write_volume(
    path: str | Path,
    source: Any,
    noise: Noise | None = None,
    settings: RenderSettings | None = None,
    resolution: int | Sequence[int] | None = None,
    threads: int = 0,
    attrs: dict[str, Any] | None = None,
) -> Path:
    """Write the extinction field of ``source`` to ``path``, the format chosen by its extension
    (``.vdb`` OpenVDB, ``.vol`` Mitsuba 3, ``.nc`` netCDF and ``.zarr`` through xarray).

    ``source`` is a drawable with a density or an ``ExtinctionField`` (module docstring);
    ``noise`` fills a 2018 cloud (default ``Noise()``), ``settings`` gives its extinction scale,
    albedo and ``g``; ``resolution`` is the lattice's longest edge or ``(x, y, z)`` (default:
    a volume's own, 128 for a cloud, 64 for particles). ``attrs`` are added to the file's
    attributes (OpenVDB metadata, netCDF/zarr attributes; ``.vol`` has none). The file is written
    atomically: an error leaves no partial file. Returns the path.
    """
    files.format_of(path)  # an unknown extension fails before any work
    field, meta = volume_field(source, noise, settings, resolution, threads)
    if attrs is not None:
        if not isinstance(attrs, dict):
            raise TypeError(f"attrs must be a dict, got {type(attrs).__name__}")
        meta |= attrs
    return files.write(path, files.checked(field.values, field.box, meta))


def read_volume(
    path: str | Path,
    albedo: float | None = None,
    g: float | None = None,
    step: float | None = None,
    detail: float = 0.0,
    reconstruction: str = "linear",
) -> VolumeCloud:
    """Read a volume file (``.vdb``, ``.vol``, ``.nc``, ``.zarr``) as a ``VolumeCloud``: its
    density is the stored extinction (``sigma_t = 1``); ``albedo`` and ``g`` default to the
    file's attributes, else 1 and 0.2 (the ``VolumeCloud`` defaults). ``ValueError`` for an
    unknown extension or a malformed file, ``OSError`` for a missing one.

    A file is read as the medium it stores: trilinear between its voxels and no fBm erosion
    (``detail=0``), so that cumuli renders what Blender or Mitsuba render from the same file.
    Pass ``detail=0.5, reconstruction="cubic"`` for the physical mode's sharp-volume reading of
    a coarse grid (:class:`~cumuli.VolumeCloud`)."""
    data = files.read(path)
    values = data.values
    if not np.isfinite(values).all() or (values < 0).any():
        raise ValueError(f"{path}: the grid holds negative, NaN or infinite values")
    a = data.attrs.get("albedo", 1.0) if albedo is None else albedo
    gg = data.attrs.get("g", 0.2) if g is None else g
    params = {"source": str(path), "format": files.format_of(path).name}
    params |= {k: v for k, v in data.attrs.items() if isinstance(v, (str, int, float))}
    return VolumeCloud(density=values, box=data.box, sigma_t=1.0, albedo=float(a), g=float(gg),
                       step=step, params=params, detail=detail,
                       reconstruction=reconstruction)  # fmt: skip
