"""The scene: drawables of every kind under a sun, extra lights and a sky, with the noise that
fills the 2018 clouds, the render settings and an optional default camera.

A scene is a frozen, validated value that round-trips through JSON: ``scene.save(path)`` writes
atomically (temporary file in the same folder, then ``os.replace``) and :func:`load_scene` reads
it back with clear errors for a file that is not JSON or misses fields. Every drawable is stored
with its ``kind`` tag (version 2; version-1 files hold only 2018 clouds and still load); the
noise by seed and size (the lattice is regenerated bit for bit). Light is not stored: it is the
light stage's output (`cumuli.prepare_light`).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from cumuli._atomic import atomic_target
from cumuli.camera import Camera
from cumuli.ground import Ground
from cumuli.model.cloud import Cloud
from cumuli.model.volume import VolumeCloud
from cumuli.noise import Noise
from cumuli.settings import MAX_CLOUDS, RenderSettings
from cumuli.sky import Sky, Sun

#: Format tag written in every scene file.
SCENE_FORMAT = "cumuli.scene"
SCENE_VERSION = 2
#: Scene-file versions `load_scene` reads (version 1: clouds without a kind are 2018 clouds).
READABLE_VERSIONS = (1, 2)
#: Top-level fields of a scene file.
SCENE_FIELDS = (
    "format",
    "version",
    "clouds",
    "sun",
    "sky",
    "noise",
    "settings",
    "camera",
    "lights",
    "ground",
)
#: Most extra lights (`Scene.lights`).
MAX_LIGHTS = 16
#: Largest scene file `load_scene` reads (clouds are stored inline as JSON arrays).
MAX_SCENE_BYTES = 1 << 30


#: Drawable kinds a scene holds, by their scene-file tag (see ARCHITECTURE.md, "a new kind").
KINDS: dict[str, type] = {Cloud.kind: Cloud, VolumeCloud.kind: VolumeCloud}


def register_kind(cls: type) -> type:
    """Let scenes hold (and scene files carry) drawables of class ``cls``: it needs a ``kind``
    tag, ``bounds()``, ``layer_box()``, ``to_dict()`` and a ``from_dict(data, where)``
    classmethod. Returns ``cls`` (usable as a decorator)."""
    kind = getattr(cls, "kind", None)
    if not isinstance(kind, str) or not kind:
        raise TypeError(f"{cls.__name__} needs a string class attribute 'kind'")
    for name in ("bounds", "layer_box", "to_dict", "from_dict"):
        if not callable(getattr(cls, name, None)):
            raise TypeError(f"{cls.__name__} needs a {name}() method to be a drawable kind")
    KINDS[kind] = cls
    return cls


def is_drawable(obj: Any) -> bool:
    """Whether ``obj`` is an instance of a registered drawable kind."""
    return isinstance(obj, tuple(KINDS.values()))


def _sun_dict(sun: Sun) -> dict[str, Any]:
    return {
        "direction": list(sun.direction),
        "colour": list(sun.colour),
        "intensity": sun.intensity,
    }


def _drawable_from_dict(data: Any, where: str) -> Any:
    """A drawable from its scene-file dict; version-1 clouds carry no kind (2018 clouds)."""
    if not isinstance(data, Mapping):
        raise ValueError(f"{where} must be a JSON object, got {type(data).__name__}")
    kind = data.get("kind", Cloud.kind)
    cls = KINDS.get(kind)
    if cls is None:
        raise ValueError(f"{where}.kind {kind!r} is not one of {sorted(KINDS)}")
    return cls.from_dict(dict(data), where)


def _require(data: Any, keys: Sequence[str], where: str) -> None:
    if not isinstance(data, Mapping):
        raise ValueError(f"{where} must be a JSON object, got {type(data).__name__}")
    missing = [k for k in keys if k not in data]
    if missing:
        raise ValueError(f"{where} is missing field(s): {', '.join(missing)}")


def _known(cls: type, data: Mapping[str, Any], where: str) -> dict[str, Any]:
    names = {f.name for f in fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise ValueError(f"{where} has unknown field(s): {', '.join(unknown)}")
    return dict(data)


@dataclass(frozen=True)
class Scene:
    """Clouds under a sun and a sky, with the noise that fills them and the render settings.

    ``camera`` is optional: a default view used by ``cumuli render scene.json`` when the command
    line gives none (:meth:`default_camera` frames the clouds when it is None). ``ground`` is an
    optional :class:`cumuli.Ground` plane under the clouds (RENDER_CONTRACT, "Ground").
    """

    clouds: tuple[Any, ...] = ()
    sun: Sun = field(default_factory=Sun)
    sky: Sky = field(default_factory=Sky)
    noise: Noise = field(default_factory=lambda: Noise(seed=0))
    settings: RenderSettings = field(default_factory=RenderSettings)
    camera: Camera | None = None
    lights: tuple[Sun, ...] = ()
    ground: Ground | None = None

    def __post_init__(self) -> None:
        clouds = self.clouds
        if is_drawable(clouds):
            clouds = (clouds,)
        kinds = ", ".join(f"cumuli.{c.__name__}" for c in KINDS.values())
        if not isinstance(clouds, (list, tuple)):
            raise TypeError(
                f"scene.clouds must be a list of drawables ({kinds}), got {type(clouds).__name__}"
            )
        for k, c in enumerate(clouds):
            if not is_drawable(c):
                raise TypeError(
                    f"scene.clouds[{k}] must be a drawable ({kinds}), got {type(c).__name__}"
                )
        if len(clouds) > MAX_CLOUDS:
            raise ValueError(f"scene.clouds holds at most {MAX_CLOUDS} clouds, got {len(clouds)}")
        object.__setattr__(self, "clouds", tuple(clouds))
        parts = (("sun", Sun), ("sky", Sky), ("noise", Noise), ("settings", RenderSettings))
        for name, cls in parts:
            if not isinstance(getattr(self, name), cls):
                raise TypeError(f"scene.{name} must be a cumuli.{cls.__name__}")
        if self.camera is not None and not isinstance(self.camera, Camera):
            raise TypeError("scene.camera must be a cumuli.Camera or None")
        lights = self.lights
        if isinstance(lights, Sun):
            lights = (lights,)
        if not isinstance(lights, (list, tuple)) or not all(isinstance(x, Sun) for x in lights):
            raise TypeError("scene.lights must be a list of cumuli.Sun (extra directional lights)")
        if len(lights) > MAX_LIGHTS:
            raise ValueError(f"scene.lights holds at most {MAX_LIGHTS} lights, got {len(lights)}")
        object.__setattr__(self, "lights", tuple(lights))
        if self.ground is not None and not isinstance(self.ground, Ground):
            raise TypeError("scene.ground must be a cumuli.Ground or None")

    @property
    def kinds(self) -> tuple[str, ...]:
        """The kind of every drawable, in order."""
        return tuple(c.kind for c in self.clouds)

    # --- convenience ----------------------------------------------------------------------
    def replace(self, **changes: Any) -> Scene:
        """A copy with some fields changed (clouds are shared, not copied)."""
        data = {f.name: getattr(self, f.name) for f in fields(self)}
        data.update(changes)
        return Scene(**data)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World bounds of every drawable (``bounds()``: a cloud's primitives, a volume's box);
        raises ValueError for an empty scene."""
        if not self.clouds:
            raise ValueError("the scene has no clouds")
        los, his = zip(*(c.bounds() for c in self.clouds), strict=True)
        return np.min(los, axis=0), np.max(his, axis=0)

    def default_camera(self) -> Camera:
        """``self.camera``, else a camera on −z looking at the clouds' centre from a distance that
        frames them with a 50° field of view."""
        if self.camera is not None:
            return self.camera
        if not self.clouds:
            return Camera(position=(0.0, 2.0, -30.0), target=(0.0, 8.0, 0.0))
        lo, hi = self.bounds()
        centre = (lo + hi) / 2
        radius = float(np.linalg.norm(hi - lo)) / 2
        dist = radius / math.tan(math.radians(25.0)) * 1.1
        pos = centre + np.array([0.0, 0.15 * radius, -dist])
        return Camera(position=tuple(pos), target=tuple(centre))

    # --- JSON -------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The scene as JSON types (see :func:`load_scene` for the inverse)."""
        return {
            "format": SCENE_FORMAT,
            "version": SCENE_VERSION,
            "clouds": [c.to_dict() for c in self.clouds],
            "sun": _sun_dict(self.sun),
            "sky": self.sky.to_dict(),
            "noise": {"seed": self.noise.seed, "size": self.noise.size},
            "settings": self.settings.to_dict(),
            "camera": None if self.camera is None else self.camera.to_dict(),
            "lights": [_sun_dict(x) for x in self.lights],
            "ground": None if self.ground is None else self.ground.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: Any) -> Scene:
        """Build a scene from :meth:`to_dict` output; ValueError names a missing/bad field."""
        _require(data, ("clouds", "sun", "sky", "noise", "settings"), "scene")
        if data.get("format", SCENE_FORMAT) != SCENE_FORMAT:
            raise ValueError(f"scene.format must be {SCENE_FORMAT!r}, got {data.get('format')!r}")
        version = data.get("version", 1)
        if version not in READABLE_VERSIONS:
            raise ValueError(f"scene.version {version!r} is not one of {READABLE_VERSIONS}")
        known = {
            "format",
            "version",
            "clouds",
            "sun",
            "sky",
            "noise",
            "settings",
            "camera",
            "lights",
            "ground",
        }
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"scene has unknown field(s): {', '.join(unknown)}")
        if not isinstance(data["clouds"], list):
            raise ValueError("scene.clouds must be a JSON list")
        clouds = [
            _drawable_from_dict(c, f"scene.clouds[{k}]") for k, c in enumerate(data["clouds"])
        ]
        _require(data["sun"], ("direction",), "scene.sun")
        sun = Sun(**_known(Sun, data["sun"], "scene.sun"))
        lights = data.get("lights") or []
        if not isinstance(lights, list):
            raise ValueError("scene.lights must be a JSON list")
        extra = []
        for k, x in enumerate(lights):
            _require(x, ("direction",), f"scene.lights[{k}]")
            extra.append(Sun(**_known(Sun, x, f"scene.lights[{k}]")))
        _require(data["sky"], (), "scene.sky")
        sky = Sky(**_known(Sky, data["sky"], "scene.sky"))
        _require(data["noise"], ("seed",), "scene.noise")
        noise = Noise(seed=data["noise"]["seed"], size=data["noise"].get("size", 64))
        _require(data["settings"], (), "scene.settings")
        settings = RenderSettings(**_known(RenderSettings, data["settings"], "scene.settings"))
        cam = data.get("camera")
        camera = None
        if cam is not None:
            _require(cam, ("position", "target"), "scene.camera")
            camera = Camera(**_known(Camera, cam, "scene.camera"))
        ground = data.get("ground")
        ground = None if ground is None else Ground.from_dict(ground, "scene.ground")
        return cls(
            clouds=clouds, sun=sun, sky=sky, noise=noise, settings=settings, camera=camera,
            lights=tuple(extra), ground=ground,
        )  # fmt: skip

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the scene as JSON, atomically (no partial file on failure). Returns the path."""
        path = Path(path)
        text = json.dumps(self.to_dict(), indent=1)
        folder = path.parent if str(path.parent) else Path(".")
        if not folder.is_dir():
            raise OSError(f"cannot save the scene: folder {str(folder)!r} does not exist")
        with atomic_target(folder / path.name) as tmp:
            tmp.write_text(text, encoding="utf-8")
        return path


def load_scene(path: str | os.PathLike[str]) -> Scene:
    """Read a scene written by :meth:`Scene.save`.

    Raises OSError when the file cannot be read and ValueError when it is not JSON or misses
    fields (the message names the file and the field).
    """
    path = Path(path)
    try:
        size = path.stat().st_size if path.is_file() else 0
    except OSError:
        size = 0  # read_text below reports the problem
    if size > MAX_SCENE_BYTES:
        raise ValueError(f"scene file {str(path)!r} has {size} bytes, more than {MAX_SCENE_BYTES}")
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise OSError(f"cannot read scene file {str(path)!r}: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise ValueError(f"scene file {str(path)!r} is not UTF-8 JSON: {exc}") from None
    try:
        data = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:  # RecursionError: absurd nesting
        raise ValueError(f"scene file {str(path)!r} is not valid JSON: {exc}") from None
    try:
        return Scene.from_dict(data)
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"scene file {str(path)!r}: {exc}") from None
