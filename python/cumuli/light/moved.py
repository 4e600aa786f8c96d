"""The light of a drawable the wind carries with its noise (a 2018 cloud with a ``wind``): the
same medium as its still self, moved, so its own light is the still one's moved — its sun
lattice's frame coordinates and its boxes shifted by the offset, its arrays shared (the light
step, :mod:`cumuli.light.physical` and the paper mode's :func:`cumuli.light.ndt.cloud_light`,
computes them once for every time)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from cumuli import registry

__all__ = ["moved", "moved_box", "moved_frame", "moved_light"]


def moved(drawable: Any) -> tuple[Any, tuple[float, float, float] | None]:
    """``(still, offset)``: the drawable is ``still`` moved by ``offset`` with its noise
    (:attr:`cumuli.registry.Medium.moved`; a 2018 cloud the wind carries), ``offset`` None when
    it is not moved."""
    medium = registry.of(drawable).medium
    if medium is None:
        return drawable, None
    still, offset = medium.moved(drawable)
    if not any(offset):  # a wind at time 0: the drawable is where it is
        return drawable, None
    return still, tuple(map(float, offset))


def moved_frame(frame: tuple, offset: Any) -> tuple:
    """A sun lattice ``frame`` moved by ``offset`` in the world: the same axes and nodes, its
    frame coordinates shifted by the offset's (``offset·u, offset·v, offset·w``)."""
    if offset is None:
        return frame
    u, v, w, lo, hi, res = frame
    shift = tuple(float(np.dot(axis, offset)) for axis in (u, v, w))
    return (u, v, w, tuple(a + b for a, b in zip(lo, shift, strict=True)),
            tuple(a + b for a, b in zip(hi, shift, strict=True)), res)  # fmt: skip


def moved_box(box: tuple, offset: Any) -> tuple:
    """A world box ``(lo, hi)`` moved by ``offset`` (itself, as tuples of floats, when None)."""
    lo, hi = (tuple(float(v) for v in b) for b in box)
    if offset is None:
        return (lo, hi)
    return (tuple(a + o for a, o in zip(lo, offset, strict=True)),
            tuple(a + o for a, o in zip(hi, offset, strict=True)))  # fmt: skip


def moved_light(light: Any, offset: Any) -> Any:
    """A drawable's own light (no other drawable's shade in it) moved by ``offset``: the light
    of the drawable moved there with its noise."""
    if offset is None:
        return light
    return dataclasses.replace(
        light, frame=moved_frame(light.frame, offset), box=moved_box(light.box, offset)
    )
