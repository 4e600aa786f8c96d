"""Drawables made of independent parts (the optional ``impostor_parts`` protocol).

A drawable whose pieces move and are seen independently — a `BillboardField`'s instances
(Torchelsen & Musse 2005 §5: "10 cloud models replicated 1000 times") — describes them with
:class:`DrawableParts` from ``drawable.impostor_parts()`` and returns part ``i`` alone, as a
drawable of its own kind in world space, from ``drawable.part(i)``. The impostor cache (Harris
2002 §3, `cumuli.rendering.impostor_cache`) then keeps one impostor **per part** (what [TM]- and
Wang-style skies of a thousand clouds need: a cloud drifting with the wind keeps its image, a
cloud that spawns or dies costs one impostor) instead of one for the whole drawable, and the
light value of such a drawable provides ``light.part(i)``, the light of part ``i`` alone.
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class DrawableParts:
    """The parts of a drawable, all arrays over its ``N`` parts (read-only).

    ``keys`` ``(N,)`` int64: a part's identity across frames (a weather's instance ids), unique;
    ``centres`` ``(N, 3)`` float64 and ``radii`` ``(N,)``: a bounding sphere of everything the
    part draws (world); ``order`` ``(N, 3)``: the point its drawer sorts the parts by, back to
    front by distance from the eye; ``anchors`` ``(N, 3)`` float64: a point that moves with the
    part (its translation since an impostor was made is the change of its anchor);
    ``signatures``: one hashable per part describing what it draws up to that translation (two
    parts with equal signatures draw the same image when moved onto each other).
    """

    keys: np.ndarray
    centres: np.ndarray
    radii: np.ndarray
    order: np.ndarray
    anchors: np.ndarray
    signatures: tuple[Hashable, ...]

    def __post_init__(self) -> None:
        n = len(self.signatures)
        shapes = {"keys": (n,), "centres": (n, 3), "radii": (n,), "order": (n, 3),
                  "anchors": (n, 3)}  # fmt: skip
        for name, shape in shapes.items():
            arr = np.array(getattr(self, name), dtype=np.int64 if name == "keys" else np.float64)
            if arr.shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        if np.unique(self.keys).size != n:
            raise ValueError("keys must be unique")

    def __len__(self) -> int:
        return len(self.signatures)
