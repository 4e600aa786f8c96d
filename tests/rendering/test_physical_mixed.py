"""The physical mode and the ground in a scene of mixed kinds: 2018 clouds lit physically,
Harris particle clouds with their own light, solids, a shadowed ground — one compositor."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.light.physical import view_depth_scale
from cumuli.model.particles import particle_cumulus
from cumuli.testing import assert_image_close, only

SUN = cu.Sun(direction=(0.6, 0.7, -0.3), intensity=6.0)
CAMERA = cu.Camera(position=(0, 4, -40), target=(0, 0, 0), fov=50)


def mixed(lighting: str = "physical", ground: bool = True) -> cu.Scene:
    return cu.Scene(
        [
            cu.gaussian_cumulus(centre=(-6, 0, 0), seed=1),
            particle_cumulus((8, 0, 0), 500, seed=2, radius=(0.8, 1.6)),
        ],
        noise=cu.Noise(seed=7),
        sun=SUN,
        settings=cu.RenderSettings(lighting=lighting, physical_resolution=24),
        ground=cu.Ground(height=-8.0) if ground else None,
        solids=[cu.Solid(centre=(0, -2, -10), radius=2.0)],
    )


def test_particles_keep_their_light_in_the_physical_mode() -> None:
    lit = cu.prepare_light(mixed())
    assert isinstance(lit.lights[0], cu.PhysicalLight)
    assert isinstance(lit.lights[1], cu.ParticleLight)
    # The shadow map covers what both clouds can shade; the particle cloud's own shadow (its
    # light pass's final buffer) is in it too.
    assert lit.shadow is not None and lit.shadow.values.min() < 0.5
    alone = cu.prepare_light(mixed().replace(clouds=mixed().clouds[1:]))
    assert alone.shadow is not None and alone.shadow.values.min() < 0.9
    assert alone.shadow.values.max() == 1.0


@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_mixed_scene_over_a_ground_gl_matches_cpu(gl_context, lighting: str) -> None:
    scene = mixed(lighting)
    gl = cu.render(scene, CAMERA, 96, 72, backend="gl")
    cpu = cu.render(scene, CAMERA, 96, 72, backend="cpu")
    assert np.isfinite(gl).all()
    assert_image_close(gl, cpu, **only(mean_abs=1e-4))
    # Both clouds are drawn and the ground shows below the horizon.
    no_clouds = cu.render(scene.replace(clouds=[]), CAMERA, 96, 72, backend="cpu")
    changed = np.abs(cpu[..., :3] - no_clouds[..., :3]).sum(-1) > 1e-3
    assert changed[:, :40].mean() > 0.05 and changed[:, 56:].mean() > 0.05
    bottom = cpu[-4:, :, :3].mean()
    sky_only = cu.render(mixed(lighting, ground=False).replace(clouds=[]), CAMERA, 96, 72,
                         backend="cpu")  # fmt: skip
    assert abs(bottom - sky_only[-4:, :, :3].mean()) > 1e-3


def test_the_cumulus_shades_the_ground_in_the_mixed_scene() -> None:
    scene = mixed()
    lit = cu.prepare_light(scene)
    shaded = cu.render(lit, CAMERA, 96, 72, backend="cpu")
    unshaded = cu.render(
        cu.LitScene(scene, lit.lights, None), CAMERA, 96, 72, backend="cpu"
    )  # the same light without the shadow map: the ground is fully sunlit
    darker = (unshaded[..., :3] - shaded[..., :3]).sum(-1)
    assert darker.max() > 0.05
    assert darker.min() > -1e-5


def test_a_cumulus_looks_the_same_beside_a_particle_cloud() -> None:
    """One world: composited as a layer beside a particle cloud, the marched cumulus shows the
    sky behind its fringes through the same δ-M view as when it is marched alone."""
    settings = cu.RenderSettings(physical_resolution=24, resolve=False, air_extinction=0.0)
    cumulus = cu.gaussian_cumulus(centre=(-6, 0, 0), seed=1)
    far = particle_cumulus((30, 0, 0), 200, seed=2, radius=(0.8, 1.6))
    alone = cu.Scene([cumulus], noise=cu.Noise(seed=7), sun=SUN, settings=settings)
    both = alone.replace(clouds=[cumulus, far])
    a = cu.render(alone, CAMERA, 96, 72, backend="cpu")
    b = cu.render(both, CAMERA, 96, 72, backend="cpu")
    side = np.s_[:, 48:]  # the cumulus's half of the picture (+x, the particles', is on the left)
    fringe = (a[side][..., 3] > 0.05) & (a[side][..., 3] < 0.95)
    assert fringe.sum() > 10
    np.testing.assert_allclose(b[side], a[side], atol=2e-3)
    # ... and not through its coverage's 1 − α: that would darken its fringes.
    sky = cu.render(alone.replace(clouds=[]), CAMERA, 96, 72, backend="cpu")[side][..., :3]
    alpha = a[side][..., 3:]
    gap = ((1 - alpha) ** view_depth_scale(settings) - (1 - alpha)) * sky
    assert gap[fringe].max() > 0.02
