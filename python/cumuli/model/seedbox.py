"""`SeedBox` and `BasisModel`: the parameters of seed-and-box billboard clouds (Torchelsen &
Musse 2005 §3.1–3.2, eq. (1); spec §2–3, §10). Generation is `cumuli.model.billboards`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli.model.atlas import SpriteAtlas, sprite_atlas

#: Per-cloud limits (spec §10), checked against the worst case before generating.
MAX_BOXES: int = int(_core.SEEDBOX_MAX_BOXES)
MAX_BILLBOARDS: int = int(_core.SEEDBOX_MAX_BILLBOARDS)
MAX_SEED_BOXES: int = int(_core.SEEDBOX_MAX_SEEDS)
COUNT_PER = ("direction", "level")
DEFAULT_DIRECTIONS = ((1.0, 0.2, 0.0), (-1.0, 0.2, 0.0), (0.0, 1.0, 0.0))
DEFAULT_APERTURES = (60.0, 60.0, 40.0)


def _int_range(value: Any, name: str, lo: int, hi: int) -> tuple[int, int]:
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise TypeError(f"{name} must be a pair (min, max), got {value!r}")
    a = check.integer(value[0], name, lo, hi)
    b = check.integer(value[1], name, lo, hi)
    if a > b:
        raise ValueError(f"{name} must have min <= max, got {(a, b)}")
    return (a, b)


def _real_range(
    value: Any, name: str, lo: float, hi: float, *, lo_open: bool = True
) -> tuple[float, float]:
    if not isinstance(value, (tuple, list)) or len(value) != 2:
        raise TypeError(f"{name} must be a pair (min, max), got {value!r}")
    a = check.real(value[0], name, lo, hi, lo_open=lo_open)
    b = check.real(value[1], name, lo, hi, lo_open=lo_open)
    if a > b:
        raise ValueError(f"{name} must have min <= max, got {(a, b)}")
    return (a, b)


@dataclass(frozen=True)
class SeedBox:
    """One seed box ([TM] §3.1): a box that grows child boxes along reproduction directions.

    ``centre`` S and ``half_size`` h (world); ``directions`` D_i (any length, the generator
    normalises them) with full cone
    ``apertures`` θ_i in degrees ([0, 360]); ``levels`` L in [1, 16]; ``boxes_per_level``
    ``(n_min, n_max)`` drawn per (level, direction) (``count_per="direction"``) or per level
    (``"level"``: each box then picks its direction uniformly); ``reach`` λ in world units (None:
    ‖h‖); children have half size ``s·h``, ``s`` uniform in ``child_scale``; every box gets
    ``billboards_per_box`` billboards; ``flat_base`` lifts boxes and billboards that would reach
    below ``S.y − h.y`` (flat cumulus bases, beyond [TM]).
    """

    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)
    half_size: tuple[float, float, float] = (4.0, 1.5, 3.0)
    directions: Sequence[Sequence[float]] = DEFAULT_DIRECTIONS  # kept as tuples
    apertures: Sequence[float] = DEFAULT_APERTURES
    levels: int = 3
    boxes_per_level: tuple[int, int] = (1, 3)
    reach: float | None = None
    child_scale: tuple[float, float] = (1.0, 1.0)
    billboards_per_box: tuple[int, int] = (4, 8)
    count_per: str = "direction"
    flat_base: bool = False

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "centre", check.vec3(self.centre, "centre", bound=check.MAX_COORD))
        h = check.vec3(self.half_size, "half_size", bound=check.MAX_COORD)
        if min(h) <= 0:
            raise ValueError(f"half_size must be positive on every axis, got {h}")
        set_(self, "half_size", h)
        dirs = self.directions
        if isinstance(dirs, np.ndarray):
            dirs = dirs.tolist()
        if not isinstance(dirs, (tuple, list)) or not 1 <= len(dirs) <= 64:
            raise ValueError("directions must hold 1 to 64 vectors (x, y, z)")
        for d in dirs:
            check.direction(d, "directions")  # finite and non-zero
        # Kept as given (the generator normalises): re-normalising on every load would change
        # the last bits, hence the clouds, of a saved model.
        set_(self, "directions", tuple(check.vec3(d, "directions") for d in dirs))
        aps = self.apertures
        if isinstance(aps, np.ndarray):
            aps = aps.tolist()
        if isinstance(aps, (int, float)) and not isinstance(aps, bool):
            aps = [aps] * len(self.directions)
        if not isinstance(aps, (tuple, list)) or len(aps) != len(self.directions):
            raise ValueError(
                f"apertures must have one entry per direction ({len(self.directions)})"
            )
        set_(self, "apertures", tuple(check.real(a, "apertures", 0.0, 360.0) for a in aps))
        set_(self, "levels", check.integer(self.levels, "levels", 1, 16))
        set_(self, "boxes_per_level", _int_range(self.boxes_per_level, "boxes_per_level", 0, 64))
        if self.reach is not None:
            set_(self, "reach", check.real(self.reach, "reach", 0.0, check.MAX_COORD, lo_open=True))
        set_(self, "child_scale", _real_range(self.child_scale, "child_scale", 0.0, 4.0))
        set_(
            self,
            "billboards_per_box",
            _int_range(self.billboards_per_box, "billboards_per_box", 0, 256),
        )
        if self.count_per not in COUNT_PER:
            raise ValueError(f"count_per must be one of {COUNT_PER}, got {self.count_per!r}")
        if not isinstance(self.flat_base, bool):
            raise TypeError(f"flat_base must be a bool, got {type(self.flat_base).__name__}")
        far = sum(abs(c) for c in self.centre) + self.levels * self.effective_reach
        if far + self.child_scale[1] * sum(h) >= check.MAX_COORD:
            raise ValueError("reach: centre + levels·reach + half sizes exceeds 1e15")

    @property
    def effective_reach(self) -> float:
        """λ in world units (``reach``, or the half-diagonal ‖h‖ when None)."""
        if self.reach is not None:
            return float(self.reach)
        return float(np.linalg.norm(np.asarray(self.half_size, dtype=np.float32)))

    @property
    def max_boxes(self) -> int:
        """Most boxes this seed box can produce, itself included."""
        per = self.boxes_per_level[1] * (
            len(self.directions) if self.count_per == "direction" else 1
        )
        return 1 + self.levels * per

    def expected_boxes(self) -> float:
        """Expected box count ``1 + L·n·(n_min + n_max)/2`` (``n = 1`` for
        ``count_per="level"``)."""
        n = len(self.directions) if self.count_per == "direction" else 1
        return 1.0 + self.levels * n * sum(self.boxes_per_level) / 2.0

    def core_dict(self) -> dict[str, Any]:
        """The arguments the C++ generator takes (reach 0 = default)."""
        d = self.to_dict()
        d["reach"] = 0.0 if self.reach is None else float(self.reach)
        return d

    def to_dict(self) -> dict[str, Any]:
        """JSON-able fields."""
        return {
            "centre": list(self.centre),
            "half_size": list(self.half_size),
            "directions": [list(d) for d in self.directions],
            "apertures": list(self.apertures),
            "levels": self.levels,
            "boxes_per_level": list(self.boxes_per_level),
            "reach": self.reach,
            "child_scale": list(self.child_scale),
            "billboards_per_box": list(self.billboards_per_box),
            "count_per": self.count_per,
            "flat_base": self.flat_base,
        }

    @classmethod
    def from_dict(cls, data: Any) -> SeedBox:
        """Inverse of :meth:`to_dict` (unknown keys are refused)."""
        if not isinstance(data, dict):
            raise TypeError(f"seed box must be an object, got {type(data).__name__}")
        unknown = set(data) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"seed box has unknown keys {sorted(unknown)}")
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})


@dataclass(frozen=True)
class BasisModel:
    """A basis model ([TM] Table 1 "NBM"): seed boxes plus billboard settings and the atlas.

    ``textures`` are the atlas sprites billboards draw from (default all); ``billboard_size``
    ``(w_min, w_max)`` scales the box's mean half size to a billboard width; heights are
    ``width·U[aspect_min, 1]``; ``rotate`` draws a rotation about the view axis per billboard;
    ``min_spacing`` > 0 drops billboards closer than that to a kept one; ``ellipsoid`` places them
    in the box's inscribed ellipsoid (both beyond [TM], off by default); ``opacity`` multiplies
    every sprite's alpha. The worst-case counts are checked here against the limits.
    """

    seeds: SeedBox | Sequence[SeedBox]  # kept as a tuple
    atlas: SpriteAtlas | None = None
    textures: tuple[int, ...] | None = None
    billboard_size: tuple[float, float] = (0.8, 1.4)
    aspect_min: float = 1.0
    rotate: bool = True
    opacity: float = 0.8
    min_spacing: float = 0.0
    ellipsoid: bool = False
    name: str = ""
    _worst: tuple[int, int] = field(default=(0, 0), init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        seeds = self.seeds
        if isinstance(seeds, SeedBox):
            seeds = (seeds,)
        if not isinstance(seeds, (tuple, list)) or not 1 <= len(seeds) <= MAX_SEED_BOXES:
            raise ValueError(f"seeds must hold 1 to {MAX_SEED_BOXES} SeedBox objects")
        for i, s in enumerate(seeds):
            if not isinstance(s, SeedBox):
                raise TypeError(f"seeds[{i}] must be a SeedBox, got {type(s).__name__}")
        set_(self, "seeds", tuple(seeds))
        atlas = self.atlas if self.atlas is not None else sprite_atlas("sunny")
        if not isinstance(atlas, SpriteAtlas):
            raise TypeError(f"atlas must be a SpriteAtlas, got {type(atlas).__name__}")
        set_(self, "atlas", atlas)
        tex = self.textures if self.textures is not None else tuple(range(atlas.count))
        if isinstance(tex, np.ndarray):
            tex = tex.tolist()
        if not isinstance(tex, (tuple, list, range)) or not tex:
            raise ValueError("textures must be a non-empty sequence of atlas indices")
        set_(self, "textures", tuple(check.integer(t, "textures", 0, atlas.count - 1) for t in tex))
        set_(self, "billboard_size", _real_range(self.billboard_size, "billboard_size", 0.0, 1e3))
        set_(self, "aspect_min", check.real(self.aspect_min, "aspect_min", 0.0, 1.0, lo_open=True))
        for name in ("rotate", "ellipsoid"):
            if not isinstance(getattr(self, name), bool):
                raise TypeError(f"{name} must be a bool")
        set_(self, "opacity", check.real(self.opacity, "opacity", 0.0, 1.0, lo_open=True))
        set_(self, "min_spacing", check.real(self.min_spacing, "min_spacing", 0.0, check.MAX_COORD))
        if not isinstance(self.name, str):
            raise TypeError("name must be a string")
        boxes, billboards = _core.seed_box_worst_case([s.core_dict() for s in self.seeds])
        if boxes > MAX_BOXES:
            raise ValueError(
                f"seeds: up to {boxes} boxes in the worst case, more than the limit {MAX_BOXES}"
            )
        if billboards > MAX_BILLBOARDS:
            raise ValueError(
                f"billboards_per_box: up to {billboards} billboards in the worst case, more than "
                f"the limit {MAX_BILLBOARDS}"
            )
        set_(self, "_worst", (int(boxes), int(billboards)))

    @property
    def worst_case(self) -> tuple[int, int]:
        """Most (boxes, billboards) a cloud of this model can have."""
        return self._worst

    def to_dict(self, atlas: bool = True) -> dict[str, Any]:
        """JSON-able fields (``atlas=False`` leaves the atlas out, as clouds' ``params`` do)."""
        d: dict[str, Any] = {
            "seeds": [s.to_dict() for s in self.seeds],
            "textures": list(self.textures or ()),
            "billboard_size": list(self.billboard_size),
            "aspect_min": self.aspect_min,
            "rotate": self.rotate,
            "opacity": self.opacity,
            "min_spacing": self.min_spacing,
            "ellipsoid": self.ellipsoid,
            "name": self.name,
        }
        if atlas:
            d["atlas"] = self.atlas.to_dict()  # type: ignore[union-attr]
        return d

    @classmethod
    def from_dict(cls, data: Any, atlas: SpriteAtlas | None = None) -> BasisModel:
        """Inverse of :meth:`to_dict`; ``atlas`` replaces (or stands in for) the stored one."""
        if not isinstance(data, dict):
            raise TypeError(f"basis model must be an object, got {type(data).__name__}")
        allowed = {f for f in cls.__dataclass_fields__ if not f.startswith("_")}
        unknown = set(data) - allowed
        if unknown:
            raise ValueError(f"basis model has unknown keys {sorted(unknown)}")
        kw = dict(data)
        seeds = kw.pop("seeds", None)
        if not isinstance(seeds, list):
            raise ValueError("basis model needs a list of seeds")
        stored = kw.pop("atlas", None)
        if atlas is None and stored is not None:
            atlas = SpriteAtlas.from_dict(stored)
        for key in ("textures", "billboard_size"):
            if isinstance(kw.get(key), list):
                kw[key] = tuple(kw[key])
        return cls(tuple(SeedBox.from_dict(s) for s in seeds), atlas=atlas, **kw)
