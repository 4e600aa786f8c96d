"""Opaque solids inside clouds (Harris 2002 §3.1.1, Fig. 7).

A :class:`Solid` is an opaque sphere — the stand-in for [H]'s airplane flying through clouds —
drawn analytically per pixel (ray–sphere, ``rendering/solids.py`` and its C++ twin
``rendering/solids.hpp``), shaded Lambert by the sun plus an ambient term:
``rgb = colour ⊙ (ambient + max(0, n·s)·sun_radiance)``. Scenes hold them in ``Scene.solids``;
the compositor lets a solid hide whatever lies behind it, the marchers stop their rays at it,
particles are depth-tested against it (direct rendering) or split around it (impostors).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli._util import validate as check

#: Most solids one scene holds (the size of the shaders' uniform arrays).
MAX_SOLIDS = 16


def _colour(value: Any, name: str) -> tuple[float, float, float]:
    """A non-negative RGB within MAX_RADIANCE (the shading multiplies it by the sun's radiance
    and the ambient light: beyond it those products overflow float32)."""
    return check.radiance(value, name)


@dataclass(frozen=True)
class Solid:
    """An opaque sphere: ``centre``, ``radius`` (> 0), linear RGB ``colour`` (its albedo) and
    ``ambient`` light (RGB added to the sun's Lambert term). Frozen and validated."""

    centre: tuple[float, float, float]
    radius: float = 1.0
    colour: tuple[float, float, float] = (0.6, 0.6, 0.62)
    ambient: tuple[float, float, float] = (0.25, 0.27, 0.3)

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", check.vec3(self.centre, "centre", bound=check.MAX_COORD))
        object.__setattr__(
            self, "radius", check.real(self.radius, "radius", 0.0, check.MAX_COORD, lo_open=True)
        )
        object.__setattr__(self, "colour", _colour(self.colour, "colour"))
        object.__setattr__(self, "ambient", _colour(self.ambient, "ambient"))

    def translated(self, offset: Sequence[float] | np.ndarray) -> Solid:
        """The solid moved by ``offset`` (an airplane flying through a cloud field)."""
        off = check.vec3(offset, "offset", bound=check.MAX_COORD)
        return Solid(
            tuple(c + o for c, o in zip(self.centre, off, strict=True)),
            self.radius,
            self.colour,
            self.ambient,
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)``: the sphere's box, float32."""
        c = np.asarray(self.centre, dtype=np.float32)
        r = np.float32(self.radius)
        return c - r, c + r

    def to_dict(self) -> dict[str, Any]:
        return {
            "centre": list(self.centre),
            "radius": self.radius,
            "colour": list(self.colour),
            "ambient": list(self.ambient),
        }

    @classmethod
    def from_dict(cls, data: Any, where: str = "solid") -> Solid:
        """A solid from :meth:`to_dict` output; ValueError names ``where`` and the field."""
        if not isinstance(data, Mapping):
            raise ValueError(f"{where} must be a JSON object, got {type(data).__name__}")
        unknown = sorted(set(data) - {"centre", "radius", "colour", "ambient"})
        if unknown:
            raise ValueError(f"{where} has unknown field(s): {', '.join(unknown)}")
        if "centre" not in data:
            raise ValueError(f"{where} is missing field(s): centre")
        try:
            return cls(**dict(data))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{where}: {exc}") from None


def as_solids(value: Any, name: str = "solids") -> tuple[Solid, ...]:
    """A tuple of at most :data:`MAX_SOLIDS` solids from one `Solid` or a sequence of them."""
    if isinstance(value, Solid):
        value = (value,)
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        raise TypeError(f"{name} must be a list of cumuli.Solid, got {type(value).__name__}")
    out = tuple(value)
    for k, s in enumerate(out):
        if not isinstance(s, Solid):
            raise TypeError(f"{name}[{k}] must be a cumuli.Solid, got {type(s).__name__}")
    if len(out) > MAX_SOLIDS:
        raise ValueError(f"{name} holds at most {MAX_SOLIDS} solids, got {len(out)}")
    return out


def solid_arrays(solids: Sequence[Solid]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(spheres (n, 4), colours (n, 3), ambient (n, 3))`` float32, as the core and the shaders
    take them (``spheres`` rows: centre x, y, z, radius)."""
    n = len(solids)
    spheres = np.zeros((n, 4), np.float32)
    colours = np.zeros((n, 3), np.float32)
    ambient = np.zeros((n, 3), np.float32)
    for k, s in enumerate(solids):
        spheres[k, :3], spheres[k, 3] = s.centre, s.radius
        colours[k], ambient[k] = s.colour, s.ambient
    return spheres, colours, ambient
