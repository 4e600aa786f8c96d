"""Scene description: camera, sky, render settings and the scene (DESIGN §4, RENDER_CONTRACT).

Every class here is a frozen, validated dataclass that round-trips through JSON:
``scene.save(path)`` writes atomically (temporary file in the same folder, then ``os.replace``)
and :func:`load_scene` reads it back with clear errors for a file that is not JSON or misses
fields. Clouds are stored with their primitive arrays and parameters; the noise by seed and size
(the lattice is regenerated bit for bit); light grids are not stored — the renderer recomputes
them on demand.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from cumuli import _validate as check
from cumuli._atomic import atomic_target
from cumuli.cloud import Cloud
from cumuli.noise import Noise
from cumuli.sun import Sun

#: Format tag written in every scene file.
SCENE_FORMAT = "cumuli.scene"
SCENE_VERSION = 1
#: Upper bounds of the settings that size shader loops and arrays (see shaders/march.frag.glsl).
MAX_CANDIDATES = 128
MAX_STEPS = 1 << 16
MAX_CLOUDS = 64
MARCH_MODES = ("paper", "union")
#: Candidate sorts of the GL marcher (compile-time variants of shaders/march.frag.glsl).
CANDIDATE_SORTS = ("insertion", "quicksort", "oddeven", "none")
#: Largest scene file `load_scene` reads (clouds are stored inline as JSON arrays).
MAX_SCENE_BYTES = 1 << 30
LIGHT_METHODS = ("ndt", "naive")


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.cross(a, b).astype(np.float32)


def _normalise(v: np.ndarray) -> np.ndarray:
    # glm::normalize's float32 operations (v · 1/√(v·v), dot summed x, y, z), so that the GL
    # marcher's camera basis is the C++ marcher's bit for bit.
    v = np.asarray(v, dtype=np.float32)
    d = (v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]
    return (v * (np.float32(1) / np.sqrt(d))).astype(np.float32)


# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Camera:
    """A pinhole camera. ``fov`` is the VERTICAL field of view in degrees (RENDER_CONTRACT).

    ``position`` looks at ``target``; ``up`` only fixes the roll and must not be parallel to the
    view direction.
    """

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov: float = 50.0

    def __post_init__(self) -> None:
        pos = check.vec3(self.position, "camera.position")
        tgt = check.vec3(self.target, "camera.target")
        up = check.direction(self.up, "camera.up")
        fov = check.real(self.fov, "camera.fov", 0.0, 180.0, lo_open=True, hi_open=True)
        view = np.subtract(tgt, pos, dtype=np.float64)
        dist = float(np.linalg.norm(view))
        if dist < 1e-6 * max(1.0, float(np.abs(pos).max())):
            raise ValueError("camera.target must differ from camera.position")
        if np.linalg.norm(np.cross(view / dist, up)) < 1e-6:
            raise ValueError("camera.up must not be parallel to the view direction")
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "target", tgt)
        object.__setattr__(self, "up", up)
        object.__setattr__(self, "fov", fov)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(f, r, u)``: forward, right and up unit vectors, float32, as RENDER_CONTRACT says."""
        pos = np.asarray(self.position, dtype=np.float32)
        f = _normalise(np.asarray(self.target, dtype=np.float32) - pos)
        r = _normalise(_cross(f, np.asarray(self.up, dtype=np.float32)))
        u = _cross(r, f)
        return f, r, u

    def ray_directions(self, width: int, height: int) -> np.ndarray:
        """Unit ray directions ``(H, W, 3)`` float32, row 0 at the top (the contract's formula).

        A slow numpy reference of what the shader computes per pixel.
        """
        width = check.integer(width, "width", 1, 1 << 14)
        height = check.integer(height, "height", 1, 1 << 14)
        f, r, u = self.basis()
        th = np.float32(math.tan(math.radians(self.fov) / 2))
        aspect = np.float32(width / height)
        j = np.arange(width, dtype=np.float32)
        i = np.arange(height, dtype=np.float32)
        x = (np.float32(2) * (j + np.float32(0.5)) / np.float32(width) - 1) * th * aspect
        y = (1 - np.float32(2) * (i + np.float32(0.5)) / np.float32(height)) * th
        d = f[None, None] + x[None, :, None] * r[None, None] + y[:, None, None] * u[None, None]
        return (d / np.linalg.norm(d, axis=-1, keepdims=True)).astype(np.float32)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


# --------------------------------------------------------------------------------------------
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
            colour = check.vec3(getattr(self, name), f"sky.{name}")
            if min(colour) < 0:
                raise ValueError(f"sky.{name} must be non-negative, got {colour}")
            object.__setattr__(self, name, colour)
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
            check.real(self.sun_disc_intensity, "sky.sun_disc_intensity", 0.0),
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
        """Sky radiance for unit directions ``(..., 3)`` (numpy reference of shaders/sky.glsl)."""
        d = np.asarray(directions, dtype=np.float32)
        zen, hor, gnd = (
            np.asarray(c, dtype=np.float32) for c in (self.zenith, self.horizon, self.ground)
        )
        dy = d[..., 1:2]
        up = hor + (zen - hor) * np.power(np.maximum(dy, 0), np.float32(self.exponent))
        down = hor + (gnd - hor) * np.minimum(np.float32(1), -8 * dy)
        base = np.where(dy >= 0, up, down)
        rad = math.radians(self.sun_disc_radius)
        e0, e1 = np.float32(math.cos(1.5 * rad)), np.float32(math.cos(rad))
        c = d @ np.asarray(sun.direction, dtype=np.float32)
        t = np.clip((c - e0) / (e1 - e0), 0, 1)
        disc = (t * t * (3 - 2 * t))[..., None] * np.float32(self.sun_disc_intensity)
        return (base + disc * np.asarray(sun.radiance, dtype=np.float32)).astype(np.float32)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RenderSettings:
    """Knobs of the render pass (RENDER_CONTRACT), shared by the GL and CPU marchers.

    Attributes
    ----------
    kappa:
        When not None, overrides every spheroid cloud's κ of eq. (2).
    absorption:
        φ of ``Δτ = exp(−φ·ρ·Δ/Δ_ref)`` (Algorithm 3, made step-size independent).
    lod_a, lod_delta:
        A and δ of the LOD step ``Δ = A·exp(−δ·|camera − cloud centre|)`` (Algorithm 1 line 50).
    step_ref:
        Δ_ref, the step at which ``Δτ`` is exactly the paper's ``exp(−φρ)``.
    step_min, step_max:
        Clamp of the LOD step.
    fixed_step:
        When > 0, replaces the LOD step (the paper uses 0.1 for its mesh tests).
    hg_g:
        Henyey-Greenstein asymmetry g of eq. (14), in (−1, 1).
    max_steps:
        Most samples marched per pixel, over all clouds (keeps every loop bounded).
    max_candidates:
        Most candidate primitives kept per ray and cloud (the nearest ones).
    march:
        ``"paper"`` marches each candidate interval on its own (overlaps twice, as the paper);
        ``"union"`` marches the union of the intervals once.
    candidate_sort:
        How the GL marcher orders a ray's candidates: ``"insertion"`` (the paper's insertion
        sort, as candidates arrive), ``"quicksort"`` (iterative, the alternative the paper
        tried) or ``"oddeven"`` (Batcher's odd-even mergesort, the one it suggests) give the
        same order — by ``t_in``, ties by primitive index — at different costs; ``"none"``
        leaves them unsorted (a cost reference: wrong where intervals overlap). The CPU marcher
        orders by the same key for the first three and leaves ``"none"`` unsorted too.
    exact_noise:
        Use exact float trilinear lookups (texelFetch) for the noise and the light grid instead
        of the hardware filter; the parity tests use it.
    octaves, gain, lacunarity, frequency:
        fBm of eq. (1): n, w, s and f (lattice texels per world unit).
    light_resolution:
        Edge of the light grid computed on demand for clouds without one.
    light_method, light_step, light_extinction:
        How that grid is computed (:func:`cumuli.light_grid`): ``"ndt"`` (Algorithm 2) or
        ``"naive"``, its march step and the extinction ``A`` of eq. (3) per world unit.
    """

    kappa: float | None = None
    absorption: float = 1.2
    lod_a: float = 0.25
    lod_delta: float = 0.004
    step_ref: float = 0.1
    step_min: float = 0.02
    step_max: float = 1.0
    fixed_step: float = 0.0
    hg_g: float = 0.6
    max_steps: int = 4096
    max_candidates: int = 64
    march: str = "paper"
    candidate_sort: str = "insertion"
    exact_noise: bool = False
    octaves: int = 5
    gain: float = 0.5
    lacunarity: float = 2.0
    frequency: float = 0.3
    light_resolution: int = 20
    light_method: str = "ndt"
    light_step: float = 0.1
    light_extinction: float = 1.0

    def __post_init__(self) -> None:
        s = object.__setattr__
        if self.kappa is not None:
            s(self, "kappa", check.real(self.kappa, "settings.kappa", 0.0, 1.0))
        s(self, "absorption", check.real(self.absorption, "settings.absorption", 0.0))
        s(self, "lod_a", check.real(self.lod_a, "settings.lod_a", 0.0, lo_open=True))
        s(self, "lod_delta", check.real(self.lod_delta, "settings.lod_delta", 0.0))
        s(self, "step_ref", check.real(self.step_ref, "settings.step_ref", 0.0, lo_open=True))
        s(self, "step_min", check.real(self.step_min, "settings.step_min", 1e-5))
        s(self, "step_max", check.real(self.step_max, "settings.step_max", 1e-5))
        if self.step_max < self.step_min:
            raise ValueError(
                f"settings.step_max ({self.step_max}) must be >= "
                f"settings.step_min ({self.step_min})"
            )
        fixed = check.real(self.fixed_step, "settings.fixed_step", 0.0)
        if 0 < fixed < 1e-5:
            raise ValueError(f"settings.fixed_step must be 0 (off) or >= 1e-5, got {fixed}")
        s(self, "fixed_step", fixed)
        g = check.real(self.hg_g, "settings.hg_g", -1.0, 1.0, lo_open=True, hi_open=True)
        s(self, "hg_g", g)
        s(self, "max_steps", check.integer(self.max_steps, "settings.max_steps", 1, MAX_STEPS))
        s(
            self,
            "max_candidates",
            check.integer(self.max_candidates, "settings.max_candidates", 1, MAX_CANDIDATES),
        )
        if self.march not in MARCH_MODES:
            raise ValueError(f"settings.march must be one of {MARCH_MODES}, got {self.march!r}")
        if self.candidate_sort not in CANDIDATE_SORTS:
            raise ValueError(
                f"settings.candidate_sort must be one of {CANDIDATE_SORTS}, "
                f"got {self.candidate_sort!r}"
            )
        if not isinstance(self.exact_noise, (bool, np.bool_)):
            raise TypeError(f"settings.exact_noise must be a bool, got {self.exact_noise!r}")
        s(self, "exact_noise", bool(self.exact_noise))
        s(self, "octaves", check.integer(self.octaves, "settings.octaves", 1, 16))
        s(self, "gain", check.real(self.gain, "settings.gain", 0.0, lo_open=True))
        s(self, "lacunarity", check.real(self.lacunarity, "settings.lacunarity", 0.0, lo_open=True))
        s(self, "frequency", check.real(self.frequency, "settings.frequency", 0.0, lo_open=True))
        s(
            self,
            "light_resolution",
            check.integer(self.light_resolution, "settings.light_resolution", 2, 256),
        )
        if self.light_method not in LIGHT_METHODS:
            raise ValueError(
                f"settings.light_method must be one of {LIGHT_METHODS}, got {self.light_method!r}"
            )
        s(self, "light_step", check.real(self.light_step, "settings.light_step", 1e-4))
        s(
            self,
            "light_extinction",
            check.real(self.light_extinction, "settings.light_extinction", 0.0),
        )

    def step_for(self, distance: float) -> float:
        """The march step Δ for a cloud whose centre is ``distance`` from the camera."""
        if self.fixed_step > 0:
            return self.fixed_step
        step = self.lod_a * math.exp(-self.lod_delta * distance)
        return min(max(step, self.step_min), self.step_max)

    def fbm_params(self) -> dict[str, float]:
        """The fBm parameters as keyword arguments of :meth:`cumuli.Noise.fbm`."""
        return {
            "octaves": self.octaves,
            "gain": self.gain,
            "lacunarity": self.lacunarity,
            "frequency": self.frequency,
        }

    def light_grid_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`cumuli.light_grid` for the grid these settings render with.

        ``light_grid(cloud, sun, noise, **settings.light_grid_kwargs())`` records the parameters
        the renderer expects, so it keeps that grid (κ: the cloud's own, unless ``kappa`` is set;
        then the renderer makes the grid itself, for the overridden κ).
        """
        return {
            "resolution": self.light_resolution,
            "method": self.light_method,
            "step": self.light_step,
            "extinction": self.light_extinction,
            **self.fbm_params(),
        }

    def replace(self, **changes: Any) -> RenderSettings:
        """A copy with some fields changed (validated again)."""
        return RenderSettings(**{**asdict(self), **changes})

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


# --------------------------------------------------------------------------------------------
def _jsonable(value: Any, where: str) -> Any:
    """Convert numpy values and tuples into JSON types; other objects become their repr."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v, f"{where}.{k}") for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v, where) for v in value]
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    return repr(value)


def cloud_to_dict(cloud: Cloud) -> dict[str, Any]:
    """A cloud as JSON types: primitives, density model and parameters (no light grid)."""
    return {
        "centres": cloud.centres.tolist(),
        "radii": cloud.radii.tolist(),
        "rotations": cloud.rotations.tolist(),
        "model": cloud.model,
        "kappa": cloud.kappa,
        "phi": cloud.phi,
        "params": _jsonable(cloud.params, "params"),
        "stats": _jsonable(cloud.stats, "stats"),
    }


def cloud_from_dict(data: Mapping[str, Any], where: str = "cloud") -> Cloud:
    """Inverse of :func:`cloud_to_dict`; missing fields raise ValueError naming them."""
    _require(data, ("centres", "radii"), where)
    return Cloud(
        centres=np.asarray(data["centres"], dtype=np.float32),
        radii=np.asarray(data["radii"], dtype=np.float32),
        rotations=None
        if data.get("rotations") is None
        else np.asarray(data["rotations"], dtype=np.float32),
        model=data.get("model", "spheroid"),
        kappa=data.get("kappa", 0.5),
        phi=data.get("phi", 0.6),
        params=dict(data.get("params", {})),
        stats=dict(data.get("stats", {})),
    )


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
    """

    clouds: tuple[Cloud, ...] = ()
    sun: Sun = field(default_factory=Sun)
    sky: Sky = field(default_factory=Sky)
    noise: Noise = field(default_factory=lambda: Noise(seed=0))
    settings: RenderSettings = field(default_factory=RenderSettings)
    camera: Camera | None = None

    def __post_init__(self) -> None:
        clouds = self.clouds
        if isinstance(clouds, Cloud):
            clouds = (clouds,)
        if not isinstance(clouds, (list, tuple)):
            raise TypeError(
                f"scene.clouds must be a list of cumuli.Cloud, got {type(clouds).__name__}"
            )
        for k, c in enumerate(clouds):
            if not isinstance(c, Cloud):
                raise TypeError(f"scene.clouds[{k}] must be a cumuli.Cloud, got {type(c).__name__}")
        if len(clouds) > MAX_CLOUDS:
            raise ValueError(f"scene.clouds holds at most {MAX_CLOUDS} clouds, got {len(clouds)}")
        object.__setattr__(self, "clouds", tuple(clouds))
        parts = (("sun", Sun), ("sky", Sky), ("noise", Noise), ("settings", RenderSettings))
        for name, cls in parts:
            if not isinstance(getattr(self, name), cls):
                raise TypeError(f"scene.{name} must be a cumuli.{cls.__name__}")
        if self.camera is not None and not isinstance(self.camera, Camera):
            raise TypeError("scene.camera must be a cumuli.Camera or None")

    # --- convenience ----------------------------------------------------------------------
    def replace(self, **changes: Any) -> Scene:
        """A copy with some fields changed (clouds are shared, not copied)."""
        data = {f.name: getattr(self, f.name) for f in fields(self)}
        data.update(changes)
        return Scene(**data)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World bounds of every cloud's primitives; raises ValueError for an empty scene."""
        if not self.clouds:
            raise ValueError("the scene has no clouds")
        los, his = zip(*(c.bbox for c in self.clouds), strict=True)
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
            "clouds": [cloud_to_dict(c) for c in self.clouds],
            "sun": {
                "direction": list(self.sun.direction),
                "colour": list(self.sun.colour),
                "intensity": self.sun.intensity,
            },
            "sky": self.sky.to_dict(),
            "noise": {"seed": self.noise.seed, "size": self.noise.size},
            "settings": self.settings.to_dict(),
            "camera": None if self.camera is None else self.camera.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: Any) -> Scene:
        """Build a scene from :meth:`to_dict` output; ValueError names a missing/bad field."""
        _require(data, ("clouds", "sun", "sky", "noise", "settings"), "scene")
        if data.get("format", SCENE_FORMAT) != SCENE_FORMAT:
            raise ValueError(f"scene.format must be {SCENE_FORMAT!r}, got {data.get('format')!r}")
        if not isinstance(data["clouds"], list):
            raise ValueError("scene.clouds must be a JSON list")
        clouds = [cloud_from_dict(c, f"scene.clouds[{k}]") for k, c in enumerate(data["clouds"])]
        _require(data["sun"], ("direction",), "scene.sun")
        sun = Sun(**_known(Sun, data["sun"], "scene.sun"))
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
        return cls(clouds=clouds, sun=sun, sky=sky, noise=noise, settings=settings, camera=camera)

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
