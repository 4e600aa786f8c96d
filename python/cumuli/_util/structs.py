"""Building the parameter structs bound in ``cumuli._core`` (``FbmParams``, ``MarchSettings``,
``GaussianCumulusParams`` …) from keyword arguments."""

from __future__ import annotations

from typing import Any, TypeVar

T = TypeVar("T")


def core_struct(cls: type[T], **fields: Any) -> T:
    """A ``cls()`` (a struct bound in ``cumuli._core``) with ``fields`` set, the others at their
    C++ defaults. A name the struct lacks raises AttributeError; a bad value ValueError or
    TypeError."""
    obj = cls()
    for name, value in fields.items():
        setattr(obj, name, value)
    return obj
