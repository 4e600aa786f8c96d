"""Impostor mathematics of Harris 2002 §3 and §3.1.

Pure functions over the C++ core (``render/impostor.hpp``, double precision): the tight impostor
camera of a cloud's bounding sphere (:func:`impostor_view`), the translation error α_trans,
the "backwards" test, the texture-resolution rule and the "inside" test that switches to a
screen impostor. :class:`ImpostorState` records what an impostor was generated for and
:func:`needs_update` says why it must be regenerated (or None). The impostor cache
(:mod:`cumuli.rendering.impostor_cache`), its GL display and splitting around solids build on
these.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli.camera import Camera

RESOLUTION_RULES = ("paper", "skyworks")
PRESETS = ("paper", "skyworks")
#: Why an impostor is (re)generated: the §7.3 tests in the order :func:`needs_update` applies them,
#: then the cache's own: ``"split"`` (a cloud split around solids inside it, [H] §3.1.1) and
#: ``"clip"`` (a marched cloud cut at a solid inside it) regenerate every frame.
REASONS = (
    "missing", "light", "cloud", "screen", "backwards", "translation", "resolution", "split",
    "clip",
)  # fmt: skip


@dataclass(frozen=True)
class ImpostorSettings:
    """Impostor knobs (spec §7, §9), frozen and validated.

    ``tolerance``: α_trans in degrees that triggers regeneration ([H]: 0.15°, "imperceptible";
    up to 1° acceptable; SkyWorks 0.125°), in (0, 5]. ``res_scale``: factor of
    ``res_req = res_scale·f_px·2R/d``. ``min_res``, ``max_res``, ``pow2``: the generated size
    ``min(max_res, max(min_res, pow2ceil(res_req)))``. ``resolution_rule``: ``"paper"`` (that) or
    ``"skyworks"`` (``2·max(W,H)·R/d`` rounded down to a power of two, at most ``max(W,H)/2``,
    /4 and /8 near the sphere). ``inside_factor``: screen impostors are ``⌈W/f⌉ × ⌈H/f⌉`` ([H]:
    "about a factor of 4 in each dimension"), 1–8. ``near``: the view's near distance of the
    inside test. ``release_after``: frames a culled cloud keeps its textures (SkyWorks 100).
    ``exact``: GL display by texelFetch blends with the C++ arithmetic (parity ≤ 1e−5) instead of
    the hardware bilinear filter (the CPU display is always exact). ``cull``: skip clouds outside
    the view frustum (never changes the image). ``split``: split impostors around solids inside
    a cloud ([H] §3.1.1) where its kind can.
    """

    tolerance: float = 0.15
    res_scale: float = 1.0
    min_res: int = 16
    max_res: int = 2048
    pow2: bool = True
    resolution_rule: str = "paper"
    inside_factor: int = 4
    near: float = 1e-3
    release_after: int = 100
    exact: bool = False
    cull: bool = True
    split: bool = True

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        put("tolerance", check.real(self.tolerance, "tolerance", 0.0, 5.0, lo_open=True))
        put("res_scale", check.real(self.res_scale, "res_scale", 0.0, 16.0, lo_open=True))
        put("min_res", check.integer(self.min_res, "min_res", 1, 16384))
        put("max_res", check.integer(self.max_res, "max_res", self.min_res, 16384))
        if not isinstance(self.pow2, (bool, np.bool_)):
            raise TypeError(f"pow2 must be a bool, got {type(self.pow2).__name__}")
        put("pow2", bool(self.pow2))
        for name in ("exact", "cull", "split"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise TypeError(f"{name} must be a bool, got {type(getattr(self, name)).__name__}")
            put(name, bool(getattr(self, name)))
        if self.resolution_rule not in RESOLUTION_RULES:
            raise ValueError(
                f"resolution_rule must be one of {RESOLUTION_RULES}, got {self.resolution_rule!r}"
            )
        put("inside_factor", check.integer(self.inside_factor, "inside_factor", 1, 8))
        put("near", check.real(self.near, "near", 0.0, 1e6, lo_open=True))
        put("release_after", check.integer(self.release_after, "release_after", 1, 1 << 30))

    @classmethod
    def preset(cls, name: str = "paper", **changes: Any) -> ImpostorSettings:
        """``"paper"`` ([H]) or ``"skyworks"`` (0.125°, SkyWorks' resolution rule)."""
        if name == "paper":
            base = cls()
        elif name == "skyworks":
            base = cls(tolerance=0.125, resolution_rule="skyworks")
        else:
            raise ValueError(f"preset must be one of {PRESETS}, got {name!r}")
        return replace(base, **changes)


def _vec(value: Any, name: str) -> tuple[float, float, float]:
    return check.vec3(value, name, bound=check.MAX_COORD)


@dataclass(frozen=True)
class ImpostorView:
    """The tight impostor camera of a bounding sphere seen from ``eye`` (spec §7.1).

    ``forward`` n̂₀, ``right``/``up`` the camera's (world up, +x when vertical), ``distance`` d₀,
    ``half_angle`` β and ``fov`` = 2β in degrees, ``half_size`` h = d₀R/√(d₀² − R²) of the quad
    centred at ``centre`` spanned by right/up, ``near_point``/``far_point`` = e₀ + (d₀ ∓ R)n̂₀.
    """

    eye: tuple[float, float, float]
    centre: tuple[float, float, float]
    radius: float
    distance: float
    half_angle: float
    fov: float
    half_size: float
    forward: tuple[float, float, float]
    right: tuple[float, float, float]
    up: tuple[float, float, float]
    near_point: tuple[float, float, float]
    far_point: tuple[float, float, float]

    def camera(self) -> Camera:
        """A :class:`cumuli.Camera` at the eye looking at the centre with ``fov = 2β`` (aspect 1:
        render it square)."""
        return Camera(position=self.eye, target=self.centre, up=self.up, fov=self.fov)

    def quad(self) -> np.ndarray:
        """The impostor quad's corners ``(4, 3)``: bottom-left, bottom-right, top-right, top-left
        (float64); from ``eye`` it covers exactly the camera's image."""
        c, r, u = (np.asarray(v) for v in (self.centre, self.right, self.up))
        h = self.half_size
        return np.array(
            [c - h * r - h * u, c + h * r - h * u, c + h * r + h * u, c - h * r + h * u]
        )


def impostor_view(eye: Sequence[float], centre: Sequence[float], radius: float) -> ImpostorView:
    """The tight impostor camera of the sphere ``(centre, radius)`` from ``eye`` (ValueError when
    the eye is inside the sphere: use a screen impostor)."""
    e, c = _vec(eye, "eye"), _vec(centre, "centre")
    r = check.real(radius, "radius", 0.0, check.MAX_COORD, lo_open=True)
    if math.dist(e, c) <= r:
        raise ValueError("the eye is inside the bounding sphere: use a screen impostor")
    d = _core.tight_impostor_view(e, c, r)
    return ImpostorView(
        eye=e,
        centre=c,
        radius=r,
        distance=d["distance"],
        half_angle=math.degrees(d["half_angle"]),
        fov=d["fov"],
        half_size=d["half_size"],
        forward=d["forward"],
        right=d["right"],
        up=d["up"],
        near_point=d["near_point"],
        far_point=d["far_point"],
    )


def translation_error(
    near_point: Sequence[float], far_point: Sequence[float], eye: Sequence[float]
) -> float:
    """α_trans in degrees: the angle at ``eye`` between the near and far points (Fig. 6)."""
    rad = _core.impostor_translation_error(
        _vec(near_point, "near_point"), _vec(far_point, "far_point"), _vec(eye, "eye")
    )
    return math.degrees(rad)


def focal_length_px(camera: Camera, height: int) -> float:
    """``f_px = (H/2)/tan(fov/2)``: [H]'s "resolution_screen"."""
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
    height = check.integer(height, "height", 1, 1 << 15)
    return float(_core.impostor_focal_length_px(height, camera.fov))


def required_resolution(
    camera: Camera, height: int, centre: Sequence[float], radius: float, res_scale: float = 1.0
) -> float:
    """``res_req = res_scale·f_px·2R/d``, d the distance from the camera to the centre."""
    d = math.dist(check.vec3(camera.position, "camera.position"), _vec(centre, "centre"))
    r = check.real(radius, "radius", 0.0, check.MAX_COORD, lo_open=True)
    scale = check.real(res_scale, "res_scale", 0.0, 16.0, lo_open=True)
    return float(_core.impostor_required_resolution(focal_length_px(camera, height), r, d, scale))


def _tan_aspect(camera: Camera, width: int, height: int) -> tuple[float, float]:
    return math.tan(math.radians(camera.fov) / 2), width / height


def needs_screen_impostor(
    eye: Sequence[float],
    centre: Sequence[float],
    radius: float,
    camera: Camera,
    width: int,
    height: int,
    settings: ImpostorSettings | None = None,
) -> bool:
    """Spec §7.4: the eye is inside the sphere, the near plane would cut it, or the tight
    frustum (2β) is wider than the view's diagonal field of view."""
    s = _settings(settings)
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
    width = check.integer(width, "width", 1, 1 << 15)
    height = check.integer(height, "height", 1, 1 << 15)
    th, aspect = _tan_aspect(camera, width, height)
    r = check.real(radius, "radius", 0.0, check.MAX_COORD, lo_open=True)
    return bool(
        _core.needs_screen_impostor(_vec(eye, "eye"), _vec(centre, "centre"), r, th, aspect, s.near)
    )


def _settings(settings: ImpostorSettings | None) -> ImpostorSettings:
    if settings is None:
        return ImpostorSettings()
    if not isinstance(settings, ImpostorSettings):
        raise TypeError(f"settings must be an ImpostorSettings, got {type(settings).__name__}")
    return settings


def impostor_resolution(
    res_req: float,
    settings: ImpostorSettings | None = None,
    *,
    camera: Camera | None = None,
    width: int = 0,
    height: int = 0,
    radius: float = 0.0,
    distance: float = 0.0,
) -> int:
    """The texture edge an impostor is generated at. Rule ``"paper"``:
    ``min(max_res, max(min_res, pow2ceil(res_req)))``; ``"skyworks"`` needs ``camera``, image
    size, ``radius`` and ``distance``."""
    s = _settings(settings)
    if s.resolution_rule == "paper":
        req = check.real(res_req, "res_req", 0.0)
        return int(_core.impostor_resolution(req, s.min_res, s.max_res, s.pow2))
    if not isinstance(camera, Camera):
        raise TypeError("the skyworks resolution rule needs camera (a cumuli.Camera)")
    width = check.integer(width, "width", 1, 1 << 15)
    height = check.integer(height, "height", 1, 1 << 15)
    radius = check.real(radius, "radius", 0.0, check.MAX_COORD, lo_open=True)
    distance = check.real(distance, "distance", 0.0, lo_open=True)
    th, aspect = _tan_aspect(camera, width, height)
    near_r = _core.impostor_near_corner_radius(s.near, th, aspect)
    return int(
        _core.impostor_resolution_skyworks(width, height, radius, distance, near_r, s.min_res)
    )


@dataclass(frozen=True)
class ImpostorState:
    """What one cloud's impostor was generated for (spec §7.1 "Store").

    ``screen`` impostors (§7.4) have ``view = None`` and ``size = (⌈W/f⌉, ⌈H/f⌉)``; tight ones a
    :class:`ImpostorView` and ``size = (res, res)``. ``offset`` is the cloud's translation at
    generation (wind moves clouds without invalidating impostors), ``light_version`` and
    ``cloud_version`` what the impostor's image depends on.
    """

    eye: tuple[float, float, float]
    centre: tuple[float, float, float]
    radius: float
    screen: bool
    size: tuple[int, int]
    view: ImpostorView | None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    light_version: int = 0
    cloud_version: int = 0

    @property
    def res(self) -> int:
        return self.size[0]

    @classmethod
    def generate(
        cls,
        centre: Sequence[float],
        radius: float,
        camera: Camera,
        width: int,
        height: int,
        settings: ImpostorSettings | None = None,
        *,
        offset: Sequence[float] = (0.0, 0.0, 0.0),
        light_version: int = 0,
        cloud_version: int = 0,
    ) -> ImpostorState:
        """The impostor the current view needs for the sphere ``(centre, radius)`` (given at the
        cloud's current position; ``offset`` its current translation)."""
        s = _settings(settings)
        eye = check.vec3(camera.position, "camera.position")
        c = _vec(centre, "centre")
        r = check.real(radius, "radius", 0.0, check.MAX_COORD, lo_open=True)
        off = _vec(offset, "offset")
        versions = {
            "offset": off,
            "light_version": int(light_version),
            "cloud_version": int(cloud_version),
        }
        if needs_screen_impostor(eye, c, r, camera, width, height, s):
            size = (
                _core.screen_impostor_size(width, s.inside_factor),
                _core.screen_impostor_size(height, s.inside_factor),
            )
            return cls(eye, c, r, True, size, None, **versions)
        view = impostor_view(eye, c, r)
        req = required_resolution(camera, height, c, r, s.res_scale)
        res = impostor_resolution(
            req, s, camera=camera, width=width, height=height, radius=r, distance=view.distance
        )
        return cls(eye, c, r, False, (res, res), view, **versions)


def needs_update(
    state: ImpostorState | None,
    camera: Camera,
    width: int,
    height: int,
    settings: ImpostorSettings | None = None,
    *,
    offset: Sequence[float] = (0.0, 0.0, 0.0),
    light_version: int = 0,
    cloud_version: int = 0,
) -> str | None:
    """Why the impostor must be regenerated for this view, or None (spec §7.3).

    Reasons, in the order tested: ``"missing"`` (no state), ``"light"`` / ``"cloud"`` (version
    changed), ``"screen"`` (a screen impostor — regenerated every frame — or the view now needs
    one), ``"backwards"`` (the eye passed the cloud's mid-plane), ``"translation"``
    (α_trans ≥ tolerance), ``"resolution"`` (the size the rule gives now exceeds the texture's).
    A cloud translated by ``offset − state.offset`` is handled by moving the eye the other way.
    """
    s = _settings(settings)
    if state is None:
        return "missing"
    if not isinstance(state, ImpostorState):
        raise TypeError(f"state must be an ImpostorState or None, got {type(state).__name__}")
    if int(light_version) != state.light_version:
        return "light"
    if int(cloud_version) != state.cloud_version:
        return "cloud"
    shift = np.subtract(_vec(offset, "offset"), state.offset)
    eye = tuple(
        float(v) for v in np.subtract(check.vec3(camera.position, "camera.position"), shift)
    )
    width = check.integer(width, "width", 1, 1 << 15)
    height = check.integer(height, "height", 1, 1 << 15)
    return view_reason(state, eye, camera.fov, width, height, s)


def view_reason(
    state: ImpostorState,
    eye: tuple[float, float, float],
    fov: float,
    width: int,
    height: int,
    s: ImpostorSettings,
) -> str | None:
    """The view tests of :func:`needs_update` (``"screen"``, ``"backwards"``, ``"translation"``,
    ``"resolution"``) for an eye already moved by the cloud's translation; no validation (the
    impostor cache calls it for every cloud of every frame)."""
    th, aspect = math.tan(math.radians(fov) / 2), width / height
    if state.screen or _core.needs_screen_impostor(
        eye, state.centre, state.radius, th, aspect, s.near
    ):
        return "screen"
    view = state.view
    assert view is not None
    if _core.impostor_backwards(view.near_point, view.far_point, eye):
        return "backwards"
    alpha = _core.impostor_translation_error(view.near_point, view.far_point, eye)
    if math.degrees(alpha) >= s.tolerance:
        return "translation"
    d = math.dist(eye, state.centre)
    f_px = _core.impostor_focal_length_px(height, fov)
    req = float(_core.impostor_required_resolution(f_px, state.radius, d, s.res_scale))
    if s.resolution_rule == "paper":
        now = int(_core.impostor_resolution(req, s.min_res, s.max_res, s.pow2))
    else:
        near_r = _core.impostor_near_corner_radius(s.near, th, aspect)
        now = int(
            _core.impostor_resolution_skyworks(width, height, state.radius, d, near_r, s.min_res)
        )
    if now > state.res:
        return "resolution"
    return None
