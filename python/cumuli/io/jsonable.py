"""JSON helpers for files that hold arrays and free-form metadata (scene files, drawables' dicts).

`jsonable` turns numpy values, tuples and mappings into JSON types (anything else becomes its
``repr``, so provenance records never make a save fail). `array_to_json` / `array_from_json`
carry a float32 array exactly and compactly (little-endian bytes in base64, with its shape),
which keeps volumes out of huge nested lists.
"""

from __future__ import annotations

import base64
import binascii
import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

#: Most values `array_from_json` accepts in one array (checked before decoding).
MAX_JSON_ARRAY_VALUES = 1 << 28
#: Most digits of an integer literal in a file read by `loads` (Python's own conversion limit is
#: 4300); a longer one is read as a float (inf beyond 308 digits), so the field that holds it
#: refuses it with its own name instead of Python's int-limit message.
MAX_INT_DIGITS = 400


def _parse_int(text: str) -> int | float:
    if len(text) - text.startswith("-") > MAX_INT_DIGITS:
        return float("inf") if not text.startswith("-") else float("-inf")
    return int(text)


def loads(text: str | bytes) -> Any:
    """``json.loads`` for files: an integer literal longer than `MAX_INT_DIGITS` digits becomes
    ±inf (refused by the field it lands in, with the field's name), never Python's int-limit
    ValueError without a file or a field."""
    return json.loads(text, parse_int=_parse_int)


def jsonable(value: Any) -> Any:
    """``value`` with numpy values, tuples and mappings converted to JSON types; non-finite
    floats and unknown objects become their ``repr``."""
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    return repr(value)


def array_to_json(array: np.ndarray) -> dict[str, Any]:
    """A float32 array as ``{"dtype": "float32", "shape": [...], "base64": "..."}`` (exact)."""
    a = np.ascontiguousarray(array, dtype="<f4")
    return {
        "dtype": "float32",
        "shape": list(a.shape),
        "base64": base64.b64encode(a.tobytes()).decode("ascii"),
    }


def array_from_json(data: Any, name: str) -> np.ndarray:
    """Inverse of `array_to_json` (a nested list is accepted too); ValueError names ``name``."""
    if isinstance(data, list):
        try:
            return np.asarray(data, dtype=np.float32)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name} is not a numeric array ({exc})") from None
    if not isinstance(data, Mapping) or set(data) != {"dtype", "shape", "base64"}:
        raise ValueError(f"{name} must be an array object with dtype, shape and base64")
    if data["dtype"] != "float32":
        raise ValueError(f"{name}.dtype must be 'float32', got {data['dtype']!r}")
    shape = data["shape"]
    if not isinstance(shape, list) or not all(
        isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in shape
    ):
        raise ValueError(f"{name}.shape must be a list of non-negative integers, got {shape!r}")
    count = math.prod(shape)
    if count > MAX_JSON_ARRAY_VALUES:
        raise ValueError(f"{name} has {count} values, more than {MAX_JSON_ARRAY_VALUES}")
    if not isinstance(data["base64"], str):
        raise ValueError(f"{name}.base64 must be a string")
    try:
        raw = base64.b64decode(data["base64"], validate=True)
    except (binascii.Error, ValueError) as exc:
        raise ValueError(f"{name}.base64 is not valid base64 ({exc})") from None
    if len(raw) != 4 * count:
        raise ValueError(f"{name} holds {len(raw)} bytes, expected {4 * count} for shape {shape}")
    return np.frombuffer(raw, dtype="<f4").astype(np.float32).reshape(shape)
