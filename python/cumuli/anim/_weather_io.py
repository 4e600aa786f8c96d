"""`Weather` files: one ``.npz`` holding the configuration (JSON) and the state arrays.

The state is everything the C++ step reads: per layer the instances (id, spawn point and time,
height, yaw, variant, state, fade starts), the inflow quota, the spawn-event counter (the RNG
position: each event draws from its own stream) and the bookkeeping totals; plus the time. The
variants are rebuilt from the configuration (deterministic), so a loaded weather continues
bit-identically.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from cumuli._atomic import atomic_target
from cumuli.anim.weather import CloudLayer, Schedule, Weather
from cumuli.model._billboard_io import (
    FileFormatError,
    check_path,
    check_readable,
    meta_array,
    meta_of,
    read_npz,
)

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


def save(weather: Weather, path: Any) -> Path:
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


def load(path: Any, threads: int = 0) -> Weather:
    p = check_path(path, (".npz",))
    check_readable(p, "weather")
    limits = {"meta": 1 << 26}
    for i in range(_MAX_LAYERS):
        for key in _ARRAYS:
            limits[f"layer{i}_{key}"] = _LIMIT
    arrays = read_npz(p, limits, ("meta",))
    meta = meta_of(arrays, p, FILE_FORMAT)
    try:
        if meta.get("version") != FILE_VERSION:
            raise FileFormatError(
                f"{p.name}: unsupported weather file version {meta.get('version')!r}"
            )
        cfg = meta["config"]
        if not isinstance(cfg, dict):
            raise ValueError("config must be an object")
        layers = [CloudLayer.from_dict(d) for d in cfg["layers"]]
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
    except FileFormatError:
        raise
    except (ValueError, TypeError, KeyError, IndexError, RuntimeError, json.JSONDecodeError) as exc:
        raise FileFormatError(f"{p.name}: invalid weather data: {exc}") from None
