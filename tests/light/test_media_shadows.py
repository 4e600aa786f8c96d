"""Light reaching particle and billboard clouds through the scene's media (beyond Harris 2002 and
Torchelsen & Musse 2005, whose clouds light only themselves): particle k's light ℓ, or a box's
(billboard's) CAF for ℓ, times exp(−τ) from its centre towards ℓ through the 2018 clouds and
volumes, in the light step (`cumuli.light.between.through_media`)."""

from __future__ import annotations

import numpy as np
import pytest
from test_ground import SUN, brute_force_transmittance, scene

import cumuli as cu
from cumuli.light.billboards import BillboardLighting, caf_points

TOWARDS_SUN = np.asarray(SUN.direction, np.float64) / np.linalg.norm(SUN.direction)


def mean_colour_shaded_and_own(
    scene_alone: cu.Scene, light: object, camera: cu.Camera, gl_cpu_atol: float, cover: float
) -> tuple[float, float]:
    """The mean RGB over the cloud's cover (alpha > ``cover`` lit by its own light) drawn alone
    with ``light`` and with ``light.unshadowed``; GL and CPU agree within ``gl_cpu_atol``."""
    images = {}
    for name, value in (("shaded", light), ("own", light.unshadowed)):
        lit = cu.LitScene(scene_alone, (value,))
        gl = cu.render(lit, camera, 64, 48)
        cpu = cu.render(lit, camera, 64, 48, backend="cpu")
        np.testing.assert_allclose(gl, cpu, atol=gl_cpu_atol)
        images[name] = cpu
    mask = images["own"][..., 3] > cover
    assert mask.sum() > 50
    return tuple(float(images[n][..., :3][mask].mean()) for n in ("shaded", "own"))


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
    shaded, own = mean_colour_shaded_and_own(only, light, camera, gl_cpu_atol=2e-3, cover=0.5)
    assert shaded < 0.6 * own, (shaded, own)


#: A fine light step for the march from the boxes (the brute force steps 0.02), exact fBm.
FINE = cu.RenderSettings(light_step=0.05, exact_noise=True, shadow_resolution=64, lighting="paper")


def seed_box(offset: tuple[float, float, float] = (14.0, 0.0, -6.0)) -> cu.BillboardCloud:
    """A seed-box cumulus behind the 2018 cumulus from the sun, half in its shadow."""
    cloud = cu.seed_box_cloud(cu.seedbox_presets.cumulus(), seed=5)
    return cloud.translated(tuple((-14.0 * TOWARDS_SUN + np.asarray(offset)).tolist()))


@pytest.mark.parametrize("at", ["box", "billboard"])
def test_a_billboard_cloud_below_a_cumulus_gets_its_shadow(at: str) -> None:
    below = seed_box()
    s = scene(FINE, clouds=[scene().clouds[0], below]).replace(
        ground=None, billboard_shading=cu.BillboardShading(caf_at=at)
    )
    light = cu.prepare_light(s).lights[1]
    own = light.unshadowed
    assert isinstance(light, BillboardLighting) and isinstance(own, BillboardLighting)
    points = caf_points(below, at)
    want_points = below.box_centres if at == "box" else below.centres
    np.testing.assert_array_equal(points, want_points)
    want = brute_force_transmittance(s, points.astype(np.float64))
    assert want.min() < 0.05 and want.max() > 0.99 and ((want > 0.05) & (want < 0.95)).any()
    caf, own_caf = light.records[0].caf, own.records[0].caf
    assert caf.dtype == np.float32 and caf.shape == own_caf.shape == (len(points),)
    lit = own_caf > 1e-3
    error = np.abs(caf[lit] / own_caf[lit] - want[lit])
    assert error.mean() < 0.02 and error.max() < 0.2  # the fBm gate at a few grazing rays
    # What else the records hold is the cloud's own light's.
    np.testing.assert_array_equal(light.records[0].length, own.records[0].length)
    assert light.records[0].at == at and light.lights == own.lights


def test_each_field_instance_gets_the_shadow_where_it_is() -> None:
    """A field's instances are placed (turned by yaw, moved by offset) before the media shade
    them: the shaded one's block follows the media, the one in the clear keeps its CAF."""
    variant = cu.seed_box_cloud(cu.seedbox_presets.cumulus(), seed=5)
    place = -14.0 * TOWARDS_SUN + np.array([14.0, 0.0, -6.0])
    offsets = [tuple(place.tolist()), (80.0, 0.0, 0.0)]
    field = cu.BillboardField([variant], offsets=offsets, yaw=[30.0, 0.0])
    s = scene(FINE, clouds=[scene().clouds[0], field]).replace(ground=None)
    light = cu.prepare_light(s).lights[1]
    own = light.unshadowed
    assert own is not None
    points = caf_points(field, "box")
    placed = [variant.rotated_y(y, about=(0, 0, 0)).translated(o)
              for y, o in zip((30.0, 0.0), offsets, strict=True)]  # fmt: skip
    np.testing.assert_allclose(
        points, np.concatenate([p.box_centres for p in placed]), rtol=0, atol=1e-5
    )
    first = light.records[0].first
    near, far = slice(first[0], first[1]), slice(first[1], first[2])
    want = brute_force_transmittance(s, points[near].astype(np.float64))
    assert want.min() < 0.05 and want.max() > 0.99
    caf, own_caf = light.records[0].caf, own.records[0].caf
    lit = own_caf[near] > 1e-3
    error = np.abs(caf[near][lit] / own_caf[near][lit] - want[lit])
    assert error.mean() < 0.02 and error.max() < 0.2
    np.testing.assert_array_equal(caf[far], own_caf[far])  # in the clear
    # An instance's part keeps its own light underneath.
    part = light.part(0)
    np.testing.assert_array_equal(part.records[0].caf, caf[near])
    np.testing.assert_array_equal(part.unshadowed.records[0].caf, own_caf[near])


def test_clear_billboard_light_stays_the_same_and_is_not_shaded_twice() -> None:
    cumulus = scene().clouds[0]
    away = seed_box().translated((60.0, 0.0, 0.0))
    alone = cu.prepare_light(scene(clouds=[away])).lights[0]
    with_media = cu.prepare_light(scene(clouds=[cumulus, away])).lights[1]
    assert with_media.unshadowed is None
    np.testing.assert_array_equal(with_media.records[0].caf, alone.records[0].caf)
    lit = cu.prepare_light(scene(clouds=[cumulus, seed_box()]))
    again = cu.prepare_light(lit)  # given back: the cloud's own light is what is given
    np.testing.assert_array_equal(again.lights[1].records[0].caf, lit.lights[1].records[0].caf)
    np.testing.assert_array_equal(
        again.lights[1].unshadowed.records[0].caf, lit.lights[1].unshadowed.records[0].caf
    )
    with pytest.raises(ValueError, match="transmittance"):
        lit.lights[1].through(np.ones((3, 1)))


@pytest.mark.gl
def test_the_shadowed_billboards_are_darker_in_both_backends(gl_context) -> None:
    below = seed_box()
    s = scene(clouds=[scene().clouds[0], below]).replace(
        ground=None, billboard_shading=cu.BillboardShading(exact_textures=True)
    )
    light = cu.prepare_light(s).lights[1]
    only = s.replace(clouds=[below])
    camera = cu.Camera(position=(-40.0, -10.0, -40.0), target=tuple(below.centre.tolist()), fov=40)
    shaded, own = mean_colour_shaded_and_own(only, light, camera, gl_cpu_atol=1e-4, cover=0.3)
    assert shaded < 0.9 * own, (shaded, own)
