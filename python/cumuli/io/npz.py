"""Checked ``.npz`` archives with a JSON ``meta`` member: the file layer of cumuli's own formats.

`read_npz` reads an archive member by member, checking each declared shape against a limit
before numpy allocates it (a compressed member can declare far more than the file's size), so a
small corrupt or hostile file cannot take huge memory. Readers raise `FileFormatError` (a
ValueError naming the file).
"""

from __future__ import annotations

import json
import os
import struct
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from cumuli.io.jsonable import loads as json_loads

#: Largest file the readers accept.
MAX_FILE_BYTES = 1 << 31


def json_default(obj: Any) -> Any:
    """Let numpy scalars and arrays, tuples and sets serialise as plain JSON."""
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (tuple, set)):
        return list(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON-serialisable")


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
    except (
        zipfile.BadZipFile, EOFError, OSError, ValueError, zlib.error, struct.error,
        NotImplementedError,  # zipfile: an unknown compression method
        RuntimeError,  # zipfile: an encrypted member
    ) as exc:  # fmt: skip
        if isinstance(exc, (FileFormatError, FileNotFoundError)):
            raise
        raise FileFormatError(
            f"{path.name}: not a readable archive ({type(exc).__name__}: {exc})"
        ) from None
    return arrays


def meta_of(arrays: dict[str, np.ndarray], path: Path, fmt: str) -> dict[str, Any]:
    """The JSON ``meta`` member, checked for the format tag."""
    try:
        meta = json_loads(arrays.pop("meta").tobytes().decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise FileFormatError(f"{path.name}: unreadable metadata ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != fmt:
        raise FileFormatError(f"{path.name}: not a {fmt} file (format tag missing)")
    return meta


def meta_array(meta: dict[str, Any]) -> np.ndarray:
    """``meta`` as the JSON bytes of an archive's ``meta`` member."""
    text = json.dumps(meta, default=json_default, allow_nan=False)
    return np.frombuffer(text.encode("utf-8"), dtype=np.uint8)
