"""Particle clouds and billboards shade the media and one another (beyond Harris 2002 and
Torchelsen & Musse 2005): the light step multiplies each 2018 cloud's and volume's sun term by
the sun's transmittance through them at the term's grid points (`cumuli.light.between.onto_media`),
and each particle's or box's sunlight by the transmittance through the other particle clouds and
billboards (`cumuli.light.between.through_media`)."""

from __future__ import annotations

import copy
import pickle
from dataclasses import replace

import numpy as np
import pytest
from test_ground import SUN

import cumuli as cu
from cumuli.light.billboards import caf_points
from cumuli.light.onto_media import frame_nodes, voxel_centres
from cumuli.light.shadow import Casters, caster_transmittance

TOWARDS_SUN = np.asarray(SUN.direction, np.float64) / np.linalg.norm(SUN.direction)
SETTINGS = {"exact_noise": True, "physical_resolution": 16}
#: Particle clouds and billboards shading one another (off by default).
ON = cu.RenderSettings(sprite_shadows=True, lighting="paper")


def cumulus() -> cu.Cloud:
    return cu.gaussian_cumulus(centre=(0, 0, 0), n=8, seed=4)


def puff_above(distance: float = 9.0) -> cu.ParticleCloud:
    """A particle cloud ``distance`` from the cumulus' centre towards the sun."""
    centre = tuple((distance * TOWARDS_SUN).tolist())
    return cu.particle_cumulus(centre, 400, seed=3, radius=(2.0, 4.0))


def scene(clouds: list, lighting: str = "paper") -> cu.Scene:
    settings = cu.RenderSettings(lighting=lighting, **SETTINGS)
    return cu.Scene(clouds, sun=SUN, noise=cu.Noise(seed=5, size=32), settings=settings)


def misses_sphere(points: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Whether the ray from each point towards the sun misses the sphere."""
    to_centre = centre[None, :] - points.astype(np.float64)
    along = np.clip(to_centre @ TOWARDS_SUN, 0.0, None)  # nearest approach ahead of the point
    nearest = points + along[:, None] * TOWARDS_SUN[None, :]
    return np.linalg.norm(nearest - centre[None, :], axis=1) > radius


def test_grid_points_follow_the_grids_conventions() -> None:
    # Voxel (i, j, k) of a [z, y, x] grid at lo + ((i, j, k) + ½)(hi − lo)/(W, H, D).
    pts = voxel_centres(((0, 0, 0), (2, 4, 6)), (3, 2, 1))
    assert pts.shape == (6, 3)
    np.testing.assert_array_equal(pts[0], [1.0, 1.0, 1.0])
    np.testing.assert_array_equal(pts[1], [1.0, 3.0, 1.0])  # y next
    np.testing.assert_array_equal(pts[2], [1.0, 1.0, 3.0])  # then z
    # The physical light's sun lattice: its own trilinear sampler reads each node's value.
    light = cu.prepare_light(scene([cumulus()], "physical")).lights[0]
    nodes = frame_nodes(light.frame, light.sun_depth.shape)
    np.testing.assert_allclose(
        light.sample_depth(nodes), light.sun_depth.reshape(-1), rtol=1e-4, atol=1e-4
    )


@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_a_cumulus_below_a_particle_cloud_gets_its_shadow(lighting: str) -> None:
    above = puff_above()
    s = scene([cumulus(), above], lighting)
    light = cu.prepare_light(s).lights[0]
    own = cu.prepare_light(scene([cumulus()], lighting)).lights[0]
    centre, radius = (np.asarray(above.sphere[0], np.float64), float(above.sphere[1]))
    if lighting == "paper":
        assert isinstance(light, cu.LightGrid) and light.box == own.box
        assert light.record == replace(own.record, shaded=True) and light.sun == own.sun
        points = voxel_centres(light.box, light.shape)
        ratio = np.divide(light.values, own.values, out=np.ones_like(own.values),
                          where=own.values > 1e-4).reshape(-1)  # fmt: skip
        want = caster_transmittance(s, points, 0, None)
        lit = own.values.reshape(-1) > 1e-4
        np.testing.assert_allclose(ratio[lit], want[lit], rtol=1e-5, atol=1e-6)
    else:
        assert isinstance(light, cu.PhysicalLight)
        points = frame_nodes(light.frame, light.sun_depth.shape)
        want = caster_transmittance(s, points, 0, None)
        extra = (light.sun_depth - own.sun_depth).reshape(-1)
        np.testing.assert_allclose(extra, -np.log(want), rtol=1e-4, atol=1e-4)
        ratio = np.exp(-extra)
        # The diffuse sunlight is shaded at its own voxels; the sky light is left as it is.
        np.testing.assert_array_equal(light.grid[..., 1:], own.grid[..., 1:])
        grid_want = caster_transmittance(s, voxel_centres(light.box, light.grid.shape[:3]), 0)
        np.testing.assert_allclose(
            light.grid[..., 0].reshape(-1), own.grid[..., 0].reshape(-1) * grid_want, rtol=1e-5
        )
    assert ratio.min() < 0.5  # the core of the shadow
    assert (ratio <= 1.0 + 1e-6).all()
    clear = misses_sphere(points, centre, 1.05 * radius)
    assert clear.any() and (~clear).any()
    np.testing.assert_array_equal(ratio[clear], 1.0)  # rays that miss the particles: unshaded


def test_billboards_shade_a_volume_sun_channel_only() -> None:
    field = cu.light_grid(cumulus(), SUN, cu.Noise(seed=5, size=32), resolution=12)
    volume = cu.VolumeCloud(density=np.asarray(field.values) * 0.5, box=field.box, sigma_t=2.0)
    boxes = cu.seed_box_cloud(cu.seedbox_presets.cumulus(), seed=5)
    centre = (np.asarray(boxes.layer_box()[0]) + np.asarray(boxes.layer_box()[1])) / 2
    above = boxes.translated(tuple((10.0 * TOWARDS_SUN - centre).tolist()))
    s = scene([volume, above])
    light = cu.prepare_light(s).lights[0]
    own = cu.prepare_light(scene([volume])).lights[0]
    assert light.shape == own.shape == (*volume.shape, 4)
    np.testing.assert_array_equal(light[..., 1:], own[..., 1:])
    want = caster_transmittance(s, voxel_centres(volume.box, volume.shape), 0)
    np.testing.assert_allclose(light[..., 0].reshape(-1), own[..., 0].reshape(-1) * want,
                               rtol=1e-6)  # fmt: skip
    assert want.min() < 0.9 and want.max() == 1.0
    # A pickled copy carries its own light: given back, it is shaded once, as the scene is.
    copies = [pickle.loads(pickle.dumps(light)), copy.deepcopy(light), light.copy()]
    for duplicate in copies:
        assert duplicate.shaded_from is not None
        again = cu.prepare_light(s, lights=[duplicate, None]).lights[0]
        np.testing.assert_array_equal(again, light)
    assert light[..., 0].shaded_from is None  # a part of the light is not the light
    pickled = copies[0]
    alone = cu.prepare_light(scene([volume]), lights=[pickled]).lights[0]
    np.testing.assert_array_equal(alone, own)
    assert getattr(light * 1.0, "shaded_from", None) is None  # arithmetic gives plain arrays


def test_clear_light_is_the_same_object_and_nothing_is_shaded_twice() -> None:
    own = cu.prepare_light(scene([cumulus()])).lights[0]
    far = puff_above().translated((60.0, 0.0, 0.0))  # not between the cumulus and the sun
    assert cu.prepare_light(scene([cumulus(), far])).lights[0] is own
    lit = cu.prepare_light(scene([cumulus(), puff_above()]))
    assert lit.lights[0] is not own
    again = cu.prepare_light(lit)  # its lights given back: the medium's own light underneath
    np.testing.assert_array_equal(again.lights[0].values, lit.lights[0].values)
    lit2 = cu.prepare_light(lit.scene, lights=list(lit.lights))
    np.testing.assert_array_equal(lit2.lights[0].values, lit.lights[0].values)
    # The particles move away: the medium's own light again, the very same object.
    moved = cu.prepare_light(lit.scene.replace(clouds=[cumulus(), far]), lights=list(lit.lights))
    assert moved.lights[0] is own


@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_a_copy_of_a_shaded_light_given_back_is_not_shaded_twice(lighting: str, tmp_path) -> None:
    """A pickled (or, for a grid, saved and loaded) shaded light carries the mark of its
    shading: given back, the medium's own light is shaded once, as the scene is."""
    lit = cu.prepare_light(scene([cumulus(), puff_above()], lighting))
    shaded = lit.lights[0]
    copies = [pickle.loads(pickle.dumps(shaded)), copy.deepcopy(shaded)]
    if lighting == "paper":
        assert shaded.record is not None and shaded.record.shaded
        copies.append(cu.load_light_grid(shaded.save(tmp_path / "shaded.npz")))
    else:
        assert shaded.shaded_from is not None
    for duplicate in copies:
        again = cu.prepare_light(lit.scene, lights=[duplicate, None]).lights[0]
        if lighting == "paper":
            np.testing.assert_array_equal(again.values, shaded.values)
        else:
            np.testing.assert_array_equal(again.sun_depth, shaded.sun_depth)
            np.testing.assert_array_equal(again.grid, shaded.grid)
    # The particles gone: the own light again, not the copy's shaded values.
    alone = cu.prepare_light(scene([cumulus()], lighting), lights=[copies[0]]).lights[0]
    own = cu.prepare_light(scene([cumulus()], lighting)).lights[0]
    if lighting == "paper":
        np.testing.assert_array_equal(alone.values, own.values)
    else:
        np.testing.assert_array_equal(alone.sun_depth, own.sun_depth)


@pytest.mark.gl
@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_the_shaded_cumulus_is_darker_in_both_backends(gl_context, lighting: str) -> None:
    above = puff_above()
    # Across the sun: the particle cloud shows above the cumulus, the shaded top below it.
    camera = cu.Camera(position=(20.0, 4.0, -34.0), target=(0.0, 2.0, 0.0), fov=45)
    images = {}
    for name, clouds in (("with", [cumulus(), above]), ("alone", [cumulus()]),
                         ("particles", [above])):  # fmt: skip
        s = scene(clouds, lighting)
        gl = cu.render(s, camera, 80, 60)
        cpu = cu.render(s, camera, 80, 60, backend="cpu")
        np.testing.assert_allclose(gl, cpu, atol=2e-3)
        images[name] = cpu
    # The cumulus where the particle cloud does not cover it on screen.
    mask = (images["alone"][..., 3] > 0.5) & (images["particles"][..., 3] < 1e-3)
    assert mask.sum() > 100
    shaded = float(images["with"][..., :3][mask].mean())
    unshaded = float(images["alone"][..., :3][mask].mean())
    # Unshaded the two would be equal (nothing else reaches these pixels). The physical mode's
    # sky light is untouched and its scattering octaves soften every sun shadow (0.96 here),
    # the paper mode's NDT light drops with the sun's (0.66).
    assert shaded < (0.98 if lighting == "physical" else 0.8) * unshaded, (shaded, unshaded)


def seed_boxes_at(centre: np.ndarray) -> cu.BillboardCloud:
    boxes = cu.seed_box_cloud(cu.seedbox_presets.cumulus(), seed=5)
    lo, hi = (np.asarray(v) for v in boxes.layer_box())
    return boxes.translated(tuple((centre - (lo + hi) / 2).tolist()))


def test_particle_clouds_and_billboards_shade_one_another() -> None:
    low = cu.particle_cumulus((0, 0, 0), 300, seed=2, radius=(2.0, 3.0))
    across = np.cross(TOWARDS_SUN, (0.0, 1.0, 0.0))
    across /= np.linalg.norm(across)
    place = 40 * TOWARDS_SUN + 14 * across  # half over the low cloud, seen from the sun
    high = cu.particle_cumulus(tuple(place.tolist()), 300, seed=3, radius=(2.0, 3.0))
    extra = cu.Sun(direction=(-0.6, 0.5, -0.2), intensity=0.5)  # clear of the high cloud
    off = cu.Scene(
        [low, high], sun=SUN, lights=(extra,), settings=cu.RenderSettings(lighting="paper")
    )
    assert all(light.unshadowed is None for light in cu.prepare_light(off).lights)  # default
    s = off.replace(settings=ON)
    a, b = cu.prepare_light(s).lights
    assert b.unshadowed is None  # the low cloud lies behind the high one from the sun
    own = a.unshadowed
    assert own is not None and a.light.shape == own.light.shape == (300, 2)
    lit = own.light[:, 0] > 1e-4
    ratio = np.ones(300)
    ratio[lit] = a.light[lit, 0] / own.light[lit, 0]
    want = cu.ground_shadow(high, SUN, low.centres, s.sprite_settings)
    np.testing.assert_allclose(ratio[lit], want[lit], rtol=1e-5, atol=1e-6)
    assert ratio.min() < 0.8
    clear = misses_sphere(low.centres, np.asarray(high.sphere[0], np.float64), high.sphere[1])
    assert clear.any()
    np.testing.assert_array_equal(ratio[clear], 1.0)
    np.testing.assert_array_equal(a.light[:, 1], own.light[:, 1])  # only the sun's column
    # Given back, nothing is shaded twice.
    again = cu.prepare_light(cu.prepare_light(s))
    np.testing.assert_array_equal(again.lights[0].light, a.light)

    # Billboards above particles, and particles above billboards.
    boxes = seed_boxes_at(30 * TOWARDS_SUN)
    s2 = cu.Scene([low, boxes], sun=SUN, settings=ON)
    p_light, b_light = cu.prepare_light(s2).lights
    assert b_light.unshadowed is None and p_light.unshadowed is not None
    want = cu.ground_shadow(boxes, SUN, low.centres, s2.billboard_shading)
    lit = p_light.unshadowed.light[:, 0] > 1e-4
    np.testing.assert_allclose(
        p_light.light[lit, 0] / p_light.unshadowed.light[lit, 0], want[lit], rtol=1e-5, atol=1e-6
    )
    assert want.min() < 0.9
    under = seed_boxes_at(-30 * TOWARDS_SUN)
    s3 = cu.Scene([under, high.translated(tuple((-40 * TOWARDS_SUN - 14 * across).tolist()))],
                  sun=SUN, settings=ON)  # fmt: skip
    b_light, p_light = cu.prepare_light(s3).lights
    assert p_light.unshadowed is None and b_light.unshadowed is not None
    points = caf_points(under, b_light.records[0].at)
    want = cu.ground_shadow(s3.clouds[1], SUN, points, s3.sprite_settings)
    caf, own_caf = b_light.records[0].caf, b_light.unshadowed.records[0].caf
    lit = own_caf > 1e-4
    np.testing.assert_allclose(caf[lit] / own_caf[lit], want[lit], rtol=1e-5, atol=1e-6)
    assert want.min() < 0.9


def test_extra_lights_are_shaded_by_the_other_sprites_too() -> None:
    """With sprite_shadows, light ℓ of scene.lights is shaded like the sun: by the casters its
    rays cross, each by its own light model (a particle cloud's pass towards ℓ lends its
    buffer), and the sun's column stays as it is when the caster is off the sun's rays."""
    extra = cu.Sun(direction=(-0.6, 0.5, -0.2), intensity=0.5)
    towards = np.asarray(extra.direction, np.float64) / np.linalg.norm(extra.direction)
    across = np.cross(towards, (0.0, 1.0, 0.0))
    across /= np.linalg.norm(across)
    low = cu.particle_cumulus((0, 0, 0), 300, seed=2, radius=(2.0, 3.0))
    place = 40 * towards + 14 * across  # half over the low cloud, seen from the extra light
    high = cu.particle_cumulus(tuple(place.tolist()), 300, seed=3, radius=(2.0, 3.0))
    s = cu.Scene([low, high], sun=SUN, lights=(extra,), settings=ON)
    a, b = cu.prepare_light(s).lights
    own = a.unshadowed
    assert own is not None and b.unshadowed is None
    np.testing.assert_array_equal(a.light[:, 0], own.light[:, 0])  # the sun's column
    lit = own.light[:, 1] > 1e-4
    want = cu.ground_shadow(high, extra, low.centres, s.sprite_settings)
    np.testing.assert_allclose(a.light[lit, 1] / own.light[lit, 1], want[lit], rtol=1e-5, atol=1e-6)
    assert want[lit].min() < 0.8
    # The buffer of the caster's own pass towards the extra light gives the same shadow.
    assert b.buffers is not None and len(b.buffers) == 2
    lent = cu.ground_shadow(high, extra, low.centres, s.sprite_settings, b)
    np.testing.assert_allclose(lent, want, rtol=1e-5, atol=1e-5)  # float32 passes
    # Without sprite_shadows neither column is shaded; billboards shade light ℓ too.
    assert (
        cu.prepare_light(s.replace(settings=cu.RenderSettings(lighting="paper")))
        .lights[0]
        .unshadowed
        is None
    )
    boxes = seed_boxes_at(30 * towards)
    p_light = cu.prepare_light(cu.Scene([low, boxes], sun=SUN, lights=(extra,), settings=ON))
    p_light = p_light.lights[0]
    want = cu.ground_shadow(
        boxes,
        extra,
        low.centres,
        cu.Scene([boxes], settings=cu.RenderSettings(lighting="paper")).billboard_shading,
    )
    lit = p_light.unshadowed.light[:, 1] > 1e-4
    np.testing.assert_allclose(
        p_light.light[lit, 1] / p_light.unshadowed.light[lit, 1], want[lit], rtol=1e-5, atol=1e-6
    )
    assert want.min() < 0.9


def test_only_casters_up_sun_are_evaluated_and_nothing_is_lost() -> None:
    """The culling by bounding spheres drops only casters whose shadow is exactly 1 there."""
    rng = np.random.default_rng(11)
    clouds = [
        cu.particle_cumulus(tuple(rng.uniform((-60, 0, -60), (60, 40, 60))), 60, seed=int(k),
                            radius=(0.5, 1.0))
        for k in range(14)
    ] + [seed_boxes_at(rng.uniform((-40, 10, -40), (40, 30, 40))) for _ in range(2)]  # fmt: skip
    s = cu.Scene(clouds, sun=SUN, settings=cu.RenderSettings(lighting="paper"))
    casters = Casters.of(s)
    assert list(casters.index) == list(range(16))
    kept = 0
    for k, cloud in enumerate(clouds):
        # The receiver's sphere as through_media takes it (its own caster sphere).
        points = caf_points(cloud, "box") if k >= 14 else cloud.centres
        assert np.linalg.norm(points - casters.centre[k], axis=1).max() <= casters.radius[k]
        among = casters.towards_sun(SUN.direction, casters.centre[k], casters.radius[k], skip=k)
        kept += len(among)
        everyone = [j for j in range(16) if j != k]
        full = caster_transmittance(s, points, 0, None, everyone)
        culled = caster_transmittance(s, points, 0, None, among) if among else None
        np.testing.assert_array_equal(np.ones_like(full) if culled is None else culled, full)
    assert 0 < kept < 16 * 15 // 2  # some casters matter, most are culled
    # A caster straight up-sun is kept, one down-sun or far to the side is not.
    ahead = Casters(np.array([0, 1, 2]), np.array([10 * TOWARDS_SUN, -10 * TOWARDS_SUN,
                    10 * TOWARDS_SUN + [0.0, 0.0, 50.0]]), np.array([1.0, 1.0, 1.0]))  # fmt: skip
    assert ahead.towards_sun(SUN.direction, (0, 0, 0), 1.0) == [0]


def test_a_billboard_box_beyond_its_quads_still_shades() -> None:
    """The CAF's chords run through the boxes: a caster is bounded by its boxes and its quads."""
    sun = cu.Sun(direction=(0.0, 1.0, 0.0))
    wide = cu.BillboardCloud(
        boxes=np.array([[[-15, 20, -15], [15, 30, 15]]], np.float32), box_level=[0],
        box_seed=[0], box_direction=[0], centres=np.array([[13, 25, 13]], np.float32),
        sizes=np.array([[2, 2]], np.float32), texture=[0], box=[0], rotation=[0],
    )  # fmt: skip
    pc = cu.particle_cumulus((0, 0, 0), 60, seed=1, radius=(0.5, 1.0))
    s = cu.Scene([pc, wide], sun=sun, settings=ON)
    light = cu.prepare_light(s).lights[0]
    want = cu.ground_shadow(wide, sun, pc.centres, s.billboard_shading)
    assert want.min() < 0.6 and light.unshadowed is not None
    lit = light.unshadowed.light[:, 0] > 1e-4
    np.testing.assert_allclose(light.light[lit, 0] / light.unshadowed.light[lit, 0], want[lit],
                               rtol=1e-5, atol=1e-6)  # fmt: skip


def test_a_moved_volume_given_its_light_back_is_shaded_where_it_is() -> None:
    field = cu.light_grid(cumulus(), SUN, cu.Noise(seed=5, size=32), resolution=12)
    volume = cu.VolumeCloud(density=np.asarray(field.values) * 0.5, box=field.box, sigma_t=2.0)
    lit = cu.prepare_light(scene([volume, puff_above()]))
    own = cu.prepare_light(scene([volume])).lights[0]
    assert lit.lights[0][..., 0].min() < own[..., 0].min()  # shaded
    away = volume.translated((60.0, 0.0, 0.0))  # its own light is the same
    moved = cu.prepare_light(lit.scene.replace(clouds=[away, puff_above()]), lights=lit.lights)
    np.testing.assert_array_equal(moved.lights[0], own)  # out of the shadow: its own light


def test_particle_shadows_with_gain_stay_transmittances() -> None:
    gain = cu.SpriteSettings(solid_angle=3.0, allow_gain=True)
    field = cu.light_grid(cumulus(), SUN, cu.Noise(seed=5, size=32), resolution=12)
    volume = cu.VolumeCloud(density=np.asarray(field.values) * 0.5, box=field.box, sigma_t=2.0)
    s = scene([volume, puff_above()]).replace(sprite_settings=gain)
    t = caster_transmittance(s, voxel_centres(volume.box, volume.shape))
    assert t is not None and np.isfinite(t).all() and t.min() >= 0.0 and t.max() <= 1.0
    light = cu.prepare_light(s).lights[0]
    own = cu.prepare_light(scene([volume])).lights[0]
    assert np.isfinite(light).all() and (light[..., 0] <= own[..., 0]).all()
