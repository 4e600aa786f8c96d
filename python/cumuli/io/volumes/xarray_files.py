"""netCDF (``.nc``) and zarr (``.zarr``) volumes through xarray (``pip install cumuli[xarray]``).

The dataset holds one variable ``extinction`` with dimensions ``(z, y, x)``, coordinates ``x``,
``y``, ``z`` at the voxel centres (world units), the box as attributes ``box_min`` and
``box_max``, and the other attributes as given. Reading takes the variable ``extinction`` (else
the first three-dimensional variable over ``z, y, x``) and, without ``box_min``/``box_max``,
the box from evenly spaced coordinates (half a spacing beyond the first and last centres).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from cumuli._util.atomic import atomic_target
from cumuli.io.volumes.data import VolumeData

VARIABLE = "extinction"


def _xarray() -> Any:
    try:
        import xarray
    except ImportError:
        raise OSError("netCDF and zarr volumes need xarray: pip install cumuli[xarray]") from None
    return xarray


def _dataset(data: VolumeData) -> Any:
    xr = _xarray()
    lo, hi = (np.asarray(b, np.float64) for b in data.box)
    d, h, w = data.values.shape
    coords = {a: lo[i] + (np.arange(n) + 0.5) * (hi[i] - lo[i]) / n
              for i, (a, n) in enumerate((("x", w), ("y", h), ("z", d)))}  # fmt: skip
    attrs = {k: (list(v) if isinstance(v, tuple) else v) for k, v in data.attrs.items()}
    attrs |= {"box_min": lo.tolist(), "box_max": hi.tolist()}
    var = xr.Variable(("z", "y", "x"), data.values, {"long_name": "extinction coefficient"})
    return xr.Dataset({VARIABLE: var}, coords=coords, attrs=attrs)


def write_netcdf(path: Path, data: VolumeData) -> None:
    """Write ``data`` as netCDF-4 (h5netcdf or netCDF4, whichever is installed; atomically)."""
    ds = _dataset(data)
    with atomic_target(path) as tmp:
        ds.to_netcdf(tmp, engine=_netcdf_engine())


def _netcdf_engine() -> str:
    for engine, module in (("h5netcdf", "h5netcdf"), ("netcdf4", "netCDF4")):
        try:
            __import__(module)
            return engine
        except ImportError:
            continue
    raise OSError("netCDF volumes need h5netcdf or netCDF4: pip install cumuli[xarray]")


def write_zarr(path: Path, data: VolumeData) -> None:
    """Write ``data`` as a zarr store: built in a temporary folder beside ``path``, then renamed
    over it (an existing store is replaced only once the new one is complete)."""
    ds = _dataset(data)
    path = Path(path)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.tmp-", dir=path.parent))
    try:
        ds.to_zarr(tmp / "store.zarr", mode="w", consolidated=False)
        old = None
        if path.exists():
            old = path.parent / f"{tmp.name}-old"
            os.rename(path, old)
        os.rename(tmp / "store.zarr", path)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _plain(v: Any) -> Any:
    """An attribute as plain Python (tuples for arrays, ints and floats for numpy scalars)."""
    if isinstance(v, (list, np.ndarray)):
        return tuple(np.asarray(v).tolist())
    return v.item() if isinstance(v, np.generic) else v


def _from_dataset(ds: Any, path: Path) -> VolumeData:
    name = VARIABLE if VARIABLE in ds.data_vars else None
    if name is None:
        name = next((n for n, v in ds.data_vars.items() if set(v.dims) == {"x", "y", "z"}), None)
    if name is None:
        raise ValueError(f"{path} has no variable over (z, y, x)")
    var = ds[name].transpose("z", "y", "x")
    values = np.asarray(var.values)
    if values.dtype.kind != "f":
        raise TypeError(f"{path}: variable {name!r} is {values.dtype}, not floating point")
    attrs = dict(ds.attrs)
    if "box_min" in attrs and "box_max" in attrs:
        box = (tuple(map(float, attrs.pop("box_min"))), tuple(map(float, attrs.pop("box_max"))))
    else:
        lo, hi = [], []
        for a in ("x", "y", "z"):
            c = np.asarray(ds[a].values, np.float64)
            step = np.diff(c)
            if len(c) < 2 or not np.allclose(step, step[0], rtol=1e-5) or step[0] <= 0:
                raise ValueError(f"{path}: coordinate {a} is not evenly spaced and increasing")
            lo.append(c[0] - step[0] / 2)
            hi.append(c[-1] + step[0] / 2)
        box = (tuple(lo), tuple(hi))
    attrs = {k: _plain(v) for k, v in attrs.items()}
    return VolumeData(values, box, attrs)  # type: ignore[arg-type]


def read_netcdf(path: Path) -> VolumeData:
    """Read a netCDF volume."""
    xr = _xarray()
    with xr.open_dataset(path, engine=_netcdf_engine()) as ds:
        return _from_dataset(ds.load(), path)


def read_zarr(path: Path) -> VolumeData:
    """Read a zarr volume."""
    xr = _xarray()
    if not Path(path).is_dir():
        raise FileNotFoundError(f"no zarr store at {path}")
    with xr.open_zarr(path, consolidated=False) as ds:
        return _from_dataset(ds.load(), path)
