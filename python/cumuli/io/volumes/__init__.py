"""Volume files, one reader and one writer per format, picked by extension from :data:`FORMATS`
(as Open3D's ``io`` does): ``.vdb`` (OpenVDB, :mod:`.vdb`), ``.vol`` (Mitsuba, :mod:`.vol`),
``.nc`` and ``.zarr`` (xarray, :mod:`.xarray_files`). They know nothing of clouds: a file holds
an extinction field ``[z, y, x]`` over a box with attributes (:class:`.data.VolumeData`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

from cumuli.io.volumes import vdb, vol, xarray_files
from cumuli.io.volumes.data import VolumeData, checked


class Format(NamedTuple):
    """A volume format: its name and its reader and writer."""

    name: str
    read: Callable[[Path], VolumeData]
    write: Callable[[Path, VolumeData], None]


#: Extension → format.
FORMATS: dict[str, Format] = {
    ".vdb": Format("OpenVDB", vdb.read, vdb.write),
    ".vol": Format("Mitsuba grid volume", vol.read, vol.write),
    ".nc": Format("netCDF (xarray)", xarray_files.read_netcdf, xarray_files.write_netcdf),
    ".zarr": Format("zarr (xarray)", xarray_files.read_zarr, xarray_files.write_zarr),
}


def format_of(path: str | Path) -> Format:
    """The format of ``path`` by its extension; ``ValueError`` for an unknown one."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        known = ", ".join(FORMATS)
        raise ValueError(f"{path}: unknown volume file extension {suffix!r} (known: {known})")
    return FORMATS[suffix]


def read(path: str | Path) -> VolumeData:
    """Read a volume file (``OSError`` where it is missing)."""
    fmt = format_of(path)
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"no volume file at {p}")
    return fmt.read(p)


def write(path: str | Path, data: VolumeData) -> Path:
    """Write ``data`` (checked first) to ``path`` in the format of its extension."""
    fmt = format_of(path)
    data = checked(data.values, data.box, data.attrs)
    p = Path(path)
    if not p.parent.is_dir():
        raise FileNotFoundError(f"folder {p.parent} does not exist")
    fmt.write(p, data)
    return p


__all__ = ["FORMATS", "Format", "VolumeData", "checked", "format_of", "read", "write"]
