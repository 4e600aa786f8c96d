"""Billboard lighting and drawing settings (Torchelsen & Musse 2005 §3.2, §5; spec §4, §5,
§13.2): :class:`BillboardShading`, frozen and validated, what `Scene.billboard_shading` holds and
scene files store. The light fields drive the CAF light pass and the vertex/fragment colour
(`cumuli.light.caf`); the drawing fields (order, fades, culling, texture filtering) the billboard
drawers (`cumuli.rendering.billboards`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli._util import validate as check

OVERLAPS = ("sum", "union")
CURVES = ("linear", "exp")
CAF_AT = ("box", "billboard")
DIRECTIONAL = ("linear", "smoothstep")
SHADING = ("vertex", "fragment")
SORTS = ("distance", "depth")
#: Most height levels (the GLSL uniform array of common/billboard_shade.glsl).
MAX_HEIGHT_LEVELS = 16


def _choice(value: Any, name: str, options: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name} must be one of {options}, got {value!r}")
    return value


def _max_distance(value: Any, default: float) -> float:
    if value is None:
        return default
    if isinstance(value, (int, float, np.floating)) and not isinstance(value, bool):
        if math.isinf(value) and value > 0:
            return math.inf
    return check.real(value, "max_distance", 0.0, lo_open=True)


@dataclass(frozen=True)
class BillboardShading:
    """Billboard lighting settings (spec §4, §13.2); every field has the spec's default.

    ``d_min, d_max, k_dir``: the directional term; ``directional``: ``"linear"`` in
    ``(1 + cos φ)/2`` or FlightGear's ``"smoothstep"`` (``smoothstep(−0.3, 0.3, cos φ)``);
    ``ambient``: an RGB, or None for the sky's mean; ``k_amb``; ``shading``: ``"vertex"`` ([TM])
    or ``"fragment"`` (per pixel, for the renderer); ``height_levels``: ``((f, h), ...)`` height
    factor H through the cloud's box AABB (None: H ≡ 1); CAF options ``max_distance`` (None: 2 ×
    the cloud's height; ``inf``: no absorption), ``overlap``, ``caf_curve``, ``caf_at``,
    ``include_self``, ``shadow_between_clouds``; ``relight_tolerance``: degrees the sun may turn
    before a CAF record counts as stale (the light step recomputes the CAF when the sun has
    turned more than this since it was made; 0: always for the exact sun).

    Drawing (spec §5; beyond [TM] except the order): ``global_sort`` sorts all billboards of all
    clouds together (interpenetrating clouds) instead of clouds back to front, then billboards
    within each; ``sort`` the key, ``"distance"`` |p − eye| or ``"depth"`` (p − eye)·f;
    ``near``: billboards with view depth ≤ near are skipped; ``fade_near = (z0, z1)``: alpha
    × smoothstep(z0, z1, Z) (fly-through without popping); ``fade_far = R``: alpha ×
    (1 − smoothstep(0.9R, R, Z)); ``cull``: drop clouds outside the frustum and billboards off
    screen (never changes a pixel); ``exact_textures``: GL samples the atlas with texelFetch
    blends (the CPU twin's arithmetic) instead of the hardware trilinear filter over mipmaps
    (the default, faster; like ``RenderSettings.exact_noise``).
    """

    d_min: float = 0.25
    d_max: float = 1.0
    k_dir: float = 1.0
    directional: str = "linear"
    ambient: tuple[float, float, float] | None = None
    k_amb: float = 0.5
    shading: str = "vertex"
    height_levels: tuple[tuple[float, float], ...] | None = None
    max_distance: float | None = None
    overlap: str = "sum"
    caf_curve: str = "linear"
    caf_at: str = "box"
    include_self: bool = True
    shadow_between_clouds: bool = False
    relight_tolerance: float = 1.0
    global_sort: bool = False
    sort: str = "distance"
    near: float = 1e-3
    fade_near: tuple[float, float] | None = None
    fade_far: float | None = None
    cull: bool = True
    exact_textures: bool = False

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "d_min", check.real(self.d_min, "d_min", 0.0, check.MAX_COORD))
        set_(self, "d_max", check.real(self.d_max, "d_max", 0.0, check.MAX_COORD))
        if self.d_min > self.d_max:
            raise ValueError(f"d_min must be <= d_max, got {self.d_min} > {self.d_max}")
        set_(self, "k_dir", check.real(self.k_dir, "k_dir", 0.0, 100.0, lo_open=True))
        _choice(self.directional, "directional", DIRECTIONAL)
        if self.ambient is not None:
            set_(self, "ambient", check.radiance(self.ambient, "ambient"))
        set_(self, "k_amb", check.real(self.k_amb, "k_amb", 0.0, check.MAX_RADIANCE))
        _choice(self.shading, "shading", SHADING)
        if self.height_levels is not None:
            levels = self.height_levels
            if not isinstance(levels, (tuple, list)) or not levels:
                raise ValueError("height_levels must be a non-empty sequence of (f, h) pairs")
            out = []
            for lv in levels:
                if not isinstance(lv, (tuple, list)) or len(lv) != 2:
                    raise ValueError(f"height_levels entries must be (f, h), got {lv!r}")
                out.append(
                    (check.real(lv[0], "height_levels"), check.real(lv[1], "height_levels", 0.0))
                )
            if any(b[0] <= a[0] for a, b in zip(out, out[1:], strict=False)):
                raise ValueError("height_levels must have strictly increasing f")
            if len(out) > MAX_HEIGHT_LEVELS:
                raise ValueError(f"height_levels holds at most {MAX_HEIGHT_LEVELS} levels")
            set_(self, "height_levels", tuple(out))
        if self.max_distance is not None:
            set_(self, "max_distance", _max_distance(self.max_distance, math.inf))
        _choice(self.overlap, "overlap", OVERLAPS)
        _choice(self.caf_curve, "caf_curve", CURVES)
        _choice(self.caf_at, "caf_at", CAF_AT)
        for name in ("include_self", "shadow_between_clouds", "global_sort", "cull",
                     "exact_textures"):  # fmt: skip
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise TypeError(f"{name} must be a bool")
            set_(self, name, bool(getattr(self, name)))
        _choice(self.sort, "sort", SORTS)
        set_(self, "near", check.real(self.near, "near", 0.0, 1e6, lo_open=True))
        if self.fade_near is not None:
            fn = self.fade_near
            if not isinstance(fn, (tuple, list)) or len(fn) != 2:
                raise ValueError(f"fade_near must be (z0, z1), got {fn!r}")
            z0 = check.real(fn[0], "fade_near", 0.0, 1e15)
            z1 = check.real(fn[1], "fade_near", 0.0, 1e15)
            if not z0 < z1:
                raise ValueError(f"fade_near must have z0 < z1, got {fn!r}")
            set_(self, "fade_near", (z0, z1))
        if self.fade_far is not None:
            set_(self, "fade_far", check.real(self.fade_far, "fade_far", 0.0, 1e15, lo_open=True))
        set_(
            self,
            "relight_tolerance",
            check.real(self.relight_tolerance, "relight_tolerance", 0.0, 180.0),
        )

    def ambient_colour(self, sky: Any = None) -> tuple[float, float, float]:
        """The ambient RGB: the explicit one, else the sky's ``(zenith + horizon)/2`` (default
        `cumuli.scene.Sky` when ``sky`` is None)."""
        if self.ambient is not None:
            return self.ambient
        if sky is None:
            from cumuli.sky import Sky

            sky = Sky()
        z, h = np.asarray(sky.zenith, float), np.asarray(sky.horizon, float)
        return tuple(float(v) for v in 0.5 * (z + h))  # type: ignore[return-value]

    def to_dict(self) -> dict[str, Any]:
        """JSON-able fields (``max_distance = inf`` is written as the string ``"inf"``)."""
        d = {k: getattr(self, k) for k in self.__dataclass_fields__}
        if d["max_distance"] is not None and math.isinf(d["max_distance"]):
            d["max_distance"] = "inf"
        if d["ambient"] is not None:
            d["ambient"] = list(d["ambient"])
        if d["height_levels"] is not None:
            d["height_levels"] = [list(lv) for lv in d["height_levels"]]
        if d["fade_near"] is not None:
            d["fade_near"] = list(d["fade_near"])
        return d

    @classmethod
    def from_dict(cls, data: Any) -> BillboardShading:
        """Inverse of :meth:`to_dict`."""
        if not isinstance(data, dict):
            raise TypeError(f"shading must be an object, got {type(data).__name__}")
        unknown = set(data) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"shading has unknown keys {sorted(unknown)}")
        kw = dict(data)
        if kw.get("max_distance") == "inf":
            kw["max_distance"] = math.inf
        if isinstance(kw.get("height_levels"), list):
            kw["height_levels"] = tuple(
                tuple(lv) if isinstance(lv, list) else lv for lv in kw["height_levels"]
            )
        return cls(**kw)

    def draw_dict(self) -> dict[str, Any]:
        """The drawing fields as the C++ sprite-list builder takes them."""
        return {
            "caf_per_box": self.caf_at == "box",
            "global_sort": self.global_sort,
            "sort": self.sort,
            "cull": self.cull,
            "fade_near": self.fade_near,
            "fade_far": self.fade_far,
            "fragment": self.shading == "fragment",
        }

    def shade_dict(self, sky: Any = None) -> dict[str, Any]:
        """The colour parameters as the C++ shading takes them (ambient resolved for ``sky``)."""
        return {
            "d_min": self.d_min,
            "d_max": self.d_max,
            "k_dir": self.k_dir,
            "directional": self.directional,
            "ambient": self.ambient_colour(sky),
            "k_amb": self.k_amb,
            "height_levels": [tuple(lv) for lv in (self.height_levels or ())],
        }
