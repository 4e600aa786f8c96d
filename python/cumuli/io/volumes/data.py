"""What a volume file holds: an extinction field ``[z, y, x]`` float32 over a world box, with
attributes (units, scale, provenance)."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

#: Longest edge and most voxels a volume file may hold (2³⁰ float32 = 4 GiB).
MAX_EDGE = 4096
MAX_VOXELS = 1 << 30


class VolumeData(NamedTuple):
    """``values`` ``[z, y, x]`` float32 over ``box`` ``(lo, hi)``, voxel ``(i, j, k)``'s value
    at its centre ``lo + ((i, j, k) + ½)·(hi − lo)/(W, H, D)``; ``attrs`` a flat mapping of
    names to strings, numbers or 3-vectors."""

    values: np.ndarray
    box: tuple[tuple[float, float, float], tuple[float, float, float]]
    attrs: dict[str, Any]


def checked(values: Any, box: Any, attrs: Any = None) -> VolumeData:
    """A :class:`VolumeData` from arguments checked for a writer: ``TypeError`` for a non-float
    array or a malformed box, ``ValueError`` for a wrong shape, NaN, infinities, negative values
    or an empty box."""
    if not isinstance(values, np.ndarray) or values.dtype.kind != "f":
        kind = values.dtype if isinstance(values, np.ndarray) else type(values).__name__
        raise TypeError(f"values must be a float numpy array [z, y, x], got {kind}")
    if values.ndim != 3 or min(values.shape) < 1:
        raise ValueError(
            f"values must be a non-empty 3-D array [z, y, x], got shape {values.shape}"
        )
    if max(values.shape) > MAX_EDGE or values.size > MAX_VOXELS:
        raise ValueError(
            f"values of shape {values.shape} exceed {MAX_EDGE} per edge or 2^30 voxels"
        )
    with np.errstate(over="ignore"):
        arr = np.ascontiguousarray(values, np.float32)
    if not np.isfinite(arr).all():
        raise ValueError("values contain NaN or infinite values (or values beyond float32)")
    if (arr < 0).any():
        raise ValueError("values must not be negative (an extinction field)")
    try:
        lo, hi = (tuple(float(v) for v in b) for b in box)
    except (TypeError, ValueError):
        raise TypeError(f"box must be ((x, y, z), (x, y, z)), got {box!r}") from None
    if len(lo) != 3 or len(hi) != 3:
        raise TypeError(f"box must be ((x, y, z), (x, y, z)), got {box!r}")
    if not all(np.isfinite(lo + hi)) or not all(h > low for low, h in zip(lo, hi, strict=True)):
        raise ValueError(f"box must be finite with hi > lo on every axis, got {lo}, {hi}")
    return VolumeData(arr, (lo, hi), dict(attrs or {}))  # type: ignore[arg-type]
