"""Skies with climatic variation, wind and layers (Torchelsen & Musse 2005 §4, Figs. 8, 13–14,
Table 1; spec §6–8).

[TM]'s "sky" (a group of clouds, one climatic state) is `SkyState` (``cu.Sky`` is the background
gradient); its "simulation" (a set of skies at one height, with its own wind) is `CloudLayer`;
`Weather` runs several layers over a square area under one climatic schedule ``CV(t)``
(`Schedule`, piecewise linear, clamped; 0 sunny … 1 stormy). In a layer with states sorted by
``cv``, ``w = (CV − cv_a)/(cv_b − cv_a)`` between the bracketing states sets the target count
``N* = round((1 − w)·NC_a + w·NC_b)`` and the share of new clouds drawn from state b. Clouds
drift with the wind, leave (are destroyed) on the downwind side and new ones come in on the
upwind edges under an inflow quota, so the sky changes smoothly (C++ step,
``cpp/include/cumuli/anim/weather.hpp``, deterministic: one RNG stream per spawn event).

Each state's NBM basis models give NM variants each (`cloud_variants`, basis index running over
(layer, state, model)), re-centred on their box AABB centre; an instance's offset is that centre.
`Weather.fields` returns one `BillboardField` per layer, ready to render. `Weather.save` writes the
configuration (JSON) and the state (arrays, RNG counters) into one ``.npz``; `load_weather`
rebuilds the variants from the configuration and continues bit-identically.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import budget
from cumuli._util import validate as check
from cumuli._util.atomic import atomic_target
from cumuli.io.npz import (
    FileFormatError,
    check_path,
    check_readable,
    meta_array,
    meta_of,
    read_npz,
)
from cumuli.model.atlas import recipes_cost
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BasisModel, BillboardCloud, cloud_variants

BOUNDARIES = ("respawn", "wrap")
MAX_INSTANCES: int = int(_core.WEATHER_MAX_INSTANCES)
#: Most variants a whole weather may generate (NBM·NM summed over states and layers).
MAX_VARIANTS = 4096
#: Bytes a variant holds per box (its corners, level, seed and direction) and per billboard
#: (centre, size, texture, box and rotation).
BYTES_PER_VARIANT_BOX = 36
BYTES_PER_VARIANT_BILLBOARD = 32


def variants_cost(layers: Sequence[Any]) -> int:
    """Bytes the variants of ``layers`` may hold: every state's NBM·NM clouds at their basis
    model's worst case (`BasisModel.worst_case`), known before any is generated."""
    total = 0
    for layer in layers:
        for state in layer.states:
            for model in state.models:
                boxes, billboards = model.worst_case
                per = boxes * BYTES_PER_VARIANT_BOX + billboards * BYTES_PER_VARIANT_BILLBOARD
                total += state.variants * per
    return total


@dataclass(frozen=True)
class SkyState:
    """One climatic state of a layer ([TM]'s "sky"): ``count`` (NC) clouds drawn from ``models``
    (NBM basis models) × ``variants`` (NM variants each). ``background`` (a `cumuli.scene.Sky`)
    and ``sun_scale`` optionally darken the sky and the sun with CV (beyond [TM])."""

    cv: float
    models: tuple[BasisModel, ...]
    variants: int = 10
    count: int = 100
    background: Any = None
    sun_scale: float = 1.0
    name: str = ""

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "cv", check.real(self.cv, "cv", 0.0, 1.0))
        models = (self.models,) if isinstance(self.models, BasisModel) else self.models
        if not isinstance(models, (tuple, list)) or not 1 <= len(models) <= 4096:
            raise ValueError("models must hold 1 to 4096 BasisModel objects")
        for i, m in enumerate(models):
            if not isinstance(m, BasisModel):
                raise TypeError(f"models[{i}] must be a BasisModel, got {type(m).__name__}")
        set_(self, "models", tuple(models))
        set_(self, "variants", check.integer(self.variants, "variants", 1, 65535))
        set_(self, "count", check.integer(self.count, "count", 0, MAX_INSTANCES))
        if self.background is not None:
            from cumuli.sky import Sky

            if not isinstance(self.background, Sky):
                raise TypeError("background must be a cumuli.Sky or None")
        set_(self, "sun_scale", check.real(self.sun_scale, "sun_scale", 0.0, 10.0))

    def to_dict(self) -> dict[str, Any]:
        bg = self.background
        return {
            "cv": self.cv,
            "models": [m.to_dict() for m in self.models],
            "variants": self.variants,
            "count": self.count,
            "background": None
            if bg is None
            else {k: getattr(bg, k) for k in bg.__dataclass_fields__},
            "sun_scale": self.sun_scale,
            "name": self.name,
        }

    @classmethod
    def from_dict(cls, d: Any) -> SkyState:
        if not isinstance(d, dict):
            raise TypeError("sky state must be an object")
        kw = dict(d)
        kw["models"] = tuple(BasisModel.from_dict(m) for m in kw.get("models") or [])
        if kw.get("background") is not None:
            from cumuli.sky import Sky

            kw["background"] = Sky(**kw["background"])
        return cls(**kw)


@dataclass(frozen=True)
class CloudLayer:
    """A layer of clouds ([TM]'s "simulation"): ``altitude`` and ``thickness`` (instance heights
    ``altitude + U(−½, ½)·thickness``), ``wind`` ``(w_x, w_z)`` in units/s, ``states`` sorted by
    strictly increasing ``cv``, ``boundary`` ``"respawn"`` ([TM]) or ``"wrap"``, ``fade_time``
    (seconds; zero-wind fades)."""

    altitude: float
    thickness: float
    wind: tuple[float, float] = (1.0, 0.0)
    states: tuple[SkyState, ...] = ()
    boundary: str = "respawn"
    fade_time: float = 10.0
    name: str = ""

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "altitude", check.real(self.altitude, "altitude", -1e9, 1e9))
        set_(self, "thickness", check.real(self.thickness, "thickness", 0.0, 1e9))
        w = self.wind
        if not isinstance(w, (tuple, list, np.ndarray)) or len(w) != 2:
            raise TypeError(f"wind must be (w_x, w_z), got {w!r}")
        set_(
            self, "wind", (check.real(w[0], "wind", -1e6, 1e6), check.real(w[1], "wind", -1e6, 1e6))
        )
        states = (self.states,) if isinstance(self.states, SkyState) else self.states
        if not isinstance(states, (tuple, list)) or not 1 <= len(states) <= 256:
            raise ValueError("states must hold 1 to 256 SkyState objects")
        for i, s in enumerate(states):
            if not isinstance(s, SkyState):
                raise TypeError(f"states[{i}] must be a SkyState, got {type(s).__name__}")
        if any(b.cv <= a.cv for a, b in zip(states, states[1:], strict=False)):
            raise ValueError("states must be sorted by strictly increasing cv")
        set_(self, "states", tuple(states))
        if self.boundary not in BOUNDARIES:
            raise ValueError(f"boundary must be one of {BOUNDARIES}, got {self.boundary!r}")
        set_(self, "fade_time", check.real(self.fade_time, "fade_time", 0.0, 1e9))

    def mix(self, cv: float) -> tuple[int, int, float]:
        """``(a, b, w)``: the bracketing states and the weight of b (CV outside clamps)."""
        cv = check.real(cv, "cv", 0.0, 1.0)
        s = self.states
        if cv <= s[0].cv:
            return 0, 0, 0.0
        if cv >= s[-1].cv:
            return len(s) - 1, len(s) - 1, 0.0
        for k in range(len(s) - 1):
            if s[k].cv <= cv < s[k + 1].cv:
                return k, k + 1, (cv - s[k].cv) / (s[k + 1].cv - s[k].cv)
        return len(s) - 1, len(s) - 1, 0.0  # pragma: no cover

    def target(self, cv: float) -> int:
        """``N*(CV) = round((1 − w)·NC_a + w·NC_b)`` (halves round up, as in the C++ step)."""
        a, b, w = self.mix(cv)
        return int(math.floor((1.0 - w) * self.states[a].count + w * self.states[b].count + 0.5))

    def to_dict(self) -> dict[str, Any]:
        return {
            "altitude": self.altitude,
            "thickness": self.thickness,
            "wind": list(self.wind),
            "states": [s.to_dict() for s in self.states],
            "boundary": self.boundary,
            "fade_time": self.fade_time,
            "name": self.name,
        }

    @classmethod
    def from_dict(cls, d: Any) -> CloudLayer:
        if not isinstance(d, dict):
            raise TypeError("layer must be an object")
        kw = dict(d)
        kw["states"] = tuple(SkyState.from_dict(s) for s in kw.get("states") or [])
        kw["wind"] = tuple(kw.get("wind", (1.0, 0.0)))
        return cls(**kw)


#: Most keyframes of one `Schedule` (each evaluation walks them).
MAX_KEYFRAMES = 100_000


@dataclass(frozen=True, init=False)
class Schedule:
    """``CV(t)``: piecewise linear through ``keys`` ``((t, cv), ...)`` (t strictly increasing, cv
    in [0, 1]), constant before the first and after the last key. ``Schedule(0.3)`` is constant."""

    keys: tuple[tuple[float, float], ...]

    def __init__(self, keys: float | Sequence[tuple[float, float]]) -> None:
        if isinstance(keys, (int, float, np.floating)) and not isinstance(keys, bool):
            keys = [(0.0, float(keys))]
        if isinstance(keys, np.ndarray) and keys.ndim == 2:
            keys = keys.tolist()
        if not isinstance(keys, (tuple, list)):
            raise TypeError(
                f"cv must be a number or a sequence of (t, cv) keyframes, got {type(keys).__name__}"
            )
        if not 1 <= len(keys) <= MAX_KEYFRAMES:
            raise ValueError(
                f"cv has {len(keys)} keyframes; a schedule holds 1 to {MAX_KEYFRAMES} "
                "(MAX_KEYFRAMES)"
            )
        out = []
        for k in keys:
            if not isinstance(k, (tuple, list)) or len(k) != 2:
                raise ValueError(f"cv keyframes must be (t, cv) pairs, got {k!r}")
            out.append((check.real(k[0], "cv time"), check.real(k[1], "cv", 0.0, 1.0)))
        if any(b[0] <= a[0] for a, b in zip(out, out[1:], strict=False)):
            raise ValueError("cv keyframe times must be strictly increasing")
        object.__setattr__(self, "keys", tuple(out))

    def __call__(self, t: float) -> float:
        t = check.real(t, "t")
        k = self.keys
        if t <= k[0][0]:
            return k[0][1]
        if t >= k[-1][0]:
            return k[-1][1]
        for (t0, c0), (t1, c1) in zip(k, k[1:], strict=False):
            if t <= t1:
                return min(1.0, max(0.0, c0 + (t - t0) / (t1 - t0) * (c1 - c0)))
        return k[-1][1]  # pragma: no cover


def _variant_radius(cloud: BillboardCloud) -> float:
    """Radius in xz of a centred variant's bounding circle (its quads at any orientation)."""
    if cloud.n_billboards:
        c, r = cloud.centres.astype(np.float64), cloud.half_diagonals().astype(np.float64)
    else:
        c = cloud.box_centres.astype(np.float64)
        r = np.linalg.norm(cloud.box_half_sizes.astype(np.float64), axis=1)
    return float((np.hypot(c[:, 0], c[:, 2]) + r).max()) * (1 + 1e-6)


class Weather:
    """Animated layered sky (see the module docstring).

    Parameters
    ----------
    area:
        ``((x0, z0), (x1, z1))`` of the sky square (world units, xz plane).
    layers:
        `CloudLayer` objects (up to 64).
    cv:
        A `Schedule`, a constant, or ``(t, cv)`` keyframes.
    seed:
        The RNG seed (variants and spawn events).
    threads:
        Threads for the variant generation (0 = all cores); results do not depend on it.
    """

    def __init__(
        self,
        area: Sequence[Sequence[float]] = ((-500.0, -500.0), (500.0, 500.0)),
        layers: Sequence[CloudLayer] = (),
        cv: Schedule | float | Sequence[tuple[float, float]] = 0.0,
        seed: int = 0,
        threads: int = 0,
    ) -> None:
        try:
            (x0, z0), (x1, z1) = area
            box = tuple(check.real(v, "area", -check.MAX_COORD, check.MAX_COORD)
                        for v in (x0, z0, x1, z1))  # fmt: skip
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"area must be ((x0, z0), (x1, z1)) with finite numbers: {exc}"
            ) from None
        if not (box[2] > box[0] and box[3] > box[1]):
            raise ValueError(f"area must have x1 > x0 and z1 > z0, got {area!r}")
        if isinstance(layers, CloudLayer) or not isinstance(layers, (tuple, list)):
            raise TypeError("layers must be a sequence of CloudLayer")
        if not 1 <= len(layers) <= 64:
            raise ValueError("layers must hold 1 to 64 CloudLayer objects")
        for i, layer in enumerate(layers):
            if not isinstance(layer, CloudLayer):
                raise TypeError(f"layers[{i}] must be a CloudLayer, got {type(layer).__name__}")
        schedule = cv if isinstance(cv, Schedule) else Schedule(cv)
        self.seed = check.integer(seed, "seed", 0, 2**64 - 1)
        threads = check.threads(threads)
        total = sum(len(s.models) * s.variants for layer in layers for s in layer.states)
        if total > MAX_VARIANTS:
            raise ValueError(f"layers ask for {total} variants, more than {MAX_VARIANTS}")
        budget.check_memory(f"a weather of {total} variants", variants_cost(layers))
        self.area = ((box[0], box[1]), (box[2], box[3]))
        self.layers: tuple[CloudLayer, ...] = tuple(layers)
        self.schedule = schedule
        self.variants: list[list[BillboardCloud]] = []
        radii: list[list[float]] = []
        basis = 0
        for layer in self.layers:
            vs: list[BillboardCloud] = []
            for state in layer.states:
                for model in state.models:
                    for v in cloud_variants(model, state.variants, self.seed, basis, threads):
                        vs.append(v.translated(-v.centre.astype(np.float64)))
                    basis += 1
            self.variants.append(vs)
            radii.append([_variant_radius(v) for v in vs])
        self._radii = radii
        self._sim = _core.WeatherSim(box, self._core_layers(), list(schedule.keys), self.seed)

    def _core_layers(self) -> list[dict[str, Any]]:
        return [
            {
                "altitude": layer.altitude,
                "thickness": layer.thickness,
                "wind": layer.wind,
                "states": [(s.cv, s.count, len(s.models), s.variants) for s in layer.states],
                "radius": self._radii[i],
                "boundary": layer.boundary,
                "fade_time": layer.fade_time,
            }
            for i, layer in enumerate(self.layers)
        ]

    # --- time ------------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulated time (seconds)."""
        return float(self._sim.time)

    @property
    def cv(self) -> float:
        """``CV(t)`` now."""
        return float(self._sim.cv)

    def step(self, dt: float) -> None:
        """Advance by ``dt ≥ 0`` seconds (advect, destroy, inflow quota, spawn, fades)."""
        dt = check.real(dt, "dt", 0.0, 1e9)
        self._sim.step(dt)

    # --- state -----------------------------------------------------------------------------
    def targets(self) -> list[int]:
        """``N*(CV(t))`` per layer."""
        return [self._sim.target(i, self.cv) for i in range(len(self.layers))]

    def counts(self) -> list[list[int]]:
        """Per layer, per state: instances present and not fading out."""
        return [list(self._sim.counts(i)) for i in range(len(self.layers))]

    def instances(self, layer: int) -> dict[str, np.ndarray]:
        """Raw instance arrays of a layer: ``id``, current ``x``/``z``, spawn
        ``x0``/``z0``/``t0``, ``y``, ``yaw``, ``variant``, ``state``, ``fade_in``/``fade_out``
        (start times), ``alpha``."""
        i = check.integer(layer, "layer", 0, len(self.layers) - 1)
        return dict(self._sim.instances(i))

    def layer_stats(self, layer: int) -> dict[str, Any]:
        """Bookkeeping of a layer: quota, event counter, spawns per edge (x0, x1, z0, z1),
        spawned/destroyed/wrapped/faded-out totals and the last step's spawn points."""
        i = check.integer(layer, "layer", 0, len(self.layers) - 1)
        return dict(self._sim.layer_stats(i))

    def fields(self) -> list[BillboardField]:
        """One `BillboardField` per layer: the layer's variants (state-major: state, model,
        variant) and its instances (offset = variant centre position, yaw, alpha, state, and the
        instance's id, which it keeps from spawn to destruction: impostors follow it)."""
        out = []
        for i, layer in enumerate(self.layers):
            d = self._sim.instances(i)
            offsets = np.stack([d["x"], d["y"].astype(np.float64), d["z"]], axis=1)
            out.append(
                BillboardField(
                    self.variants[i],
                    offsets.astype(np.float32),
                    variant=d["variant"],
                    yaw=d["yaw"],
                    alpha=d["alpha"],
                    state=d["state"],
                    ids=d["id"],
                    params={"layer": i, "name": layer.name, "t": self.t, "cv": self.cv},
                )  # fmt: skip
            )
        return out

    def sky(self, base: Any = None) -> tuple[Any, float]:
        """``(background Sky, sun scale)`` at the current CV (beyond [TM]): the first layer whose
        states set a background interpolates its bracketing states' colours (None → ``base``);
        the sun scale is the product over layers of the interpolated ``sun_scale``."""
        from cumuli.sky import Sky

        base = base if base is not None else Sky()
        cv, sky, scale = self.cv, base, 1.0
        chosen = False
        for layer in self.layers:
            a, b, w = layer.mix(cv)
            sa, sb = layer.states[a], layer.states[b]
            scale *= (1.0 - w) * sa.sun_scale + w * sb.sun_scale
            if not chosen and any(s.background is not None for s in layer.states):
                ba, bb = sa.background or base, sb.background or base
                mixed = {
                    k: tuple(
                        (1 - w) * p + w * q
                        for p, q in zip(getattr(ba, k), getattr(bb, k), strict=True)
                    )
                    for k in ("zenith", "horizon", "ground")
                }
                sky = Sky(**{**{k: getattr(base, k) for k in base.__dataclass_fields__}, **mixed})
                chosen = True
        return sky, scale

    def scene_at(self, base: Any = None) -> Any:
        """The sky now as a `cumuli.Scene`: ``base``'s drawables (a hero cloud, ...) followed by
        one `BillboardField` per layer that holds clouds, ``base``'s sun scaled and its sky
        interpolated with CV where the states ask for it (`sky`), the rest of ``base`` (lights,
        settings, billboard shading, camera) as it is. ``base`` defaults to ``cumuli.Scene()``.
        The time is the weather's: `step` between calls films it."""
        from cumuli.scene import Scene
        from cumuli.sky import Sun

        if base is None:
            base = Scene()
        if not isinstance(base, Scene):
            raise TypeError(f"base must be a cumuli.Scene, got {type(base).__name__}")
        sky, scale = self.sky(base.sky)
        sun = base.sun
        if scale != 1.0:
            sun = Sun(sun.direction, sun.colour, sun.intensity * scale)
        fields = [f for f in self.fields() if f.n > 0]
        return base.replace(clouds=(*base.clouds, *fields), sky=sky, sun=sun)

    def to_dict(self) -> dict[str, Any]:
        """The configuration (JSON-able): area, layers, schedule, seed."""
        return {
            "area": [list(self.area[0]), list(self.area[1])],
            "layers": [layer.to_dict() for layer in self.layers],
            "cv": [list(k) for k in self.schedule.keys],
            "seed": self.seed,
        }

    def save(self, path: Any) -> Any:
        """Write configuration and state to ``path`` (``.npz``) atomically; see `load_weather`."""
        return _save(self, path)

    def __repr__(self) -> str:
        return (
            f"Weather(t={self.t:g}, cv={self.cv:.3f}, layers={len(self.layers)}, "
            f"counts={self.counts()})"
        )


def load_weather(path: Any, threads: int = 0) -> Weather:
    """Read a weather written by `Weather.save`; it continues exactly as the saved one would.

    ``FileNotFoundError`` for a missing file, ``ValueError`` naming the file for a corrupt,
    truncated or foreign one."""
    return _load(path, threads)


# --- files -----------------------------------------------------------------------------------
FILE_FORMAT = "cumuli.weather"
FILE_VERSION = 1
_ARRAYS = {
    "id": np.uint64,
    "x0": np.float64,
    "z0": np.float64,
    "t0": np.float64,
    "y": np.float32,
    "yaw": np.float32,
    "variant": np.int32,
    "state": np.int32,
    "fade_in": np.float64,
    "fade_out": np.float64,
}
_SCALARS = ("quota", "events", "spawn_edges", "spawned", "destroyed", "wrapped", "faded_out")
_MAX_LAYERS = 64
_LIMIT = 2 << 20


def _save(weather: Weather, path: Any) -> Path:
    p = check_path(path, (".npz",))
    if not p.parent.is_dir():
        raise FileNotFoundError(f"folder of path does not exist: {str(p.parent)!r}")
    sim = weather._sim
    layers_meta = []
    arrays: dict[str, np.ndarray] = {}
    for i in range(len(weather.layers)):
        inst = sim.instances(i)
        stats = sim.layer_stats(i)
        layers_meta.append({k: stats[k] for k in _SCALARS} | {"n": int(inst["id"].size)})
        for key, dtype in _ARRAYS.items():
            arrays[f"layer{i}_{key}"] = np.ascontiguousarray(inst[key], dtype=dtype)
    meta = {
        "format": FILE_FORMAT,
        "version": FILE_VERSION,
        "config": weather.to_dict(),
        "t": weather.t,
        "layers": layers_meta,
    }
    arrays["meta"] = meta_array(meta)
    with atomic_target(p) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    return p


def _load(path: Any, threads: int = 0) -> Weather:
    threads = check.threads(threads)  # an argument's error is not the file's
    p = check_path(path, (".npz",))
    check_readable(p, "weather")
    limits = {"meta": 1 << 26}
    for i in range(_MAX_LAYERS):
        for key in _ARRAYS:
            limits[f"layer{i}_{key}"] = _LIMIT
    arrays = read_npz(p, limits, ("meta",))
    meta = meta_of(arrays, p, FILE_FORMAT)
    # The atlases its layers' recipes rebuild, before any is made: at most what a scene file of
    # its size may cost.
    recipes = recipes_cost(meta.get("config"))
    size = p.stat().st_size
    budget.check_memory(
        f"weather file {p.name!r} of {budget.amount(size)} ({len(recipes)} atlas recipe(s))",
        sum(cost for _, _, cost in recipes),
        budget.get_limits().scene_bytes(size),
        "cumuli.set_limits(scene_expansion=..., scene_allowance=...) or CUMULI_SCENE_ALLOWANCE",
    )
    try:
        if meta.get("version") != FILE_VERSION:
            raise FileFormatError(
                f"{p.name}: unsupported weather file version {meta.get('version')!r}"
            )
        cfg = meta["config"]
        if not isinstance(cfg, dict):
            raise ValueError("config must be an object")
        layers = [CloudLayer.from_dict(d) for d in cfg["layers"]]
        # Its variants too, at the scene rule's budget, before any is generated.
        budget.check_memory(
            f"weather file {p.name!r} of {budget.amount(size)} (its layers' variants)",
            variants_cost(layers) + sum(cost for _, _, cost in recipes),
            budget.get_limits().scene_bytes(size),
            "cumuli.set_limits(scene_expansion=..., scene_allowance=...) or CUMULI_SCENE_ALLOWANCE",
        )
        weather = Weather(
            area=tuple(tuple(v) for v in cfg["area"]),
            layers=layers,
            cv=Schedule([tuple(k) for k in cfg["cv"]]),
            seed=cfg["seed"],
            threads=threads,
        )
        lm = meta["layers"]
        if not isinstance(lm, list) or len(lm) != len(layers):
            raise ValueError("state must hold one entry per layer")
        state = []
        for i, m in enumerate(lm):
            d: dict[str, Any] = {}
            for key, dtype in _ARRAYS.items():
                name = f"layer{i}_{key}"
                if name not in arrays:
                    raise ValueError(f"missing array {name!r}")
                a = arrays[name]
                if a.ndim != 1 or a.size != m["n"]:
                    raise ValueError(f"array {name!r} has {a.size} entries, expected {m['n']}")
                if a.dtype != np.dtype(dtype):
                    raise ValueError(
                        f"array {name!r} has dtype {a.dtype}, expected {np.dtype(dtype)}"
                    )
                d[key] = a
            for key in _SCALARS:
                d[key] = m[key]
            state.append(d)
        weather._sim.set_state(float(meta["t"]), state)
        return weather
    except (FileFormatError, budget.BudgetError):
        raise
    except (ValueError, TypeError, KeyError, IndexError, RuntimeError, json.JSONDecodeError) as exc:
        raise FileFormatError(f"{p.name}: invalid weather data: {exc}") from None
