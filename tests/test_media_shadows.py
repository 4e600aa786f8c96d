"""Light reaching particle clouds through the scene's media (beyond Harris 2002, whose clouds light
only themselves): particle k's light ℓ times exp(−τ) from its centre towards ℓ through the 2018
clouds and volumes, in the light step (`cumuli.light.prepare.through_media`)."""

from __future__ import annotations

import numpy as np
import pytest
from test_ground import SUN, brute_force_transmittance, scene

import cumuli as cu

TOWARDS_SUN = np.asarray(SUN.direction, np.float64) / np.linalg.norm(SUN.direction)


def puff(distance: float) -> cu.ParticleCloud:
    """A particle cloud ``distance`` from the cumulus' centre, away from the sun."""
    centre = tuple((-distance * TOWARDS_SUN).tolist())
    return cu.particle_cumulus(centre, 200, seed=3, radius=(1.0, 2.0))


@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_a_particle_cloud_below_a_cumulus_gets_its_shadow(lighting: str) -> None:
    settings = cu.RenderSettings(lighting=lighting, light_step=0.05, exact_noise=True,
                                 physical_resolution=16, shadow_resolution=64)  # fmt: skip
    below = puff(9.0)
    s = scene(settings, clouds=[scene().clouds[0], below]).replace(ground=None)
    light = cu.prepare_light(s).lights[1]
    own = light.unshadowed
    assert own is not None and light.light.shape == own.light.shape == (200, 1)
    # The media's exp(−τ) by a fine numpy march from every particle centre towards the sun.
    want = brute_force_transmittance(s, below.centres.astype(np.float64))
    assert want.min() < 0.05 and want.max() > 0.5  # the shadow's core and its edge
    lit = own.light[:, 0] > 1e-3
    ratio = light.light[lit, 0] / own.light[lit, 0]
    assert np.abs(ratio - want[lit]).mean() < 0.01
    assert np.abs(ratio - want[lit]).max() < 0.15  # the fBm gate at a few grazing rays


def test_clear_light_stays_the_same_bits_and_is_not_shaded_twice() -> None:
    cumulus = scene().clouds[0]
    away = puff(9.0).translated((40.0, 0.0, 0.0))  # no medium between it and the sun
    alone = cu.prepare_light(scene(clouds=[away])).lights[0]
    with_media = cu.prepare_light(scene(clouds=[cumulus, away])).lights[1]
    assert np.array_equal(with_media.light, alone.light) and with_media.unshadowed is None
    below = scene(clouds=[cumulus, puff(9.0)])
    lit = cu.prepare_light(below)
    again = cu.prepare_light(lit)  # its lights are given back: the cloud's own light underneath
    assert np.array_equal(again.lights[1].light, lit.lights[1].light)
    assert again.lights[1].unshadowed is lit.lights[1].unshadowed
    # The medium moves away: the light is the cloud's own again.
    moved = cu.prepare_light(
        lit.scene.replace(clouds=[cumulus.translated((60.0, 0, 0)), puff(9.0)])
    )
    assert moved.lights[1] is lit.lights[1].unshadowed  # memoised: the very same light
    with pytest.raises(ValueError, match="transmittance"):
        lit.lights[1].through(np.ones((3, 1)))


@pytest.mark.gl
def test_the_shadowed_cloud_is_darker_in_both_backends(gl_context) -> None:
    below = puff(9.0)
    s = scene(clouds=[scene().clouds[0], below]).replace(ground=None)
    light = cu.prepare_light(s).lights[1]
    only = s.replace(clouds=[below])
    camera = cu.Camera(
        position=(-30.0, -8.0, -30.0), target=tuple(below.sphere[0].tolist()), fov=30
    )
    images = {}
    for name, value in (("shaded", light), ("own", light.unshadowed)):
        lit = cu.LitScene(only, (value,))
        gl = cu.render(lit, camera, 64, 48)
        cpu = cu.render(lit, camera, 64, 48, backend="cpu")
        np.testing.assert_allclose(gl, cpu, atol=2e-3)
        images[name] = cpu
    cover = images["own"][..., 3] > 0.5
    assert cover.sum() > 50
    shaded, own = (images[n][..., :3][cover].mean() for n in ("shaded", "own"))
    assert shaded < 0.6 * own, (shaded, own)
