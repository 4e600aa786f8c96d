"""The light environment: the sun and the gradient sky (DESIGN §3, RENDER_CONTRACT "Sky").

`Sun` is a directional light (``direction`` points towards it); `Sky` is the background gradient
with a sun disc, whose radiance also lights the clouds where a renderer models sky light.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check


@dataclass(frozen=True)
class Sun:
    """Directional light. ``direction`` points from the scene towards the sun (normalised here);
    light travels along ``-direction``."""

    direction: tuple[float, float, float] = (0.3, 0.8, 0.2)
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "direction", check.direction(self.direction, "sun.direction"))
        colour = check.radiance(self.colour, "sun.colour")
        object.__setattr__(self, "colour", colour)
        intensity = check.real(self.intensity, "sun.intensity", 0.0, check.MAX_RADIANCE)
        if max(colour) * intensity > check.MAX_RADIANCE:
            raise ValueError(
                f"sun.colour × sun.intensity must be at most {check.MAX_RADIANCE:g} "
                f"(MAX_RADIANCE: beyond it the renderers overflow float32), got "
                f"{max(colour)} × {intensity}"
            )
        object.__setattr__(self, "intensity", intensity)

    @property
    def radiance(self) -> tuple[float, float, float]:
        """colour × intensity, what the renderer multiplies the light grid by."""
        return tuple(c * self.intensity for c in self.colour)  # type: ignore[return-value]


@dataclass(frozen=True)
class Sky:
    """A gradient sky with a sun disc (RENDER_CONTRACT "Sky"); colours are linear RGB.

    For a unit direction d: ``base = horizon + (zenith − horizon)·d.y^exponent`` above the horizon,
    ``horizon + (ground − horizon)·min(1, −8·d.y)`` below; the disc adds
    ``smoothstep(cos 1.5r, cos r, d·sun)·sun_disc_intensity·sun_radiance`` (r in degrees).
    The default is a clear daylight sky; :meth:`sunset` is the warm preset of the paper's Fig. 10.
    """

    zenith: tuple[float, float, float] = (0.20, 0.40, 0.85)
    horizon: tuple[float, float, float] = (0.62, 0.75, 0.95)
    ground: tuple[float, float, float] = (0.30, 0.30, 0.32)
    exponent: float = 0.45
    sun_disc_radius: float = 0.6
    sun_disc_intensity: float = 12.0

    def __post_init__(self) -> None:
        for name in ("zenith", "horizon", "ground"):
            object.__setattr__(self, name, check.radiance(getattr(self, name), f"sky.{name}"))
        object.__setattr__(
            self, "exponent", check.real(self.exponent, "sky.exponent", 0.0, 100.0, lo_open=True)
        )
        object.__setattr__(
            self,
            "sun_disc_radius",
            check.real(self.sun_disc_radius, "sky.sun_disc_radius", 0.0, 45.0, lo_open=True),
        )
        object.__setattr__(
            self,
            "sun_disc_intensity",
            check.real(self.sun_disc_intensity, "sky.sun_disc_intensity", 0.0, check.MAX_RADIANCE),
        )

    @classmethod
    def sunset(cls) -> Sky:
        """Warm low-sun sky: deep blue zenith, orange horizon (paper Fig. 10)."""
        return cls(
            zenith=(0.10, 0.16, 0.42),
            horizon=(1.00, 0.52, 0.26),
            ground=(0.16, 0.10, 0.09),
            exponent=0.35,
            sun_disc_radius=1.0,
            sun_disc_intensity=10.0,
        )

    def colour(self, directions: np.ndarray, sun: Sun) -> np.ndarray:
        """Sky radiance for unit directions ``(..., 3)`` (numpy twin of shaders/common/sky.glsl)."""
        d = np.asarray(directions, dtype=np.float32)
        zen, hor, gnd = (
            np.asarray(c, dtype=np.float32) for c in (self.zenith, self.horizon, self.ground)
        )
        dy = d[..., 1:2]
        up = hor + (zen - hor) * np.power(np.maximum(dy, 0), np.float32(self.exponent))
        down = hor + (gnd - hor) * np.minimum(np.float32(1), -8 * dy)
        base = np.where(dy >= 0, up, down)
        e0, e1 = (np.float32(e) for e in sun_disc_edges(self.sun_disc_radius))
        c = d @ np.asarray(sun.direction, dtype=np.float32)
        t = np.clip((c - e0) / (e1 - e0), 0, 1)
        disc = (t * t * (3 - 2 * t))[..., None] * np.float32(self.sun_disc_intensity)
        return (base + disc * np.asarray(sun.radiance, dtype=np.float32)).astype(np.float32)

    def radiance(self, directions: Any, sun: Sun | None = None) -> np.ndarray:
        """The sky's radiance (linear RGB) towards unit ``directions`` ``(N, 3)`` → ``(N, 3)``
        float32: the gradient of :meth:`colour` without the sun disc (the sun's own light is
        the directional :class:`Sun`). This is the environment the physical mode lights clouds
        with and what a reference renderer takes as its environment map; ``sun`` is accepted
        for skies whose radiance depends on it (the gradient does not)."""
        if sun is not None and not isinstance(sun, Sun):
            raise TypeError(f"sun must be a cumuli.Sun or None, got {type(sun).__name__}")
        d = check.points3(directions, "directions")
        return Sky(self.zenith, self.horizon, self.ground, self.exponent, self.sun_disc_radius,
                   0.0).colour(d, Sun())  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def as_sky(sky: Any) -> Sky:
    """A :class:`cumuli.Sky` from ``None`` (the default sky), a ``Sky``, one colour (a uniform sky:
    zenith, horizon and ground alike) or a pair ``(zenith, horizon)``."""
    if sky is None:
        return Sky()
    if isinstance(sky, Sky):
        return sky
    try:
        arr = np.asarray(sky, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(
            f"sky must be a cumuli.Sky, a colour or (zenith, horizon), got {sky!r}"
        ) from None
    if arr.shape == (3,):
        c = check.vec3(arr, "sky")
        return Sky(zenith=c, horizon=c, ground=c)
    if arr.shape == (2, 3):
        return Sky(
            zenith=check.vec3(arr[0], "sky zenith"), horizon=check.vec3(arr[1], "sky horizon")
        )
    raise ValueError(
        f"sky must be a colour (3,) or (zenith, horizon) (2, 3), got shape {arr.shape}"
    )


def sun_disc_edges(radius: float) -> tuple[float, float]:
    """The sun disc's smoothstep edges ``(cos 1.5r, cos r)`` for its radius ``r`` in degrees:
    the disc weighs ``smoothstep(cos 1.5r, cos r, d·sun)`` (RENDER_CONTRACT "Sky"; the GLSL
    ``u_sun_disc`` and :meth:`Sky.colour`)."""
    rad = math.radians(radius)
    return (math.cos(1.5 * rad), math.cos(rad))


def sky_args(sky: Sky) -> Any:
    """The sky as the core takes it: a ``_core.SkyParams``."""
    p = _core.SkyParams()
    p.zenith, p.horizon, p.ground = sky.zenith, sky.horizon, sky.ground
    p.exponent = float(sky.exponent)
    p.sun_disc_radius = float(sky.sun_disc_radius)
    p.sun_disc_intensity = float(sky.sun_disc_intensity)
    return p
