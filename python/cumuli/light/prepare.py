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

import os
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from cumuli import registry
from cumuli._util import progress as _progress
from cumuli._util import validate as check
from cumuli.light import memo as _memo
from cumuli.light.between import onto_media, own_light_of, through_media
from cumuli.light.digests import shadow_digest as _shadow_digest
from cumuli.light.memo import clear as _memo_clear
from cumuli.light.memo import remember as _remember
from cumuli.light.moved import moved
from cumuli.light.physical import check_budget, own_sun_depth, pass_plan, physical_pass
from cumuli.light.shadow import ShadowMap, compute_shadow, default_extent
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
    _memo_clear()
    for kind in registry.kinds():
        if kind.forget is not None:
            kind.forget()


def scene_shadow(
    scene: Scene, threads: int = 0, lights: Sequence[Any] | None = None
) -> ShadowMap | None:
    """The shadow map the renderers use for a scene's ground (None without a ground, or when
    no cloud can shade it), memoised by content; ``lights``: the scene's, whose particle light
    buffers (their shadow maps) it reuses."""
    if scene.ground is None:
        return None
    drift = _common_drift(scene)
    if drift is not None:
        # Everything that shades the ground is its still self moved by one horizontal offset:
        # the shadow is the still scene's, moved (a drifting deck's is computed once).
        still_scene, (ox, oz) = drift
        still = scene_shadow(still_scene, threads)
        if still is None:
            return None
        x0, z0, x1, z1 = still.extent
        return ShadowMap(still.values, (x0 + ox, z0 + oz, x1 + ox, z1 + oz), still.height)
    height = scene.ground.height
    extent = default_extent(scene, height)
    if extent is None:
        return None
    n = scene.settings.shadow_resolution
    key = ("shadow", tuple(_shadow_digest(d) for d in scene.clouds), scene.noise.identity,
           scene.settings, tuple(scene.sprite_settings.light_dict().items()),
           scene.billboard_shading, scene.sun.direction, height)  # fmt: skip
    return _remember(key, lambda: compute_shadow(scene, extent, (n, n), height, threads, lights))


def _common_drift(scene: Scene) -> tuple[Scene, tuple[float, float]] | None:
    """``(still scene, (ox, oz))`` when every drawable of ``scene`` is its still self moved by
    the same horizontal offset (:func:`cumuli.light.moved.moved`: a deck or 2018 clouds the
    same wind carries, volumes off the origin); None otherwise."""
    if not scene.clouds:
        return None
    stills, offsets = [], set()
    for drawable in scene.clouds:
        still, offset = moved(drawable)
        if offset is None or offset[1] != 0.0:
            return None
        stills.append(still)
        offsets.add(offset)
    if len(offsets) != 1:
        return None
    ox, _, oz = offsets.pop()
    return scene.replace(clouds=tuple(stills)), (ox, oz)


def _own_light(given: Any) -> Any:
    """The own light of a drawable under ``given``: a particle or billboard light shaded by the
    others keeps it as ``unshadowed``, a medium's light shaded by them is found by
    :func:`cumuli.light.between.own_light_of`."""
    unshadowed = getattr(given, "unshadowed", None)
    return unshadowed if unshadowed is not None else own_light_of(given)


def _cores(threads: int) -> int:
    """The cores ``threads`` asks for (0: all of them)."""
    return threads if threads > 0 else max(1, os.cpu_count() or 1)


def _side_by_side(
    todo: list[int], kinds: list[Any], physical: bool, threads: int
) -> tuple[list[int], list[int]]:
    """``(side, alone)``: the clouds of ``todo`` whose light passes run side by side, one core
    each, and those that run one after another on every core.

    One cloud's physical light step keeps two cores only ~80 % busy (its stages are short
    parallel loops between serial pieces), while separate clouds' steps share nothing but the
    memo (sixteen cumulus copies on two vCPUs: 847 → 774 ms). The physical pass of the media
    goes side by side in whole rounds of one cloud per core; a last round with fewer clouds
    than cores (which would leave cores idle) runs on every core instead. The light is the same
    either way (the passes do not depend on the thread count)."""
    cores = _cores(threads)
    if not physical or cores < 2:
        return [], list(todo)
    media = [k for k in todo if kinds[k].light_pass(True) is physical_pass]
    side = media[: len(media) - len(media) % cores]
    chosen = set(side)
    return side, [k for k in todo if k not in chosen]


def _marches(
    scene: Scene, todo: list[int], kinds: list[Any], given: list[Any]
) -> list[tuple[int, Any]]:
    """``(k, march)``: the marches of the own sun lattices (:func:`own_sun_depth`, one thread
    each) that the physical passes of ``todo`` are about to read, none for a light given or
    memoised already.

    When clouds are lit side by side these go first: a pass that reads the lattice of a cloud
    upstream of it then finds it made, instead of waiting for the core that is making it
    (sixteen cumulus copies on two cores: 17–33 ms of waits in a ~250 ms step). None either when
    the memo could drop a lattice before its pass reads it (two entries per cloud: its lattice
    and its light): each pass then marches what it reads itself."""
    media = [k for k in todo if given[k] is None and kinds[k].light_pass(True) is physical_pass]
    if not media or 2 * len(media) > _memo.MEMO_SIZE:
        return []
    check_budget(scene)  # as the passes would, before any lattice is made
    unlit = [
        k
        for k in media
        if not _memo.known(_light_of(k, partial(pass_plan, scene.clouds[k], scene))[0])
    ]
    return [(k, partial(own_sun_depth, scene.clouds[k], scene, 1)) for k in unlit]


def _light_of(k: int, make: Any) -> Any:
    """``make()``, its errors naming cloud ``k``."""
    try:
        return make()
    except (TypeError, ValueError) as exc:
        raise type(exc)(f"scene.clouds[{k}]: {exc}") from None


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
    given = [_own_light(g) for g in given]
    # The physical mode replaces the light pass of the media; particles and billboards keep
    # their own light models (Harris 2002, Torchelsen & Musse 2005) in either mode.
    kinds = []
    for k, drawable in enumerate(scene.clouds):  # every kind known before any work
        try:
            kinds.append(registry.of(drawable))
        except TypeError:
            raise TypeError(
                f"scene.clouds[{k}]: no light pass for {type(drawable).__name__}"
            ) from None
    physical = scene.settings.physical
    out: list[Any] = [None] * n
    for kind in {k.name: k for k in kinds}.values():  # kinds whose passes share one C++ call
        batch = kind.light_batch
        idx = [k for k, d in enumerate(scene.clouds) if d.kind == kind.name]
        if batch is not None and len(idx) > 1:
            try:
                made = batch(
                    [scene.clouds[k] for k in idx], scene, [given[k] for k in idx], threads
                )
            except (TypeError, ValueError) as exc:
                raise type(exc)(f"scene.clouds ({kind.name}): {exc}") from None
            for k, light in zip(idx, made, strict=True):
                out[k] = light
    todo = [k for k in range(n) if out[k] is None]
    side, alone = _side_by_side(todo, kinds, physical, threads)
    bar = _progress.bar(
        desc="light", total=len(todo), unit="cloud", progress=progress if len(todo) > 1 else False
    )
    with bar as steps:
        if side:
            with ThreadPoolExecutor(max_workers=_cores(threads)) as pool:
                # Every medium's own sun lattice first, one per core: the passes that read the
                # lattices of the clouds upstream of them then find them made.
                marching = [
                    (k, pool.submit(march)) for k, march in _marches(scene, todo, kinds, given)
                ]
                running = [
                    pool.submit(kinds[k].light_pass(physical), scene.clouds[k], scene, given[k], 1)
                    for k in side
                ]
                for k, made in marching:
                    _light_of(k, made.result)
                for k, made in zip(side, running, strict=True):
                    out[k] = _light_of(k, made.result)
                    steps.update()
        for k in alone:
            light_pass = kinds[k].light_pass(physical)
            with _progress.core(f"light of cloud {k}", progress):
                out[k] = _light_of(k, lambda: light_pass(scene.clouds[k], scene, given[k], threads))  # noqa: B023
            steps.update()
    out = onto_media(scene, through_media(scene, out, threads), threads)
    return LitScene(scene, tuple(out), scene_shadow(scene, threads, out))
