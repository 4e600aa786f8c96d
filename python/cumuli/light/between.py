"""Light between kinds (beyond Harris 2002 and Torchelsen & Musse 2005, whose clouds light only
themselves): particle clouds and billboards lit through the media and one another
(:func:`through_media`), and shading the media's sunlight (:func:`onto_media`). The light step
runs both after every drawable's own light pass (RENDER_CONTRACT, "Light through the media")."""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from cumuli import registry
from cumuli.light import onto_media as media_shadows
from cumuli.light.digests import shadow_digest
from cumuli.light.memo import remember
from cumuli.light.particles import light_directions
from cumuli.light.shadow import Casters, caster_transmittance, media_transmittance, points_sphere
from cumuli.scene import Scene


def _receivers(scene: Scene, lights: Sequence[Any]) -> dict[int, tuple[Callable[[], Any], Any]]:
    """The particle clouds and billboard clouds or fields whose light can be shaded: by index,
    a function making the world points where the light is received (in the order of its light's
    rows or CAF entries) and a key for where they are."""
    out: dict[int, tuple[Callable[[], Any], Any]] = {}
    for k, cloud in enumerate(scene.clouds):
        caster = registry.of(cloud).caster
        received = None if caster is None else caster.receiver(cloud, lights[k])
        if received is not None:
            out[k] = received
    return out


def _medium(d: Any) -> Any:
    """The drawable's :class:`cumuli.registry.Medium`, or None."""
    return registry.of(d).medium


def _split(values: np.ndarray, parts: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
    """``values`` computed on the concatenated ``parts``, cut back into one array per part."""
    ends = np.cumsum([len(p) for p in parts.values()])
    return dict(zip(parts, np.split(values, ends[:-1]), strict=True))


def _between_casters(
    scene: Scene,
    points: Callable[[int], np.ndarray],
    receivers: Sequence[int],
    casters: Casters,
    own_lights: Sequence[Any],
    threads: int,
) -> dict[int, np.ndarray]:
    """Per receiver, ``(M, L)``: the transmittance of each light (the sun, then
    ``scene.lights``) at its ``M`` points through the other particle clouds and billboards its
    bounding sphere's rays towards that light can cross (receivers in the clear of every light
    left out): one shadow query per caster and light over all the points it may shade, the
    factors of each receiver multiplied in the casters' order."""
    suns = (scene.sun, *scene.lights)
    out: dict[int, np.ndarray] = {}
    for ell, sun in enumerate(suns):
        shaded_by: dict[int, list[int]] = {}
        for k in receivers:
            me = int(np.flatnonzero(casters.index == k)[0])
            for j in casters.towards_sun(sun.direction, casters.centre[me], casters.radius[me], k):
                shaded_by.setdefault(j, []).append(k)
        for j in sorted(shaded_by):
            parts = {k: points(k) for k in shaded_by[j]}
            t = caster_transmittance(scene, np.concatenate(list(parts.values())), threads,
                                     own_lights, [j], sun)  # fmt: skip
            if t is None:
                continue
            for k, part in _split(np.asarray(t, np.float32), parts).items():
                if k not in out:
                    out[k] = np.ones((len(part), len(suns)), np.float32)
                out[k][:, ell] *= part
    return out


def through_media(scene: Scene, lights: Sequence[Any], threads: int = 0) -> list[Any]:
    """``lights`` (aligned with ``scene.clouds``) with the light of every particle cloud and
    billboard cloud or field passed through the rest of the scene first (beyond Harris 2002
    and Torchelsen & Musse 2005, whose clouds light only themselves): particle ``k``'s light
    ``ℓ``, or the CAF of a box (billboard) for light ``ℓ``, times ``exp(−τ)`` from its centre
    towards ``ℓ`` through the 2018 clouds and volumes
    (:func:`cumuli.light.shadow.media_transmittance`), and, with ``settings.sprite_shadows``,
    also times the transmittance of light ``ℓ`` (the sun and each of ``scene.lights``) through
    the other particle clouds and billboards (:func:`cumuli.light.shadow.caster_transmittance`,
    only for the casters the rays from its bounding sphere towards ``ℓ`` can cross:
    :meth:`Casters.towards_sun`), each memoised by content and place for the whole scene. The
    instances of one billboard field shade one another in the field's own light pass instead,
    with ``BillboardShading(shadow_between_clouds=True)``. :func:`onto_media` makes the particle
    clouds and billboards shade the media."""
    out = list(lights)
    receivers = _receivers(scene, lights)
    if not receivers:
        return out
    media = tuple(shadow_digest(d) for d in scene.clouds if _medium(d) is not None)
    # The casters' spheres only when they shade one another (each frame of a field pays them).
    casters = Casters.of(scene) if scene.settings.sprite_shadows else None
    mutual = casters is not None and len(casters.index) >= 2
    if not (media or mutual):
        return out
    dirs = light_directions([scene.sun, *scene.lights])
    # The casters' own lights lend their shadow buffers (a shaded particle light keeps its own).
    own_lights = [getattr(light, "unshadowed", None) or light for light in lights]
    places = tuple((k, place) for k, (_, place) in receivers.items())
    made: dict[int, np.ndarray] = {}

    def points(k: int) -> np.ndarray:  # made once, and only when a memo misses
        if k not in made:
            made[k] = np.asarray(receivers[k][0](), np.float32).reshape(-1, 3)
        return made[k]

    def through_the_media() -> dict[int, np.ndarray]:
        parts = {k: points(k) for k in receivers}
        everywhere = np.concatenate(list(parts.values()))
        columns = [media_transmittance(scene, everywhere, d, threads) for d in dirs]
        return _split(np.stack(columns, axis=1).astype(np.float32), parts)

    t_media: dict[int, np.ndarray] = {}
    if media:
        key = ("through media", media, places, dirs.tobytes(), scene.noise.identity,
               scene.settings)  # fmt: skip
        t_media = remember(key, through_the_media)
    t_casters: dict[int, np.ndarray] = {}
    if mutual:
        assert casters is not None
        key = ("between casters", tuple(shadow_digest(scene.clouds[j]) for j in casters.index),
               places, dirs.tobytes(), tuple(scene.sprite_settings.light_dict().items()),
               scene.billboard_shading)  # fmt: skip
        t_casters = remember(key, lambda: _between_casters(
            scene, points, list(receivers), casters, own_lights, threads))  # fmt: skip
    for k in receivers:
        if k not in t_media and k not in t_casters:
            continue
        # The same factors (memoised arrays) on the same own light give the same shaded light
        # object as last frame: no new arrays, and the impostor cache sees it unchanged at once.
        factors = (t_media.get(k), t_casters.get(k))
        last = _shaded_lights.get(out[k])
        if last is not None and last[0] is factors[0] and last[1] is factors[1]:
            if last[2] is not None:
                out[k] = last[2]
            continue
        if k in t_media:
            t = t_media[k].copy()
        else:
            t = np.ones((len(t_casters[k]), dirs.shape[0]), np.float32)
        if k in t_casters:
            t *= t_casters[k]  # every light's column
        shaded = None if (t == 1.0).all() else out[k].through(t)  # clear: the own light object
        _shaded_lights[out[k]] = (*factors, shaded)
        if shaded is not None:
            out[k] = shaded
    return out


#: A particle or billboard cloud's own light → (its media factors, its casters' factors, the
#: shaded light made from them), reused while the factors are the same memoised arrays.
_shaded_lights: weakref.WeakKeyDictionary[Any, tuple[Any, Any, Any]] = weakref.WeakKeyDictionary()


#: Media lights shaded by `onto_media` → the light each was made from, by id with a weak
#: reference to the shaded one (a light given back to `prepare_light` is unshaded first).
_own_media_light: dict[int, tuple[weakref.ref, Any]] = {}
_own_media_lock = threading.Lock()


def own_light_of(light: Any) -> Any:
    """The light `onto_media` shaded into ``light``, or ``light`` when it shaded none."""
    with _own_media_lock:
        entry = _own_media_light.get(id(light))
    return entry[1] if entry is not None and entry[0]() is light else light


def _note_own_light(shaded: Any, own: Any) -> None:
    key = id(shaded)
    with _own_media_lock:
        entry = _own_media_light.get(key)
        if entry is not None and entry[0]() is shaded:
            return

    def forget(_: Any, key: int = key) -> None:
        # No lock: a garbage collection may run this inside a locked block of this thread, and
        # one dict.pop is atomic. The entry goes when its light dies, before its id is reused.
        _own_media_light.pop(key, None)

    ref = weakref.ref(shaded, forget)
    with _own_media_lock:
        _own_media_light[key] = (ref, own)


def onto_media(scene: Scene, lights: Sequence[Any], threads: int = 0) -> list[Any]:
    """``lights`` (aligned with ``scene.clouds``) with the sunlight of every 2018 cloud and
    volume passed through the scene's particle clouds and billboards first (beyond Harris 2002
    and Torchelsen & Musse 2005): each of the medium's sun terms times the sun's transmittance
    through them at its grid points (:mod:`cumuli.light.onto_media`), memoised by the medium's
    own light and place and the casters' content and place. A medium in the clear keeps its own
    light object. A shaded light given back to `prepare_light` in this process is replaced by the
    light it was made from (the registry holds it by the shaded light's identity). A copy of a
    shaded light is marked (``LightRecord.shaded``, ``PhysicalLight.shaded_from``,
    ``ShadedVolumeLight.shaded_from``) and the light step goes back to the own light."""
    out = list(lights)
    if not any(_medium(d) is not None for d in scene.clouds):
        return out
    shade_key = tuple(shadow_digest(d) for d in scene.clouds if registry.of(d).caster is not None)
    if not shade_key:
        return out
    # The casters' own lights lend their shadow buffers (a shaded particle light keeps its own).
    own_lights = [getattr(light, "unshadowed", None) or light for light in lights]

    casters = Casters.of(scene)

    def transmittance(points: np.ndarray) -> np.ndarray | None:
        among = casters.towards_sun(scene.sun.direction, *points_sphere(points))
        return caster_transmittance(scene, points, threads, own_lights, among) if among else None

    for k, medium in enumerate(scene.clouds):
        of = _medium(medium)
        if of is None:
            continue
        own = out[k]
        box = of.light_box(medium)
        # id(own) cannot name another light while the entry holds `own`; the medium's digest
        # holds where it is (a volume's light, given back, does not change when it moves).
        key = ("onto media", shade_key, id(own), shadow_digest(medium), scene.sun.direction,
               tuple(scene.sprite_settings.light_dict().items()),
               scene.billboard_shading)  # fmt: skip
        made = remember(
            key, lambda own=own, box=box: (own, media_shadows.shade(own, box, transmittance))
        )
        if made[1] is not own:
            _note_own_light(made[1], own)
            out[k] = made[1]
    return out
