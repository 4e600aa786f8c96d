"""What the viewer does in the kernel, without any widget: a scene (or a `Weather`, or any
function of time) seen through an orbit camera under a sun set by azimuth and elevation; the
light step kept while only the camera moves; cheap preview frames while the user drags and the
full frame when they stop. `Viewer` wires it to the browser; the benchmark drives it directly."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from cumuli._util import validate as check
from cumuli.anim.frames import scene_after
from cumuli.anim.weather import Weather
from cumuli.io.images import TONEMAPS, display_for, to_srgb8
from cumuli.io.png import png_bytes
from cumuli.jupyter.orbit import Orbit, angles, direction
from cumuli.light.prepare import LitScene, prepare_light
from cumuli.registry import of as kind_of
from cumuli.rendering.compositor import BACKENDS, render
from cumuli.scene import Scene
from cumuli.settings import LIGHTING_MODES
from cumuli.sky import Sun

#: What a preview frame gives up for speed (RenderSettings fields): a longer LOD step (A of
#: Δ = A·exp(−δ·d)), 3 fBm octaves, each cloud's candidate intervals marched once ("union"),
#: the paper mode's early exit at T < 0.2. The light step is the full frame's. On the default
#: scene at 240 × 135 the image moves by ~0.013 (mean |Δ| of linear RGB) for 2–5× the speed.
PREVIEW_SETTINGS = {"lod_a": 1.0, "octaves": 3, "march": "union", "min_transmittance": 0.2}
#: The weather is filmed forward in steps of at most this many seconds.
WEATHER_STEP = 1.0


def _weather_source(weather: Weather, base: Scene | None) -> Callable[[float], Scene]:
    state = {"weather": weather}

    def at(t: float) -> Scene:
        w = state["weather"]
        if t < w.t:  # the simulation only runs forward: start again (same seed, same sky)
            w = Weather(area=w.area, layers=w.layers, cv=w.schedule, seed=w.seed)
            state["weather"] = w
        while w.t < t - 1e-9:
            w.step(min(WEATHER_STEP, t - w.t))
        return w.scene_at(base)

    return at


def _animated(scene: Scene) -> bool:
    """Whether a drawable of ``scene`` moves by itself (a deck, a 2018 cloud with a wind: its
    kind's ``advance`` gives another drawable a second later)."""
    return any(
        (advance := kind_of(d).advance) is not None and advance(d, 1.0) is not d
        for d in scene.clouds
    )


class ViewerSession:
    """The viewer's state and its frames.

    ``source``: a `Scene` (with a time axis when one of its drawables moves by itself, a
    `CloudDeck`'s wind), a `Weather` (filmed over ``base``, default an empty scene) or a
    function ``t → Scene`` (an endless animation, anything that changes with time).
    ``duration``: the time axis' length in seconds (0: none).
    """

    def __init__(
        self,
        source: Scene | Weather | Callable[[float], Scene],
        *,
        base: Scene | None = None,
        camera: Any = None,
        size: tuple[int, int] = (960, 540),
        preview_size: tuple[int, int] = (240, 135),
        backend: str = "cpu",
        exposure: float | None = None,
        tonemap: str | None = None,
        duration: float | None = None,
    ) -> None:
        if isinstance(source, Weather):
            self._at: Callable[[float], Scene] | None = _weather_source(source, base)
            default_duration = 600.0
        elif isinstance(source, Scene):
            self._at = (lambda t: scene_after(source, t)) if _animated(source) else None
            default_duration = 600.0 if self._at is not None else 0.0
        elif callable(source):
            self._at = source
            default_duration = 60.0
        else:
            raise TypeError(
                "the viewer shows a cumuli.Scene, a cumuli.Weather or a function of time that "
                f"returns a Scene, got {type(source).__name__}"
            )
        self._static = source if isinstance(source, Scene) else None
        self.duration = check.real(
            default_duration if duration is None else duration, "duration", 0.0, 1e9
        )
        self.time = 0.0
        self.size = self._size(size, "size")
        self.preview_size = self._size(preview_size, "preview_size")
        self.backend = check.choice(backend, "backend", BACKENDS)
        first = self.scene_at_time()
        # Unless given, the display of the first scene's lighting mode (the paper mode untoned).
        shown = display_for(first.settings.lighting)
        self.exposure = float(shown[0] if exposure is None else exposure)
        self.tonemap = check.choice(shown[1] if tonemap is None else tonemap, "tonemap", TONEMAPS)
        to_srgb8(np.zeros((1, 1, 3), np.float32), self.exposure, self.tonemap)  # checks them
        if camera is None:
            camera = first.default_camera()
        self.orbit = Orbit.from_camera(camera)
        self.sun_azimuth, self.sun_elevation = angles(first.sun.direction)
        self.lighting = first.settings.lighting
        self._lit_key: tuple[Any, ...] | None = None
        self._lit: LitScene | None = None
        self.last: np.ndarray | None = None
        self.timings: dict[str, float] = {}

    @staticmethod
    def _size(size: Any, name: str) -> tuple[int, int]:
        try:
            w, h = size
        except (TypeError, ValueError):
            raise TypeError(f"{name} must be (width, height), got {size!r}") from None
        return check.integer(w, f"{name} width", 1, 8192), check.integer(
            h, f"{name} height", 1, 8192
        )

    # --- the scene ------------------------------------------------------------------------
    def scene_at_time(self) -> Scene:
        """The source's scene at `time`, as given (no sun or lighting of the viewer's)."""
        if self._at is None:
            assert self._static is not None
            return self._static
        scene = self._at(self.time)
        if not isinstance(scene, Scene):
            raise TypeError(f"the source returned {type(scene).__name__}, not a cumuli.Scene")
        return scene

    def scene(self) -> Scene:
        """The scene the viewer shows: the source at `time` under the viewer's sun and lighting."""
        base = self.scene_at_time()
        sun = base.sun
        sun = Sun(direction(self.sun_azimuth, self.sun_elevation), sun.colour, sun.intensity)
        settings = dataclasses.replace(base.settings, lighting=self.lighting)
        return base.replace(sun=sun, settings=settings, camera=self.orbit.camera())

    def set(self, **changes: Any) -> None:
        """Change ``sun_azimuth``, ``sun_elevation``, ``lighting``, ``backend``, ``time``,
        ``exposure`` or ``tonemap`` (checked)."""
        for name, value in changes.items():
            if name == "sun_azimuth":
                self.sun_azimuth = check.real(value, name, -360.0, 360.0)
            elif name == "sun_elevation":
                self.sun_elevation = check.real(value, name, -90.0, 90.0)
            elif name == "lighting":
                self.lighting = check.choice(value, name, LIGHTING_MODES)
            elif name == "backend":
                self.backend = check.choice(value, name, BACKENDS)
            elif name == "time":
                self.time = check.real(value, name, 0.0, max(self.duration, 0.0))
            elif name == "exposure":
                to_srgb8(np.zeros((1, 1, 3), np.float32), value, self.tonemap)
                self.exposure = float(value)
            elif name == "tonemap":
                self.tonemap = check.choice(value, name, TONEMAPS)
            else:
                raise ValueError(f"the viewer has no setting {name!r}")

    # --- the mouse --------------------------------------------------------------------------
    def rotate(self, dx: float, dy: float) -> None:
        """Orbit by a mouse drag of ``(dx, dy)`` pixels."""
        self.orbit = self.orbit.rotated(check.real(dx, "dx"), check.real(dy, "dy"))

    def pan(self, dx: float, dy: float, height: int | None = None) -> None:
        """Pan by ``(dx, dy)`` pixels of an image ``height`` tall (default: the full size)."""
        h = self.size[1] if height is None else height
        self.orbit = self.orbit.panned(check.real(dx, "dx"), check.real(dy, "dy"), h)

    def zoom(self, factor: float) -> None:
        """Move closer (``factor`` < 1) or away."""
        self.orbit = self.orbit.zoomed(check.real(factor, "factor", 1e-3, 1e3))

    # --- frames -----------------------------------------------------------------------------
    def lit(self) -> LitScene:
        """The light step for the current time, sun and lighting, made once and kept while
        only the camera moves."""
        scene = self.scene()
        key = (self.time, scene.sun, self.lighting)
        if self._lit is None or key != self._lit_key:
            t0 = time.perf_counter()
            self._lit = prepare_light(scene.replace(camera=None), progress=False)
            self._lit_key = key
            self.timings["light"] = time.perf_counter() - t0
        return self._lit

    def render(self, preview: bool = False) -> np.ndarray:
        """A linear frame from the current camera: the preview (smaller, cheaper march) or the
        full one. The light step is reused while only the camera has moved."""
        lit = self.lit()
        scene = lit.scene
        if preview:
            settings = dataclasses.replace(scene.settings, **PREVIEW_SETTINGS)
            lit = LitScene(scene.replace(settings=settings), lit.lights, lit.shadow)
        w, h = self.preview_size if preview else self.size
        t0 = time.perf_counter()
        img = render(lit, self.orbit.camera(), w, h, backend=self.backend, progress=False)
        self.timings["preview" if preview else "full"] = time.perf_counter() - t0
        self.last = img
        return img

    def png(self, img: np.ndarray | None = None) -> bytes:
        """``img`` (default: the last frame) as displayed PNG bytes (fast compression)."""
        img = self.last if img is None else img
        if img is None:
            raise ValueError("no frame rendered yet")
        return png_bytes(to_srgb8(img[..., :3], self.exposure, self.tonemap), level=1)

    def camera_state(self) -> dict[str, Any]:
        """The camera as JSON types: position, target, fov and the orbit's angles."""
        cam = self.orbit.camera()
        return {
            "position": [float(v) for v in cam.position],
            "target": [float(v) for v in cam.target],
            "fov": float(cam.fov),
            "azimuth": self.orbit.azimuth,
            "elevation": self.orbit.elevation,
            "distance": self.orbit.distance,
        }
