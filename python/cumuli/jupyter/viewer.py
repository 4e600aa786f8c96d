"""`Viewer`: look around a scene in a notebook with the mouse (an anywidget).

The browser side (``viewer.js``, plain ES module, no build step) shows the frame, turns mouse
drags, the wheel and its sliders into messages and trait changes; the kernel side renders with
a `ViewerSession` and sends back PNG frames: a preview while the mouse moves, the full frame
when it stops. Where widgets cannot be shown the output is the frame as a static image."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

try:
    import anywidget
    import traitlets as t
except ImportError as exc:  # pragma: no cover - depends on the installation
    raise ImportError('cumuli.Viewer needs anywidget: pip install "cumuli[jupyter]"') from exc

from cumuli.anim.weather import Weather
from cumuli.jupyter.session import ViewerSession
from cumuli.scene import Scene

_HERE = Path(__file__).parent


class Viewer(anywidget.AnyWidget):
    """An interactive view of ``source`` (a `Scene`, a `Weather` or a function ``t → Scene``):
    drag to orbit, shift-drag (or the right button) to pan, the wheel to zoom; sliders for the
    sun's azimuth and elevation, the exposure and the time (when the source has one), menus for
    the lighting mode, the tone map and the backend (``"cpu"``: the C++ twin, the faster on a
    software GL; ``"gl"``: the GLSL drawers). Keyword arguments are `ViewerSession`'s.

    The synchronised traits are the viewer's state: ``camera`` (position, target, fov, orbit
    angles), ``sun_azimuth``, ``sun_elevation``, ``lighting``, ``backend``, ``exposure``,
    ``tonemap``, ``time``; ``frame`` is the PNG shown, ``frame_kind`` ``"preview"`` or
    ``"full"``, ``frames`` counts them and ``status`` says how long the last one took.
    """

    _esm = _HERE / "viewer.js"
    _css = _HERE / "viewer.css"

    frame = t.Bytes(b"").tag(sync=True)
    frame_kind = t.Unicode("full").tag(sync=True)
    frames = t.Int(0).tag(sync=True)
    width = t.Int(960).tag(sync=True)
    height = t.Int(540).tag(sync=True)
    camera = t.Dict().tag(sync=True)
    sun_azimuth = t.Float(0.0).tag(sync=True)
    sun_elevation = t.Float(30.0).tag(sync=True)
    lighting = t.Unicode("physical").tag(sync=True)
    backend = t.Unicode("cpu").tag(sync=True)
    exposure = t.Float(0.8).tag(sync=True)
    tonemap = t.Unicode("aces").tag(sync=True)
    time = t.Float(0.0).tag(sync=True)
    duration = t.Float(0.0).tag(sync=True)
    status = t.Unicode("").tag(sync=True)
    error = t.Unicode("").tag(sync=True)

    def __init__(self, source: Scene | Weather | Callable[[float], Scene], **session: Any) -> None:
        self.session = ViewerSession(source, **session)
        s = self.session
        super().__init__(
            width=s.size[0], height=s.size[1], sun_azimuth=s.sun_azimuth,
            sun_elevation=s.sun_elevation, lighting=s.lighting, backend=s.backend,
            exposure=s.exposure, tonemap=s.tonemap, duration=s.duration,
        )  # fmt: skip
        self._draw(preview=False)
        self.observe(
            self._on_setting,
            names=["sun_azimuth", "sun_elevation", "lighting", "backend", "time"],
        )
        self.observe(self._on_look, names=["exposure", "tonemap"])
        self.on_msg(self._on_message)

    # --- drawing ---------------------------------------------------------------------------
    def _draw(self, preview: bool) -> None:
        s = self.session
        try:
            s.render(preview=preview)
        except (TypeError, ValueError, RuntimeError) as exc:
            self.error = f"{type(exc).__name__}: {exc}"
            return
        self.error = ""
        w, h = s.preview_size if preview else s.size
        took = s.timings["preview" if preview else "full"]
        self.camera = s.camera_state()
        self.frame_kind = "preview" if preview else "full"
        self.status = f"{'preview' if preview else 'full'} {w}×{h} ({s.backend}) {took:.2f} s"
        self.frame = s.png()
        self.frames += 1

    def _on_setting(self, change: dict[str, Any]) -> None:
        try:
            self.session.set(**{change["name"]: change["new"]})
        except (TypeError, ValueError) as exc:
            self.error = f"{type(exc).__name__}: {exc}"
            return
        self._draw(preview=False)

    def _on_look(self, change: dict[str, Any]) -> None:
        try:
            self.session.set(**{change["name"]: change["new"]})
        except (TypeError, ValueError) as exc:
            self.error = f"{type(exc).__name__}: {exc}"
            return
        if self.session.last is not None:  # the same linear frame, shown differently
            self.frame = self.session.png()
            self.frames += 1

    def _on_message(self, _widget: Any, content: Any, _buffers: Any) -> None:
        """Mouse messages from the browser: ``{"type": "orbit"|"pan", "dx", "dy"}``,
        ``{"type": "zoom", "factor"}`` (each answered by a preview) and ``{"type": "end"}``
        (answered by the full frame)."""
        if not isinstance(content, dict):
            return
        kind = content.get("type")
        try:
            if kind == "orbit":
                self.session.rotate(float(content["dx"]), float(content["dy"]))
            elif kind == "pan":
                self.session.pan(float(content["dx"]), float(content["dy"]), self.height)
            elif kind == "zoom":
                self.session.zoom(float(content["factor"]))
            elif kind != "end":
                return
        except (KeyError, TypeError, ValueError) as exc:
            self.error = f"{type(exc).__name__}: {exc}"
            return
        self._draw(preview=kind != "end")

    # --- where widgets cannot be shown -----------------------------------------------------
    def _repr_png_(self) -> bytes:
        return bytes(self.frame)

    def _repr_mimebundle_(self, **kwargs: Any) -> Any:
        bundle = super()._repr_mimebundle_(**kwargs)
        data = bundle[0] if isinstance(bundle, tuple) else bundle
        if isinstance(data, dict) and self.frame:
            data["image/png"] = bytes(self.frame)  # shown by frontends without widgets
        return bundle
