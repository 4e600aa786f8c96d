"""Eye pass of Harris 2002 particle clouds (§2.2.2, §2.3, eq. (5)).

:func:`particle_sprites` turns a lit :class:`~cumuli.model.particles.ParticleCloud` into a
:class:`~cumuli.gl.sprites.Sprites` batch for a camera, in the C++ core: colour per
particle ``C_k = ambient + Σ_ℓ c_{k,ℓ}·p(cos θ_ℓ)`` with ``c_{k,ℓ} = a_k τ_k γ/(4π)·i_{k,ℓ}·
radiance_ℓ`` and ``cos θ_ℓ = normalize(p_k − eye)·s_ℓ``, alpha ``1 − e^{−τ_k}``, back-to-front
order (distance or depth, ties by index), culling of a cloud outside the frustum and of
particles off screen (which never changes a pixel). :func:`draw_particles_cpu` and
:func:`draw_particles_gl` splat them into the premultiplied layer ``(H, W, 4)`` — no sky: a
compositor makes ``rgb = C + (1 − A)·sky``, ``alpha = A``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli._util.structs import core_struct
from cumuli.camera import Camera
from cumuli.gl import GLContext
from cumuli.gl.sprites import SpriteLayerRenderer, Sprites, camera_dict, draw_sprites_cpu
from cumuli.light.particles import (
    ParticleLight,
    SpriteSettings,
    as_lights,
    as_settings,
    light_directions,
)
from cumuli.model.particles import ParticleCloud
from cumuli.sky import Sun

#: Most a light direction may differ from the one the light was made for (component-wise).
DIRECTION_TOLERANCE = 1e-4


def _check_light(cloud: ParticleCloud, light: ParticleLight, lights: tuple[Sun, ...]) -> None:
    if not isinstance(cloud, ParticleCloud):
        raise TypeError(f"cloud must be a ParticleCloud, got {type(cloud).__name__}")
    if not isinstance(light, ParticleLight):
        raise TypeError(f"light must be a ParticleLight, got {type(light).__name__}")
    if light.light.shape[0] != cloud.n:
        raise ValueError(f"light has {light.light.shape[0]} rows, the cloud {cloud.n} particles")
    if light.n_lights != len(lights):
        raise ValueError(f"light was made for {light.n_lights} lights, {len(lights)} given")
    gap = np.abs(light.light_dirs - light_directions(lights)).max()
    if gap > DIRECTION_TOLERANCE:
        raise ValueError(
            f"light was made for other light directions (differ by {gap:.3g}): relight the cloud"
        )


def particle_sprites(
    cloud: ParticleCloud,
    light: ParticleLight,
    lights: Sun | Sequence[Sun],
    camera: Camera,
    width: int,
    height: int,
    settings: SpriteSettings | None = None,
    ambient: Sequence[float] | None = None,
    *,
    cull: bool = True,
    return_keys: bool = False,
) -> Any:
    """The cloud's sprites for ``camera`` at ``width × height``, back to front (spec §5 steps
    1–4). ``lights`` are the suns ``light`` was computed for, in the same order (their colour and
    intensity may have changed since). ``ambient`` overrides ``settings.ambient``. With
    ``return_keys`` also the sort keys ``(M,)`` (distance or depth, decreasing)."""
    settings = as_settings(settings)
    lights = as_lights(lights)
    _check_light(cloud, light, lights)
    amb = settings.ambient if ambient is None else check.radiance(ambient, "ambient")
    if not isinstance(cull, (bool, np.bool_)):
        raise TypeError("cull must be a bool")
    cam = camera_dict(camera, width, height, settings.near)
    radiance = np.array([s.radiance for s in lights], dtype=np.float32).reshape(-1, 3)
    index, colours, alpha, keys = _core.particle_sprites(
        *cloud.core_args(),
        light.light,
        light_directions(lights),
        radiance,
        cam,
        core_struct(
            _core.ParticleSpriteSettings,
            solid_angle=settings.solid_angle,
            phase=settings.phase,
            hg_g=settings.hg_g,
            ambient=amb,
            sort=settings.sort,
            cull=bool(cull),
        ),
    )
    sprites = Sprites(
        centres=cloud.centres[index],
        half_sizes=cloud.radii[index],
        colours=colours,
        alpha=alpha,
    )
    return (sprites, keys) if return_keys else sprites


def draw_particles_cpu(
    cloud: ParticleCloud,
    light: ParticleLight,
    lights: Sun | Sequence[Sun],
    camera: Camera,
    width: int,
    height: int,
    settings: SpriteSettings | None = None,
    *,
    ambient: Sequence[float] | None = None,
    cull: bool = True,
    threads: int = 0,
) -> np.ndarray:
    """The premultiplied layer ``(height, width, 4)`` of the cloud, by the C++ CPU twin."""
    settings = as_settings(settings)
    sprites = particle_sprites(
        cloud, light, lights, camera, width, height, settings, ambient, cull=cull
    )
    return draw_sprites_cpu(
        sprites,
        camera,
        width,
        height,
        kernel=settings.kernel,
        peak=settings.peak,
        near=settings.near,
        threads=threads,
    )


def draw_particles_gl(
    cloud: ParticleCloud,
    light: ParticleLight,
    lights: Sun | Sequence[Sun],
    camera: Camera,
    width: int,
    height: int,
    settings: SpriteSettings | None = None,
    *,
    ambient: Sequence[float] | None = None,
    cull: bool = True,
    renderer: SpriteLayerRenderer | None = None,
    context: GLContext | None = None,
) -> np.ndarray:
    """The premultiplied layer ``(height, width, 4)`` of the cloud, by the GL sprite pipeline.

    Pass a :class:`~cumuli.gl.sprites.SpriteLayerRenderer` to reuse its compiled program
    across frames; otherwise one is made on ``context`` (default: the process-wide context) and
    released.
    """
    settings = as_settings(settings)
    sprites = particle_sprites(
        cloud, light, lights, camera, width, height, settings, ambient, cull=cull
    )
    if renderer is not None:
        if not isinstance(renderer, SpriteLayerRenderer):
            raise TypeError(
                f"renderer must be a SpriteLayerRenderer, got {type(renderer).__name__}"
            )
        return renderer.draw(
            sprites,
            camera,
            width,
            height,
            kernel=settings.kernel,
            peak=settings.peak,
            near=settings.near,
        )
    with SpriteLayerRenderer(context) as own:
        return own.draw(
            sprites,
            camera,
            width,
            height,
            kernel=settings.kernel,
            peak=settings.peak,
            near=settings.near,
        )
