"""The scene: drawables of every kind under a sun, extra lights and a sky, with the noise that
fills the 2018 clouds, the render settings and an optional default camera; opaque solids
(Harris 2002's airplane stand-ins), the particle passes' `SpriteSettings` and the impostors'
`ImpostorSettings`.

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
import stat
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from cumuli import registry
from cumuli._util.atomic import atomic_target
from cumuli._util.budget import amount, get_limits
from cumuli.camera import Camera
from cumuli.ground import Ground
from cumuli.io.jsonable import loads as json_loads
from cumuli.light.billboard_shading import BillboardShading
from cumuli.light.sprite_settings import SpriteSettings
from cumuli.model.solid import Solid, as_solids
from cumuli.noise import PAPER_VERSION, Noise
from cumuli.rendering.impostors import ImpostorSettings
from cumuli.scene_cost import check_scene
from cumuli.settings import RenderSettings
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
    "solids",
    "sprite_settings",
    "impostor_settings",
    "billboard_shading",
    "ground",
)
#: Most drawables one scene holds (a field of particle clouds has thousands; the GL marcher
#: still draws at most `cumuli.settings.MAX_CLOUDS` 2018 clouds per pass).
MAX_DRAWABLES = 1 << 16
#: Most extra lights (`Scene.lights`).
MAX_LIGHTS = 16
#: Largest scene file `load_scene` reads (clouds are stored inline as JSON arrays).
MAX_SCENE_BYTES = 1 << 30


def is_drawable(obj: Any) -> bool:
    """Whether ``obj`` is an instance of a registered drawable kind (:mod:`cumuli.registry`)."""
    return registry.is_drawable(obj)


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
    kind = data.get("kind", "cloud")  # version 1: 2018 clouds only
    classes = registry.model_classes()
    cls = classes.get(kind) if isinstance(kind, str) else None
    if cls is None:
        raise ValueError(f"{where}.kind {kind!r} is not one of {sorted(classes)}")
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
    line gives none (:meth:`default_camera` frames the clouds when it is None).
    ``billboard_shading`` lights and draws the billboard clouds and fields (Torchelsen & Musse
    2005; its ambient defaults to this scene's sky). ``ground`` is an optional
    :class:`cumuli.Ground` plane under the clouds (RENDER_CONTRACT, "Ground").
    """

    clouds: Sequence[Any] = ()  # any sequence; kept as a tuple
    sun: Sun = field(default_factory=Sun)
    sky: Sky = field(default_factory=Sky)
    noise: Noise = field(default_factory=lambda: Noise(seed=0))
    settings: RenderSettings = field(default_factory=RenderSettings)
    camera: Camera | None = None
    lights: Sequence[Sun] = ()
    solids: Sequence[Solid] = ()
    sprite_settings: SpriteSettings = field(default_factory=SpriteSettings)
    impostor_settings: ImpostorSettings = field(default_factory=ImpostorSettings)
    billboard_shading: BillboardShading = field(default_factory=BillboardShading)
    ground: Ground | None = None

    def __post_init__(self) -> None:
        clouds = self.clouds
        if is_drawable(clouds):
            clouds = (clouds,)
        kinds = ", ".join(f"cumuli.{c.__name__}" for c in registry.model_classes().values())
        if not isinstance(clouds, (list, tuple)):
            raise TypeError(
                f"scene.clouds must be a list of drawables ({kinds}), got {type(clouds).__name__}"
            )
        for k, c in enumerate(clouds):
            if not is_drawable(c):
                raise TypeError(
                    f"scene.clouds[{k}] must be a drawable ({kinds}), got {type(c).__name__}"
                )
        if len(clouds) > MAX_DRAWABLES:
            raise ValueError(
                f"scene.clouds holds at most {MAX_DRAWABLES} drawables, got {len(clouds)}"
            )
        object.__setattr__(self, "clouds", tuple(clouds))
        parts = (
            ("sun", Sun),
            ("sky", Sky),
            ("noise", Noise),
            ("settings", RenderSettings),
            ("billboard_shading", BillboardShading),
        )
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
        object.__setattr__(self, "solids", as_solids(self.solids, "scene.solids"))
        for name, cls in (
            ("sprite_settings", SpriteSettings),
            ("impostor_settings", ImpostorSettings),
        ):
            if not isinstance(getattr(self, name), cls):
                raise TypeError(f"scene.{name} must be a cumuli.{cls.__name__}")
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
            "noise": {
                "seed": self.noise.seed,
                "size": self.noise.size,
                "version": self.noise.version,
            },
            "settings": self.settings.to_dict(),
            "camera": None if self.camera is None else self.camera.to_dict(),
            "lights": [_sun_dict(x) for x in self.lights],
            "solids": [x.to_dict() for x in self.solids],
            "sprite_settings": self.sprite_settings.to_dict(),
            "impostor_settings": asdict(self.impostor_settings),
            "billboard_shading": self.billboard_shading.to_dict(),
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
        known = set(SCENE_FIELDS)
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"scene has unknown field(s): {', '.join(unknown)}")
        if not isinstance(data["clouds"], list):
            raise ValueError("scene.clouds must be a JSON list")
        check_scene(data, "building the scene", get_limits().memory)
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
        unknown = sorted(set(data["noise"]) - {"seed", "size", "version"})
        if unknown:
            raise ValueError(f"scene.noise has unknown field(s): {', '.join(unknown)}")
        # Files written before noise versions existed hold version 1 noise (the table), not the
        # default: they reproduce bit for bit. Every file written since records its version.
        noise = Noise(
            seed=data["noise"]["seed"],
            size=data["noise"].get("size", 64),
            version=data["noise"].get("version", PAPER_VERSION),
        )
        _require(data["settings"], (), "scene.settings")
        settings = RenderSettings(**_known(RenderSettings, data["settings"], "scene.settings"))
        cam = data.get("camera")
        camera = None
        if cam is not None:
            _require(cam, ("position", "target"), "scene.camera")
            camera = Camera(**_known(Camera, cam, "scene.camera"))
        solids = data.get("solids") or []
        if not isinstance(solids, list):
            raise ValueError("scene.solids must be a JSON list")
        extras: dict[str, Any] = {
            "solids": tuple(Solid.from_dict(x, f"scene.solids[{k}]") for k, x in enumerate(solids))
        }
        if data.get("sprite_settings") is not None:
            try:
                extras["sprite_settings"] = SpriteSettings.from_dict(data["sprite_settings"])
            except (TypeError, ValueError) as exc:
                raise ValueError(f"scene.sprite_settings: {exc}") from None
        if data.get("impostor_settings") is not None:
            _require(data["impostor_settings"], (), "scene.impostor_settings")
            extras["impostor_settings"] = ImpostorSettings(
                **_known(ImpostorSettings, data["impostor_settings"], "scene.impostor_settings")
            )
        if data.get("billboard_shading") is not None:
            try:
                extras["billboard_shading"] = BillboardShading.from_dict(data["billboard_shading"])
            except (TypeError, ValueError) as exc:
                raise type(exc)(f"scene.billboard_shading: {exc}") from None
        ground = data.get("ground")
        extras["ground"] = None if ground is None else Ground.from_dict(ground, "scene.ground")
        return cls(
            clouds=clouds, sun=sun, sky=sky, noise=noise, settings=settings, camera=camera,
            lights=tuple(extra), **extras,
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

    Raises FileNotFoundError for a missing file, OSError when it cannot be read or is not a
    regular file (a FIFO would block), and ValueError / TypeError when it is not JSON, misses
    fields, has unknown ones or holds a wrong type (the message names the file and the field).
    """
    path = Path(path)
    try:
        info = path.stat()
    except FileNotFoundError:
        raise FileNotFoundError(
            f"cannot read scene file {str(path)!r}: it does not exist"
        ) from None
    except OSError as exc:
        raise OSError(f"cannot read scene file {str(path)!r}: {exc.strerror or exc}") from exc
    if not stat.S_ISREG(info.st_mode):  # a FIFO or a device would block or never end
        raise OSError(f"scene file {str(path)!r} is not a regular file")
    size = info.st_size
    if size > MAX_SCENE_BYTES:
        raise ValueError(f"scene file {str(path)!r} has {size} bytes, more than {MAX_SCENE_BYTES}")
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise OSError(f"cannot read scene file {str(path)!r}: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise ValueError(f"scene file {str(path)!r} is not UTF-8 JSON: {exc}") from None
    try:
        data = json_loads(text)
    except (ValueError, RecursionError) as exc:  # RecursionError: absurd nesting
        raise ValueError(f"scene file {str(path)!r} is not valid JSON: {exc}") from None
    limits = get_limits()
    allowed = limits.scene_bytes(size)
    check_scene(
        data, f"scene file {str(path)!r} of {amount(size)}", allowed,
        f"cumuli.set_limits(scene_expansion=..., scene_allowance=...) (a scene file may cost "
        f"max({limits.scene_expansion} × its size, {amount(limits.scene_allowance)}), and at "
        f"most the memory budget, {amount(limits.memory)}: set_limits(memory=...) or "
        "CUMULI_MEMORY_BUDGET; CUMULI_SCENE_ALLOWANCE)",
    )  # fmt: skip
    try:
        return Scene.from_dict(data)
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"scene file {str(path)!r}: {exc}") from None
