"""Files and dicts of billboard clouds: ``.npz`` / ``.json``, atomic writes, checked reads.

Shared by `BillboardCloud.save` / `load_billboards` / ``to_dict`` and by the weather's save file
(`read_npz` reads an archive member by member, checking each declared shape against a limit
before numpy allocates it).
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from cumuli._atomic import atomic_target
from cumuli.model.atlas import MAX_ATLAS_TEXELS, SpriteAtlas
from cumuli.model.billboards import (
    ARRAY_FIELDS,
    MAX_BILLBOARDS,
    MAX_BOXES,
    BillboardCloud,
    _json_default,
)

FILE_FORMAT = "cumuli.billboards"
FILE_VERSION = 1
#: Largest file `load` reads.
MAX_FILE_BYTES = 1 << 31
_LIMITS = {
    "boxes": 6 * MAX_BOXES,
    "box_level": MAX_BOXES,
    "box_seed": MAX_BOXES,
    "box_direction": MAX_BOXES,
    "centres": 3 * MAX_BILLBOARDS,
    "sizes": 2 * MAX_BILLBOARDS,
    "texture": MAX_BILLBOARDS,
    "box": MAX_BILLBOARDS,
    "rotation": MAX_BILLBOARDS,
    "atlas_image": 4 * MAX_ATLAS_TEXELS,
    "meta": 1 << 26,
}


class FileFormatError(ValueError):
    """A file that is not what its reader expects (a ValueError naming the file)."""


def check_path(path: Any, suffixes: tuple[str, ...]) -> Path:
    """``path`` as a Path with one of ``suffixes`` (ValueError otherwise)."""
    p = Path(os.fspath(path))
    if p.suffix.lower() not in suffixes:
        raise ValueError(f"path must end in {' or '.join(suffixes)}, got {p.name!r}")
    return p


def check_readable(path: Path, what: str) -> None:
    """FileNotFoundError / OSError / ValueError for a missing, odd, empty or huge file."""
    if not path.exists():
        raise FileNotFoundError(f"no such {what} file: {str(path)!r}")
    if not path.is_file():
        raise OSError(f"not a file: {str(path)!r}")
    size = path.stat().st_size
    if size == 0:
        raise FileFormatError(f"{path.name}: empty file")
    if size > MAX_FILE_BYTES:
        raise FileFormatError(f"{path.name}: {size} bytes, more than the limit {MAX_FILE_BYTES}")


def read_npz(
    path: Path, limits: dict[str, int], required: tuple[str, ...]
) -> dict[str, np.ndarray]:
    """Members of an ``.npz`` named in ``limits`` (each at most that many elements, no objects);
    ``required`` ones must be there. Raises FileFormatError naming the file."""
    arrays: dict[str, np.ndarray] = {}
    try:
        with zipfile.ZipFile(path) as zf:
            names = set(zf.namelist())
            for key, limit in limits.items():
                member = key + ".npy"
                if member not in names:
                    if key in required:
                        raise FileFormatError(f"{path.name}: missing array {key!r}")
                    continue
                with zf.open(member) as fh:
                    version = np.lib.format.read_magic(fh)
                    if version == (1, 0):
                        shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
                    else:
                        shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
                    count = int(np.prod(shape, dtype=np.int64)) if shape else 1
                    if dtype.hasobject or count > limit:
                        raise FileFormatError(
                            f"{path.name}: array {key!r} has unacceptable shape/dtype"
                        )
                    data = fh.read(count * dtype.itemsize)
                    if len(data) != count * dtype.itemsize:
                        raise FileFormatError(f"{path.name}: array {key!r} is truncated")
                    order = "F" if fortran else "C"
                    arrays[key] = (
                        np.frombuffer(data, dtype=dtype).reshape(shape, order=order).copy()
                    )
    except (zipfile.BadZipFile, EOFError, OSError, ValueError) as exc:
        if isinstance(exc, (FileFormatError, FileNotFoundError)):
            raise
        raise FileFormatError(f"{path.name}: not a readable archive ({exc})") from None
    return arrays


def meta_of(arrays: dict[str, np.ndarray], path: Path, fmt: str) -> dict[str, Any]:
    """The JSON ``meta`` member, checked for the format tag."""
    try:
        meta = json.loads(arrays.pop("meta").tobytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise FileFormatError(f"{path.name}: unreadable metadata ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != fmt:
        raise FileFormatError(f"{path.name}: not a {fmt} file (format tag missing)")
    return meta


def meta_array(meta: dict[str, Any]) -> np.ndarray:
    text = json.dumps(meta, default=_json_default, allow_nan=False)
    return np.frombuffer(text.encode("utf-8"), dtype=np.uint8)


# --- dicts -------------------------------------------------------------------------------------
def cloud_to_dict(cloud: BillboardCloud) -> dict[str, Any]:
    d: dict[str, Any] = {
        "kind": BillboardCloud.kind,
        "format": FILE_FORMAT,
        "version": FILE_VERSION,
    }
    for key in ARRAY_FIELDS:
        d[key] = getattr(cloud, key).tolist()
    d["opacity"] = cloud.opacity
    d["atlas"] = cloud.atlas.to_dict()  # type: ignore[union-attr]
    d["params"] = cloud.params
    d["stats"] = cloud.stats
    return d


def _shaped(value: Any, key: str, width: tuple[int, ...], dtype: Any) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{key} is not a numeric array ({exc})") from None
    if a.size == 0:  # [] has shape (0,): give it the row width
        a = a.reshape((0, *width))
    return a


def cloud_from_dict(data: Any, atlas_image: np.ndarray | None = None) -> BillboardCloud:
    if not isinstance(data, dict):
        raise TypeError(f"billboard cloud must be an object, got {type(data).__name__}")
    if data.get("kind", BillboardCloud.kind) != BillboardCloud.kind:
        raise ValueError(f"kind must be {BillboardCloud.kind!r}, got {data.get('kind')!r}")
    if data.get("version", FILE_VERSION) != FILE_VERSION:
        raise ValueError(f"unsupported billboard cloud version {data.get('version')!r}")
    widths = {"boxes": (2, 3), "centres": (3,), "sizes": (2,)}
    arrays: dict[str, np.ndarray] = {}
    for key in ARRAY_FIELDS:
        if key not in data:
            raise ValueError(f"billboard cloud is missing {key!r}")
        value = data[key]
        dtype = (
            np.int32
            if key in ("box_level", "box_seed", "box_direction", "texture", "box")
            else np.float32
        )
        arrays[key] = _shaped(value, key, widths.get(key, ()), dtype)
    atlas_d = data.get("atlas")
    if atlas_d is None:
        raise ValueError("billboard cloud is missing 'atlas'")
    if atlas_image is not None:
        if not isinstance(atlas_d, dict) or "grid" not in atlas_d or "count" not in atlas_d:
            raise ValueError("atlas must have grid and count")
        grid = atlas_d["grid"]
        if not isinstance(grid, list) or len(grid) != 2:
            raise ValueError(f"atlas grid must be [nx, ny], got {grid!r}")
        atlas = SpriteAtlas(atlas_image, (grid[0], grid[1]), atlas_d["count"])
    else:
        atlas = SpriteAtlas.from_dict(atlas_d)
    return BillboardCloud(
        **arrays,
        opacity=data.get("opacity", 0.8),
        atlas=atlas,
        params=dict(data.get("params") or {}),
        stats=dict(data.get("stats") or {}),
    )


# --- files -------------------------------------------------------------------------------------
def save(cloud: BillboardCloud, path: Any) -> Path:
    p = check_path(path, (".npz", ".json"))
    if not p.parent.is_dir():
        raise FileNotFoundError(f"folder of path does not exist: {str(p.parent)!r}")
    atlas = cloud.atlas
    assert atlas is not None
    with atomic_target(p) as tmp, open(tmp, "wb") as fh:
        if p.suffix.lower() == ".npz":
            meta = {
                "format": FILE_FORMAT,
                "version": FILE_VERSION,
                "opacity": cloud.opacity,
                "params": cloud.params,
                "stats": cloud.stats,
                "atlas": atlas.to_dict()
                if atlas.recipe is not None
                else {"grid": list(atlas.grid), "count": atlas.count},
            }
            arrays = {k: getattr(cloud, k) for k in ARRAY_FIELDS}
            arrays["meta"] = meta_array(meta)
            if atlas.recipe is None:
                arrays["atlas_image"] = atlas.image
            np.savez_compressed(fh, **arrays)
        else:
            text = json.dumps(cloud_to_dict(cloud), default=_json_default, allow_nan=False)
            fh.write(text.encode("utf-8"))
    return p


def load(path: Any) -> BillboardCloud:
    p = check_path(path, (".npz", ".json"))
    check_readable(p, "billboard cloud")
    try:
        if p.suffix.lower() == ".npz":
            arrays = read_npz(p, _LIMITS, (*ARRAY_FIELDS, "meta"))
            meta = meta_of(arrays, p, FILE_FORMAT)
            if meta.get("version") != FILE_VERSION:
                raise FileFormatError(f"{p.name}: unsupported version {meta.get('version')!r}")
            data = dict(meta)
            data.update(arrays)
            image = data.pop("atlas_image", None)
            return cloud_from_dict(data, atlas_image=image)
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
            raise FileFormatError(f"{p.name}: not readable JSON ({exc})") from None
        if not isinstance(doc, dict) or doc.get("format") != FILE_FORMAT:
            raise FileFormatError(f"{p.name}: not a {FILE_FORMAT} file (format tag missing)")
        return cloud_from_dict(doc)
    except FileFormatError:
        raise
    except (ValueError, TypeError, KeyError, IndexError) as exc:
        raise FileFormatError(f"{p.name}: invalid billboard cloud data: {exc}") from None
