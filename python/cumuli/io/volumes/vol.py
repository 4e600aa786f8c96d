"""Mitsuba's grid volume files (``.vol``, read by Mitsuba 3's ``gridvolume`` plugin).

The layout (Mitsuba's documentation of the ``gridvolume`` plugin), little-endian: bytes
``'V' 'O' 'L'``, the version byte 3, an int32 encoding (1: float32), int32 ``xres, yres,
zres``, int32 channel count, six float32 (the bounding box's min x, y, z then max x, y, z),
then the float32 data with x fastest, then y, then z (``[z, y, x]`` in C order), channels
interleaved. One channel is written; the first channel is read. The format has no room for
attributes, so none travel.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from cumuli._util.atomic import atomic_target
from cumuli.io.volumes.data import MAX_VOXELS, VolumeData

HEADER = struct.Struct("<3sBi4i6f")
VERSION = 3
FLOAT32 = 1


def encode(data: VolumeData) -> bytes:
    """The bytes of a ``.vol`` file holding ``data``."""
    d, h, w = data.values.shape
    head = HEADER.pack(b"VOL", VERSION, FLOAT32, w, h, d, 1, *data.box[0], *data.box[1])
    return head + data.values.astype("<f4", copy=False).tobytes()


def write(path: Path, data: VolumeData) -> None:
    """Write ``data`` as a Mitsuba ``.vol`` file (atomically)."""
    raw = encode(data)
    with atomic_target(path) as tmp:
        tmp.write_bytes(raw)


def decode(raw: bytes, path: Path) -> VolumeData:
    """A ``.vol`` file's first channel over its bounding box."""
    if len(raw) < HEADER.size or raw[:3] != b"VOL":
        raise ValueError(f"{path} is not a Mitsuba volume file (no 'VOL' header)")
    _, version, encoding, w, h, d, channels, *box = HEADER.unpack_from(raw)
    if version != VERSION:
        raise ValueError(f"{path}: Mitsuba volume version {version} is not supported (only 3)")
    if encoding != FLOAT32:
        raise ValueError(
            f"{path}: Mitsuba volume encoding {encoding} is not supported (1: float32)"
        )
    if min(w, h, d, channels) < 1 or w * h * d > MAX_VOXELS:
        raise ValueError(f"{path}: malformed resolution {(w, h, d)} × {channels} channels")
    count = w * h * d * channels
    if len(raw) != HEADER.size + 4 * count:
        raise ValueError(
            f"{path}: {len(raw) - HEADER.size} data bytes where {(w, h, d)} × {channels} "
            f"float32 need {4 * count} (truncated or malformed)"
        )
    values = np.frombuffer(raw, "<f4", count, HEADER.size).reshape(d, h, w, channels)[..., 0]
    lo, hi = tuple(box[:3]), tuple(box[3:])
    return VolumeData(np.ascontiguousarray(values, np.float32), (lo, hi), {})  # type: ignore[arg-type]


def read(path: Path) -> VolumeData:
    """Read a Mitsuba ``.vol`` file."""
    return decode(Path(path).read_bytes(), Path(path))
