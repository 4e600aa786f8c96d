"""The particle cloud (Harris 2002): particles lit by multiple forward scattering (a C++ pass, a
GLSL compute pass or the paper's read-back), splatted as sprites with the eye-pass phase."""

from __future__ import annotations

import math
from functools import partial
from typing import Any

import numpy as np

from cumuli import registry
from cumuli.light import particle_pass
from cumuli.light.particles import ParticleLight, ground_shadow, particles_digest
from cumuli.model.particles import ParticleCloud
from cumuli.rendering import particle_layers
from cumuli.rendering.impostor_units import particle_translation
from cumuli.rendering.particle_layers import (
    ParticleCloudsGL,
    draw_particle_clouds_cpu,
    split_particle_cloud_cpu,
)


def shadow_digest(cloud: ParticleCloud) -> tuple:
    """What a particle cloud's shadow depends on: its light's digest and, as its light does not
    depend on where it is, its bounding sphere."""
    centre, radius = cloud.sphere
    return ("particles", particles_digest(cloud), tuple(centre.tolist()), radius)


def sphere(cloud: ParticleCloud) -> tuple[np.ndarray, float]:
    """Its bounding sphere widened by √2: Harris's shadow map is the square around it, sampled
    bilinearly."""
    c, r = cloud.sphere
    return np.asarray(c, np.float64), float(r) * math.sqrt(2.0)


def transmittance(
    cloud: ParticleCloud, sun: Any, points: np.ndarray, scene: Any, light: Any, threads: int
) -> np.ndarray:
    """The sun's transmittance through the cloud at ``points``: Harris's own shadow map, the
    final buffer of its light pass for the sun (its light lends it when it has it)."""
    return ground_shadow(cloud, sun, points, scene.sprite_settings, light)


def receiver(cloud: ParticleCloud, light: Any) -> Any:
    """Its particles receive the others' light (a :class:`ParticleLight` row each)."""
    if not isinstance(light, ParticleLight):
        return None
    return partial(np.asarray, cloud.centres), shadow_digest(cloud)


def light_batch(clouds: Any, scene: Any, given: Any, threads: int) -> list[ParticleLight]:
    """The light of several particle clouds in one C++ call."""
    return particle_pass.particles_light_many(clouds, scene, given, threads)


KIND = registry.register(
    registry.Kind(
        name=ParticleCloud.kind,
        model=ParticleCloud,
        paper="Harris 2002",
        modules=(
            "model.particles",
            "light.particles",
            "light.particles_gl",
            "light.particle_pass",
            "light.sprite_settings",
            "rendering.particles",
            "rendering.particle_layers",
            "rendering.fidelity",
            "kinds.particles",
        ),  # fmt: skip
        light=particle_pass.particles_light,
        light_batch=light_batch,
        shadow_digest=shadow_digest,
        caster=registry.Caster(sphere=sphere, transmittance=transmittance, receiver=receiver),
        forget=particle_pass.forget,
        gl_drawer=ParticleCloudsGL,
        cpu_drawer=draw_particle_clouds_cpu,
        # Splatted cloud by cloud, back to front, in one pass (as SkyWorks does).
        groups=True,
        clips_solids=True,
        cpu_split=split_particle_cloud_cpu,
        split_key=particle_layers.sort_key,
        translation=particle_translation,
    )
)

__all__ = ["KIND", "receiver", "shadow_digest", "sphere", "transmittance"]
