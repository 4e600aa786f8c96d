"""Argument checks shared by the public API: clear errors that name the parameter."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

#: Largest number of points / samples a single call accepts (keeps allocations sane).
MAX_POINTS = 1 << 28
#: Largest magnitude accepted for a coordinate or length passed to a generator (world units).
#: Far beyond any scene (float32 spacing there is ~1e8), and small enough that the sums,
#: differences and squared distances the core forms from a few such values (≲ 1e32) stay far
#: inside float32 (max 3.4e38): finite input then cannot come out as inf or NaN.
MAX_COORD = 1e15
#: Largest value of a light: a sun's radiance (colour × intensity), a sky colour, the sun-disc
#: factor, a light grid or light volume value. The renderers multiply a few of these (disc ×
#: sun radiance, sun radiance × light × phase ≤ 1e5): ≲ 1e29, far inside float32 (3.4e38), so
#: no accepted light renders as inf or NaN on either backend.
MAX_RADIANCE = 1e12
#: Largest magnitude of any real parameter: beyond it a value is inf once the core or a shader
#: converts it to float32.
FLOAT32_MAX = float(np.finfo(np.float32).max)


def points3(
    value: Any, name: str = "points", *, allow_empty: bool = True, bound: float | None = None
) -> np.ndarray:
    """Return ``value`` as a C-contiguous float32 ``(N, 3)`` array of finite numbers.

    With ``bound``, every component must also have a magnitude of at most ``bound``.
    """
    arr, biggest = points3_magnitude(value, name, allow_empty=allow_empty)
    if bound is not None and biggest > bound:
        raise ValueError(
            f"{name} has a component of magnitude {biggest:.3g}, beyond the limit ±{bound:g}"
        )
    return arr


def points3_magnitude(
    value: Any, name: str = "points", *, allow_empty: bool = True
) -> tuple[np.ndarray, float]:
    """`points3` and the largest magnitude of a component (0.0 when empty).

    Two reductions (min and max, which propagate NaN) and no temporary array: on a million
    points this is a fraction of the time ``np.isfinite(a).all()`` plus ``np.abs(a).max()`` take,
    which matters where the call itself is fast (fBm).
    """
    arr = points3_unscanned(value, name, allow_empty=allow_empty)
    if arr.size == 0:
        return arr, 0.0
    lo, hi = float(arr.min()), float(arr.max())
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr, max(-lo, hi)


def points3_unscanned(value: Any, name: str = "points", *, allow_empty: bool = True) -> np.ndarray:
    """`points3`'s type, shape and size checks and conversion, without reading the values: for a
    caller whose core call reads them anyway and reports what it found (``Noise.fbm``)."""
    if isinstance(value, np.ndarray):
        arr = value
    else:
        try:
            arr = np.asarray(value)
        except Exception as exc:  # ragged lists and the like
            raise TypeError(f"{name} must be an array of shape (N, 3): {exc}") from None
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a real numeric array, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {arr.shape}")
    if arr.shape[0] > MAX_POINTS:
        raise ValueError(f"{name} has {arr.shape[0]} rows, more than the limit {MAX_POINTS}")
    if not allow_empty and arr.shape[0] == 0:
        raise ValueError(f"{name} must not be empty")
    return np.ascontiguousarray(arr, dtype=np.float32)


def vec3(value: Any, name: str, *, bound: float | None = None) -> tuple[float, float, float]:
    """Return ``value`` as a tuple of three finite floats (each within ``±bound`` if given;
    strings are refused, not read as digits)."""
    try:
        if isinstance(value, (str, bytes)):
            raise TypeError
        items = list(value)
        if any(isinstance(v, (str, bytes, bool, np.bool_)) for v in items):
            raise TypeError
        seq = [float(v) for v in items]
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a sequence of three numbers, got {value!r}") from None
    if len(seq) != 3:
        raise ValueError(f"{name} must have three components, got {len(seq)}")
    if not all(math.isfinite(v) for v in seq):
        raise ValueError(f"{name} must be finite, got {tuple(seq)}")
    if bound is not None and max(abs(v) for v in seq) > bound:
        raise ValueError(f"{name} must have components within ±{bound:g}, got {tuple(seq)}")
    return (seq[0], seq[1], seq[2])


def radiance(value: Any, name: str) -> tuple[float, float, float]:
    """A non-negative colour with components of at most :data:`MAX_RADIANCE`."""
    colour = vec3(value, name)
    if min(colour) < 0:
        raise ValueError(f"{name} must be non-negative, got {colour}")
    if max(colour) > MAX_RADIANCE:
        raise ValueError(
            f"{name} must have components of at most {MAX_RADIANCE:g} (MAX_RADIANCE: beyond it "
            f"the renderers overflow float32), got {colour}"
        )
    return colour


def direction(value: Any, name: str) -> tuple[float, float, float]:
    """Return ``value`` normalised; zero-length or non-finite vectors are rejected. A vector that
    is already unit length (to 4 ulps) is returned as it is, so normalising is idempotent and a
    direction read back from a file equals the one saved."""
    v = vec3(value, name)
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if abs(n - 1.0) <= 4 * 2.220446049250313e-16:
        return v
    if n < 1e-12:
        raise ValueError(f"{name} must not be the zero vector")
    if math.isinf(n):  # components beyond ~1e154 overflow when squared: scale them down first
        m = max(abs(c) for c in v)
        v = (v[0] / m, v[1] / m, v[2] / m)
        n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / n, v[1] / n, v[2] / n)


def integer(value: Any, name: str, lo: int | None = None, hi: int | None = None) -> int:
    """Return ``value`` as an int within ``[lo, hi]`` (bools and floats with fractions refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        shown = f" {value!r}" if isinstance(value, (float, np.floating)) else ""
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}{shown}")
    v = int(value)
    if lo is not None and v < lo:
        raise ValueError(f"{name} must be >= {lo}, got {v}")
    if hi is not None and v > hi:
        raise ValueError(f"{name} must be <= {hi}, got {v}")
    return v


def real(
    value: Any,
    name: str,
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
) -> float:
    """Return ``value`` as a finite float within the given (optionally open) bounds."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise TypeError(f"{name} must be a number, got {type(value).__name__} {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    if abs(v) > FLOAT32_MAX:
        raise ValueError(f"{name} must be within the float32 range (±3.4e38), got {v:g}")
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise ValueError(f"{name} must be {'>' if lo_open else '>='} {lo}, got {v}")
    if hi is not None and (v > hi or (hi_open and v == hi)):
        raise ValueError(f"{name} must be {'<' if hi_open else '<='} {hi}, got {v}")
    return v


def flag(value: Any, name: str) -> bool:
    """A bool (Python or numpy); anything else (``nan``, ``"no"``, 1) is refused."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {type(value).__name__} {value!r}")
    return bool(value)


def threads(value: Any) -> int:
    """Thread count: 0 means all cores."""
    return integer(value, "threads", 0, 1024)


def shape3(value: Any, name: str, hi: int) -> tuple[int, int, int]:
    """A resolution given as one int or three ints, each in [1, hi]; returned as (x, y, z)."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        n = integer(value, name, 1, hi)
        return (n, n, n)
    if isinstance(value, Sequence) and len(value) == 3:
        a, b, c = (integer(v, name, 1, hi) for v in value)
        return (a, b, c)
    raise TypeError(f"{name} must be an int or three ints, got {value!r}")


def seed(value: Any) -> int:
    """An RNG seed: an integer in [0, 2⁶⁴)."""
    return integer(value, "seed", 0, 2**64 - 1)


def choice(value: Any, name: str, options: Sequence[str]) -> str:
    """One of ``options`` (a string), else ValueError naming ``name``."""
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name} must be one of {tuple(options)}, got {value!r}")
    return value


def pair(
    value: Any, name: str, *, positive: bool = True, bound: float | None = MAX_COORD
) -> tuple[float, float]:
    """A (lo, hi) pair of finite floats with lo <= hi, lo > 0 when ``positive``, |·| <= bound."""
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 2:
        raise TypeError(f"{name} must be a (lo, hi) pair, got {value!r}")
    floor = 0.0 if positive else (None if bound is None else -bound)
    lo = real(value[0], name, floor, bound, lo_open=positive)
    hi = real(value[1], name, floor, bound, lo_open=positive)
    if lo > hi:
        raise ValueError(f"{name} must have lo <= hi, got ({lo}, {hi})")
    return (lo, hi)


def float_array(value: Any, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` as a C-contiguous float32 array of exactly ``shape`` with finite entries
    (TypeError for a non-numeric dtype, ValueError for another shape or NaN/inf)."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a real numeric array, got dtype {arr.dtype}")
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    return arr


def uploadable(arr: np.ndarray, name: str, bound: float = FLOAT32_MAX) -> None:
    """Refuse an array about to be handed to the GPU (or the core) that holds NaN, inf or a
    magnitude beyond ``bound``: checked on what is uploaded, not on what the API once made, so
    an array flipped writable and changed after it was validated is still caught."""
    if arr.size == 0:
        return
    lo, hi = float(np.min(arr)), float(np.max(arr))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{name} contains NaN or infinite values")
    if max(-lo, hi) > bound:
        raise ValueError(f"{name} holds a value of magnitude {max(-lo, hi):.3g}, beyond ±{bound:g}")


def wind3(value: Any, name: str) -> tuple[float, float, float]:
    """A wind given as ``(wx, wz)`` (horizontal, as a deck's) or ``(wx, wy, wz)``, as three
    finite floats within ±MAX_COORD."""
    bad = f"{name} must be (wx, wz) or (wx, wy, wz) numbers, got {value!r}"
    if isinstance(value, (str, bytes)):
        raise TypeError(bad)
    try:
        parts = [float(v) for v in value]
    except (TypeError, ValueError):
        raise TypeError(bad) from None
    if len(parts) not in (2, 3):
        raise TypeError(bad)
    if len(parts) == 2:
        parts = [parts[0], 0.0, parts[1]]
    wx, wy, wz = (real(v, name, -MAX_COORD, MAX_COORD) for v in parts)
    return (wx, wy, wz)
