"""The light pass of particle clouds in a scene (Harris 2002, §2.2): each cloud's multiple forward
scattering light for the scene's sun and extra lights, memoised by what a translation leaves
unchanged, so a field of clouds drifting with the wind keeps its light."""

from __future__ import annotations

import weakref
from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli.light.memo import content_digest
from cumuli.light.memo import lock as _memo_lock
from cumuli.light.particles import (
    ParticleLight,
    light_directions,
    light_is_stale,
    particle_light_many,
)
from cumuli.model.particles import ParticleCloud

# Particle light is small ((N, L) floats) and a field of clouds has many: its own memo, bounded
# by the floats it holds rather than by entries. A translated cloud (wind) finds the light of the
# original: entries are keyed by what translation leaves exactly unchanged (radii, τ, albedo,
# directions, settings) and matched by the centres relative to the bounding sphere's centre
# within 1e−5·R (float32 rounding of a translation moves them by ~1e−7·|coordinates|).
PARTICLE_MEMO_FLOATS = 1 << 25
_particle_memo: OrderedDict[Any, list[tuple[np.ndarray, float, ParticleLight]]] = OrderedDict()
_particle_floats = 0
_exact: weakref.WeakKeyDictionary[ParticleCloud, tuple[str, np.ndarray, float]] = (
    weakref.WeakKeyDictionary()
)


def _invariants(cloud: ParticleCloud) -> tuple[str, np.ndarray, float]:
    """(digest of radii, τ, albedo; centres relative to the sphere centre; R), per cloud object."""
    known = _exact.get(cloud)
    if known is None:
        centre, radius = cloud.sphere
        rel = cloud.centres.astype(np.float64) - centre.astype(np.float64)
        known = (content_digest(cloud.radii, cloud.tau, cloud.albedo), rel, radius)
        _exact[cloud] = known
    return known


# The light each cloud object was last given, by the scene part of the key: the frames of a
# camera path find it without comparing particles again.
_resolved: weakref.WeakKeyDictionary[ParticleCloud, tuple[Any, ParticleLight]] = (
    weakref.WeakKeyDictionary()
)


def _particle_lookup(cloud: ParticleCloud, common: Any) -> tuple[Any, ParticleLight | None]:
    digest, rel, radius = _invariants(cloud)
    key = (digest, *common)
    known = _resolved.get(cloud)
    if known is not None and known[0] == key:
        return key, known[1]
    with _memo_lock:
        for rel_e, radius_e, light in _particle_memo.get(key, ()):
            if rel_e.shape == rel.shape and np.abs(rel_e - rel).max() <= 1e-5 * max(
                radius, radius_e
            ):
                _particle_memo.move_to_end(key)
                _resolved[cloud] = (key, light)
                return key, light
    return key, None


def _particle_remember(key: Any, cloud: ParticleCloud, light: ParticleLight) -> None:
    global _particle_floats
    _, rel, radius = _invariants(cloud)
    with _memo_lock:
        _particle_memo.setdefault(key, []).append((rel, radius, light))
        _particle_memo.move_to_end(key)
        _particle_floats += light.light.size
        while _particle_floats > PARTICLE_MEMO_FLOATS and len(_particle_memo) > 1:
            _, old = _particle_memo.popitem(last=False)
            _particle_floats -= sum(entry[2].light.size for entry in old)


def particles_light(
    cloud: ParticleCloud, scene: Any, given: Any = None, threads: int = 0
) -> ParticleLight:
    """The light of a `ParticleCloud` for ``scene.sun`` and ``scene.lights`` (in that order) with
    ``scene.sprite_settings``: ``given`` when it is a current :class:`ParticleLight`
    (:func:`cumuli.light.particles.light_is_stale` says None), else memoised or computed."""
    return particles_light_many([cloud], scene, [given], threads)[0]


def particles_light_many(
    clouds: Sequence[ParticleCloud], scene: Any, given: Sequence[Any], threads: int = 0
) -> list[ParticleLight]:
    """:func:`particles_light` of several clouds; those to compute share one C++ call (clouds ×
    lights over the threads)."""
    lights = [scene.sun, *scene.lights]
    common = (
        light_directions(lights).tobytes(),
        tuple(scene.sprite_settings.light_dict().items()),
    )
    out: list[Any] = [None] * len(clouds)
    todo: list[tuple[Any, int]] = []
    for i, (cloud, g) in enumerate(zip(clouds, given, strict=True)):
        if g is not None:
            if not isinstance(g, ParticleLight):
                raise TypeError(
                    f"the light of a ParticleCloud must be a ParticleLight, got {type(g).__name__}"
                )
            if light_is_stale(g, cloud, lights, scene.sprite_settings) is None:
                out[i] = g
                continue
        key, hit = _particle_lookup(cloud, common)
        if hit is not None:
            out[i] = hit
        else:
            todo.append((key, i))
    if todo:
        # With their final buffers: the sun's is the cloud's shadow map on the ground.
        made = particle_light_many(
            [clouds[i] for _, i in todo], lights, scene.sprite_settings, threads=threads,
            return_buffers=True,
        )  # fmt: skip
        for (key, i), light in zip(todo, made, strict=True):
            _particle_remember(key, clouds[i], light)
            _resolved[clouds[i]] = (key, light)
            out[i] = light
    return out


def forget() -> None:
    """Forget every memoised particle light."""
    global _particle_floats
    with _memo_lock:
        _particle_memo.clear()
        _resolved.clear()
        _particle_floats = 0
