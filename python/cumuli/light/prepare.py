"""The light step of a scene: every drawable's light for the scene's sun and sky, as a value.

`prepare_light` runs the light pass of each drawable's kind — the NDT light grid for a 2018
`Cloud` (:func:`cumuli.light_grid` with ``settings.light_params()``), the per-voxel sun and sky
light for a `VolumeCloud` (:class:`cumuli.VolumeLighting`), the multiple forward scattering light
of a `ParticleCloud` for the sun and every extra light (:func:`cumuli.particle_light` with
``scene.sprite_settings``; one column per light, colours applied at render), the CAF of
billboard clouds and fields (:mod:`cumuli.light.billboards`) — and returns an immutable
:class:`LitScene` that the renderers draw. Nothing is stored on the clouds, and a failed call
changes no object.

Between kinds: particle clouds and billboards are lit through the media and one another
(:func:`cumuli.light.between.through_media`) and shade the media's sunlight
(:func:`cumuli.light.between.onto_media`), in either mode.

With ``settings.lighting == "physical"`` every drawable gets its :class:`cumuli.PhysicalLight`
instead (:mod:`cumuli.light.physical`: the sun's optical depth, the sky's visibility and the
multiple scattering), and a scene with a ground gets the sun's shadow map on it
(:mod:`cumuli.light.shadow`), in either mode.

Light a caller already has is passed in ``lights``: a `LightGrid` made by `light_grid` is used
while its record and sun match what the scene's settings would make (otherwise recomputed); a
grid made by hand (``LightGrid(values, box)``, no record) is used as it is. Results are
memoised by content (the cloud's primitives, the parameters, the sun and sky), so rendering the
same scene again — every frame of a camera path — does not repeat the light pass.
"""

from __future__ import annotations

import weakref
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from cumuli import _progress
from cumuli import _validate as check
from cumuli.ground import ground_radiance_unshadowed
from cumuli.light import billboards as billboard_pass
from cumuli.light.between import onto_media, own_light_of, through_media
from cumuli.light.digests import content_digest as _digest
from cumuli.light.digests import drawable_digest
from cumuli.light.digests import shadow_digest as _shadow_digest
from cumuli.light.memo import lock as _memo_lock
from cumuli.light.memo import remember as _remember
from cumuli.light.memo import store as _memo
from cumuli.light.ndt import LightGrid, LightRecord, light_grid
from cumuli.light.particles import (
    ParticleLight,
    light_directions,
    light_is_stale,
    particle_light_many,
)
from cumuli.light.physical import PhysicalLight, physical_light
from cumuli.light.shadow import ShadowMap, compute_shadow, default_extent
from cumuli.light.volume import VolumeLighting
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BillboardCloud
from cumuli.model.cloud import Cloud
from cumuli.model.particles import ParticleCloud
from cumuli.model.volume import VolumeCloud, VolumeDatabase
from cumuli.scene import Scene


@dataclass(frozen=True, eq=False)
class LitScene:
    """A scene with the light of every drawable: ``lights[k]`` belongs to ``scene.clouds[k]``
    (a :class:`cumuli.LightGrid` for a `Cloud`, a ``(D, H, W, 4)`` light volume for a
    `VolumeCloud`, a :class:`cumuli.ParticleLight` for a `ParticleCloud`). Made by
    :func:`prepare_light`; the renderers take it in place of a scene."""

    scene: Scene
    lights: tuple[Any, ...]
    #: The sun's shadow map on the scene's ground (None without a ground).
    shadow: ShadowMap | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.scene, Scene):
            raise TypeError(f"scene must be a cumuli.Scene, got {type(self.scene).__name__}")
        if len(self.lights) != len(self.scene.clouds):
            raise ValueError(
                f"a LitScene needs one light per cloud: {len(self.scene.clouds)} clouds, "
                f"{len(self.lights)} lights"
            )


def clear_memo() -> None:
    """Forget every memoised light (they are recomputed on demand)."""
    global _particle_floats
    with _memo_lock:
        _memo.clear()
        _particle_memo.clear()
        _resolved.clear()
        _particle_floats = 0
    billboard_pass.clear_memo()


# --- light passes, one per kind ----------------------------------------------------------------
def cloud_light(cloud: Cloud, scene: Scene, given: Any = None, threads: int = 0) -> LightGrid:
    """The NDT light grid `cloud` renders with in ``scene`` (see the module docstring)."""
    params = scene.settings.light_params()
    sun = scene.sun.direction
    if given is not None:
        if not isinstance(given, LightGrid):
            raise TypeError(
                f"the light of a Cloud must be a cumuli.LightGrid, got {type(given).__name__}"
            )
        if given.record is None:
            # Made by hand: trusted as it is, unless it says it was made for another sun.
            if given.sun is None or np.allclose(given.sun, sun, rtol=0, atol=1e-6):
                return given
        elif np.allclose(given.sun, sun, rtol=0, atol=1e-6) and given.record == LightRecord.of(
            cloud, scene.noise, params
        ):
            return given
    record = LightRecord.of(cloud, scene.noise, params)
    return _remember(
        ("cloud", record, sun),
        lambda: light_grid(cloud, scene.sun, scene.noise, params=params, threads=threads),
    )


def volume_light(
    volume: VolumeCloud, scene: Scene, given: Any = None, threads: int = 0
) -> np.ndarray:
    """The ``(D, H, W, 4)`` light of a `VolumeCloud` under the scene's sun and sky: its own
    precomputed light (or ``given``) when made for them, else computed by `VolumeLighting`."""
    if given is not None:
        # A copy of a light shaded by particles and billboards: the volume's own underneath.
        own = getattr(given, "shaded_from", None)
        light = np.asarray(given if own is None else own, dtype=np.float32)
        if light.shape != (*volume.shape, 4) or not np.isfinite(light).all():
            raise ValueError(
                f"the light of a VolumeCloud must be a finite {(*volume.shape, 4)} array"
            )
        return light
    if volume.light is not None and (volume.light_sun, volume.light_sky) == (scene.sun, scene.sky):
        return volume.light
    key = (
        "volume",
        _digest(volume.density),
        volume.box,
        volume.sigma_t,
        volume.albedo,
        tuple(sorted(volume.lighting.items())),
        scene.sun,
        scene.sky,
    )

    def make() -> np.ndarray:
        database = VolumeDatabase(volume.density[None], *volume.box)
        lighting = VolumeLighting(
            database, scene.sun, scene.sky, sigma_t=volume.sigma_t, albedo=volume.albedo,
            threads=threads, **volume.lighting,
        )  # fmt: skip
        light = lighting.light(0, threads=threads)
        light.setflags(write=False)
        return light

    return _remember(key, make)


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
        known = (_digest(cloud.radii, cloud.tau, cloud.albedo), rel, radius)
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
    cloud: ParticleCloud, scene: Scene, given: Any = None, threads: int = 0
) -> ParticleLight:
    """The light of a `ParticleCloud` for ``scene.sun`` and ``scene.lights`` (in that order) with
    ``scene.sprite_settings``: ``given`` when it is a current :class:`ParticleLight`
    (:func:`cumuli.light.particles.light_is_stale` says None), else memoised or computed."""
    return particles_light_many([cloud], scene, [given], threads)[0]


def particles_light_many(
    clouds: Sequence[ParticleCloud], scene: Scene, given: Sequence[Any], threads: int = 0
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


#: The light pass of each kind of drawable: ``(drawable, scene, given, threads) -> light``.
LIGHT_PASSES: dict[str, Callable[..., Any]] = {
    Cloud.kind: cloud_light,
    VolumeCloud.kind: volume_light,
    ParticleCloud.kind: particles_light,
    BillboardCloud.kind: billboard_pass.billboard_light,
    BillboardField.kind: billboard_pass.billboard_light,
}
#: Kinds whose light pass also runs on all the scene's drawables of the kind at once:
#: ``(drawables, scene, given, threads) -> lights`` (same results as one by one, faster).
LIGHT_BATCHES: dict[str, Callable[..., list[Any]]] = {ParticleCloud.kind: particles_light_many}


def light_sky(scene: Scene) -> Any:
    """The sky that lights the clouds: the scene's, with the ground's unshadowed radiance below
    the horizon when the scene has a ground."""
    if scene.ground is None:
        return scene.sky
    return replace(scene.sky, ground=ground_radiance_unshadowed(scene.ground, scene.sky, scene.sun))


def physical_pass(drawable: Any, scene: Scene, given: Any = None, threads: int = 0) -> Any:
    """The physical mode's light of a `Cloud` or a `VolumeCloud` (:func:`physical_light`),
    memoised by content; a :class:`PhysicalLight` given is used as it is."""
    if given is not None:
        if not isinstance(given, PhysicalLight):
            raise TypeError(
                f"the physical light of a drawable must be a cumuli.PhysicalLight, got "
                f"{type(given).__name__}"
            )
        # A light shaded by particles and billboards (a copy, whose registry entry is gone):
        # the drawable's own light underneath; the light step shades it again as the scene is.
        return given.shaded_from or given
    sky = light_sky(scene)
    others = tuple(drawable_digest(d) for d in scene.clouds if d is not drawable)
    key = ("physical", drawable_digest(drawable), others, scene.noise.seed, scene.noise.size,
           scene.settings, scene.sun, sky)  # fmt: skip
    return _remember(key, lambda: physical_light(drawable, replace(scene, sky=sky), threads))


#: The physical mode's light pass of each kind.
PHYSICAL_LIGHT_PASSES: dict[str, Callable[..., Any]] = {
    Cloud.kind: physical_pass,
    VolumeCloud.kind: physical_pass,
}


def scene_shadow(
    scene: Scene, threads: int = 0, lights: Sequence[Any] | None = None
) -> ShadowMap | None:
    """The shadow map the renderers use for a scene's ground (None without a ground, or when
    no cloud can shade it), memoised by content; ``lights``: the scene's, whose particle light
    buffers (their shadow maps) it reuses."""
    if scene.ground is None:
        return None
    height = scene.ground.height
    extent = default_extent(scene, height)
    if extent is None:
        return None
    n = scene.settings.shadow_resolution
    key = ("shadow", tuple(_shadow_digest(d) for d in scene.clouds), scene.noise.seed,
           scene.noise.size, scene.settings, tuple(scene.sprite_settings.light_dict().items()),
           scene.billboard_shading, scene.sun.direction, height)  # fmt: skip
    return _remember(key, lambda: compute_shadow(scene, extent, (n, n), height, threads, lights))


def prepare_light(
    scene: Scene | LitScene,
    lights: Mapping[int, Any] | Sequence[Any] | None = None,
    threads: int = 0,
    progress: bool | None = None,
) -> LitScene:
    """The light of every drawable of ``scene`` for its sun and sky: a :class:`LitScene`.

    ``lights`` gives light the caller already has, by cloud index (a mapping) or aligned with
    ``scene.clouds`` (a sequence, ``None`` where the light is to be computed). A `LitScene`
    passed in is checked again (its lights count as given). Nothing is stored on the clouds.
    A progress bar shows when the light passes take more than a few seconds (``progress``:
    ``None`` unless ``CUMULI_PROGRESS=0``, ``False`` never).
    """
    if isinstance(scene, LitScene):
        if lights is None:
            lights = scene.lights
        scene = scene.scene
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a cumuli.Scene, got {type(scene).__name__}")
    threads = check.threads(threads)
    n = len(scene.clouds)
    given: list[Any] = [None] * n
    if isinstance(lights, Mapping):
        for k, v in lights.items():
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < n:
                raise ValueError(f"lights: {k!r} is not the index of one of the {n} clouds")
            given[int(k)] = v
    elif lights is not None:
        if isinstance(lights, (str, bytes)) or not isinstance(lights, Sequence):
            raise TypeError(f"lights must be a mapping or a sequence, got {type(lights).__name__}")
        if len(lights) != n:
            raise ValueError(f"lights must hold one entry per cloud ({n}), got {len(lights)}")
        given = list(lights)
    # A light passed through the media (or a medium's light shaded by particles and billboards)
    # is the cloud's own light underneath: that is what is given.
    shadowable = (ParticleLight, billboard_pass.BillboardLighting)
    given = [g.unshadowed or g if isinstance(g, shadowable) else own_light_of(g) for g in given]
    # The physical mode replaces the light pass of the marched kinds; particles and billboards
    # keep their own light models (Harris 2002, Torchelsen & Musse 2005) in either mode.
    passes = {**LIGHT_PASSES, **PHYSICAL_LIGHT_PASSES} if scene.settings.physical else LIGHT_PASSES
    for k, drawable in enumerate(scene.clouds):  # every kind known before any work
        if passes.get(drawable.kind) is None:
            raise TypeError(f"scene.clouds[{k}]: no light pass for kind {drawable.kind!r}")
    out: list[Any] = [None] * n
    for kind, batch in LIGHT_BATCHES.items():  # kinds whose light passes share one C++ call
        idx = [k for k, d in enumerate(scene.clouds) if d.kind == kind]
        if len(idx) > 1:
            try:
                made = batch(
                    [scene.clouds[k] for k in idx], scene, [given[k] for k in idx], threads
                )
            except (TypeError, ValueError) as exc:
                raise type(exc)(f"scene.clouds ({kind}): {exc}") from None
            for k, light in zip(idx, made, strict=True):
                out[k] = light
    todo = [k for k in range(n) if out[k] is None]
    steps = _progress.bar(
        todo, desc="light", total=len(todo), unit="cloud",
        progress=progress if len(todo) > 1 else False,
    )  # fmt: skip
    for k in steps:
        drawable = scene.clouds[k]
        try:
            with _progress.core(f"light of cloud {k}", progress):
                out[k] = passes[drawable.kind](drawable, scene, given[k], threads)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"scene.clouds[{k}]: {exc}") from None
    out = onto_media(scene, through_media(scene, out, threads), threads)
    return LitScene(scene, tuple(out), scene_shadow(scene, threads, out))
