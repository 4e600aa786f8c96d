"""The ground (RENDER_CONTRACT "Ground"): the plane, its scene-file round trip, the sun's shadow
map against a brute-force march, its radiance, and both backends in one pass and in layers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from test_billboard_caf import reference_lengths  # the numpy slab-test reference

import cumuli as cu
from cumuli.ground import sky_irradiance
from cumuli.light.caf import ground_caf
from cumuli.light.particles import ground_shadow
from cumuli.testing import assert_image_close, only

F = np.float32
SUN = cu.Sun(direction=(0.5, 0.7, 0.3), colour=(1.0, 0.95, 0.9), intensity=3.0)
GROUND = cu.Ground(height=-10.0, albedo=(0.4, 0.35, 0.3))


def scene(settings: cu.RenderSettings | None = None, clouds=None) -> cu.Scene:
    clouds = [cu.gaussian_cumulus(centre=(0, 0, 0), n=8, seed=4)] if clouds is None else clouds
    return cu.Scene(
        clouds, sun=SUN, noise=cu.Noise(seed=5, size=32), ground=GROUND,
        settings=settings or cu.RenderSettings(exact_noise=True, physical_resolution=16,
                                               shadow_resolution=64, lighting="paper"),
    )  # fmt: skip


CAMERA = cu.Camera(position=(0.0, 8.0, -45.0), target=(0.0, -6.0, 0.0), fov=50)


def test_ground_values_and_scene_files(tmp_path: Path) -> None:
    g = cu.Ground(2.0, 0.5)
    assert g.albedo == (0.5, 0.5, 0.5)
    for bad, error in (({"albedo": 1.5}, ValueError), ({"height": float("nan")}, ValueError),
                       ({"albedo": "grey"}, TypeError)):  # fmt: skip
        with pytest.raises(error, match="ground"):
            cu.Ground(**bad)
    with pytest.raises(TypeError, match="scene.ground"):
        cu.Scene([], ground=3.0, settings=cu.RenderSettings(lighting="paper"))
    s = scene()
    back = cu.load_scene(s.save(tmp_path / "s.json"))
    assert back.ground == GROUND
    assert cu.load_scene(s.replace(ground=None).save(tmp_path / "n.json")).ground is None
    data = s.to_dict()
    data["ground"]["colour"] = 1
    with pytest.raises(ValueError, match="scene.ground has unknown field"):
        cu.Scene.from_dict(data)


def brute_force_transmittance(s: cu.Scene, points: np.ndarray, step: float = 0.02) -> np.ndarray:
    """exp(−∫σt) from each ground point towards the sun, σt = the mode's extinction × the
    density field, by the midpoint rule with a fine step (numpy, one cloud)."""
    cloud = s.clouds[0]
    k = (
        s.settings.extinction_scale
        if s.settings.physical
        else s.settings.absorption / s.settings.step_ref
    )
    sun = np.asarray(s.sun.direction)
    lo, hi = (np.asarray(b, np.float64) for b in cloud.layer_box())
    out = []
    for p in points:
        t0, t1 = 0.0, np.inf
        for a in range(3):
            ta, tb = (lo[a] - p[a]) / sun[a], (hi[a] - p[a]) / sun[a]
            t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
        if t1 <= t0:
            out.append(1.0)
            continue
        ts = np.arange(t0 + step / 2, t1, step)
        rho, _ = cloud.density(
            (p + ts[:, None] * sun).astype(F), s.noise, **s.settings.fbm_params()
        )
        out.append(math.exp(-k * rho.sum() * step))
    return np.array(out)


@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_shadow_map_matches_a_brute_force_march(lighting: str) -> None:
    # The point sun's direct transmittance (the physical mode's soft shadows off).
    s = scene(cu.RenderSettings(lighting=lighting, light_step=0.05, sun_angular_diameter=0.0,
                                diffuse_shadows=False))  # fmt: skip
    extent = ((-12.0, -8.0), (12.0, 16.0))
    t = cu.shadow_map(s, extent, (24, 20))
    assert t.shape == (20, 24) and t.dtype == np.float32
    xs = -12 + (np.arange(24) + 0.5) * 1.0
    zs = -8 + (np.arange(20) + 0.5) * 1.2
    zz, xx = np.meshgrid(zs, xs, indexing="ij")
    pts = np.stack([xx, np.full_like(xx, GROUND.height), zz], -1).reshape(-1, 3)
    want = brute_force_transmittance(s, pts).reshape(20, 24)
    assert want.min() < 0.01 and want.max() == 1.0  # a real shadow, and open ground
    # max: the fBm gate at a few grazing rays
    assert_image_close(t, want, **only(mean_abs=0.01, max_abs=0.15))


def test_shadow_map_defaults_and_bad_input() -> None:
    s = scene()
    t = cu.shadow_map(s, resolution=32)
    assert t.shape == (32, 32) and t.min() < 0.05 and t.max() > 0.99
    assert (
        cu.shadow_map(s.replace(sun=cu.Sun(direction=(0.3, -0.5, 0.1))), resolution=8) == 1
    ).all()
    with pytest.raises(TypeError, match="scene"):
        cu.shadow_map("scene")
    with pytest.raises(ValueError, match="extent"):
        cu.shadow_map(s, ((1, 1), (0, 2)))
    with pytest.raises(TypeError, match="extent"):
        cu.shadow_map(s, (1, 2, 3))
    with pytest.raises(ValueError, match="resolution"):
        cu.shadow_map(s, resolution=0)
    with pytest.raises(TypeError, match="resolution"):
        cu.shadow_map(s, resolution=2.5)


def texel_centres(extent, shape) -> np.ndarray:
    """Ground points at the texel centres of a shadow map over ``extent`` of ``shape`` (nx, nz)."""
    (x0, z0), (x1, z1) = extent
    nx, nz = shape
    xs = x0 + (np.arange(nx) + 0.5) * (x1 - x0) / nx
    zs = z0 + (np.arange(nz) + 0.5) * (z1 - z0) / nz
    zz, xx = np.meshgrid(zs, xs, indexing="ij")
    return np.stack([xx, np.full_like(xx, GROUND.height), zz], -1).reshape(-1, 3).astype(F)


def test_particle_clouds_shadow_the_ground() -> None:
    """A particle cloud shades the ground with Harris 2002's own shadow map (its light pass's final
    buffer for the sun, `ground_shadow`), multiplied into the media's exp(−τ)."""
    particles = cu.particle_cumulus(centre=(14.0, 2.0, 4.0), n_particles=300, seed=1)
    cumulus = scene().clouds[0]
    extent, shape = ((-30.0, -30.0), (30.0, 30.0)), (40, 36)
    both = scene(clouds=[cumulus, particles])
    t_media = cu.shadow_map(scene(clouds=[cumulus]), extent, shape)
    t_both = cu.shadow_map(both, extent, shape)
    t_particles = ground_shadow(
        particles, SUN, texel_centres(extent, shape), both.sprite_settings
    ).reshape(shape[::-1])
    assert t_particles.min() < 0.7 and t_particles.max() == 1.0  # a shadow, and open ground
    assert (t_media[t_particles < 0.9] > 0.99).mean() > 0.5  # mostly apart from the cumulus'
    np.testing.assert_allclose(t_both, t_media * t_particles, rtol=1e-6, atol=1e-7)
    # Alone, over the default extent (the particle cloud's box moved along the light).
    alone = scene(clouds=[particles])
    assert cu.shadow_map(alone, resolution=32).min() < 0.7
    # The light step's map follows the cloud when it moves.
    moved = scene(clouds=[particles.translated((0.0, 0.0, 20.0))])
    lit, lit_moved = cu.prepare_light(alone), cu.prepare_light(moved)
    assert lit.shadow is not None and lit_moved.shadow is not None
    assert lit_moved.shadow.extent[1] == pytest.approx(lit.shadow.extent[1] + 20.0, abs=1e-3)


def test_billboards_shadow_the_ground_by_their_caf() -> None:
    """A billboard cloud or field shades the ground with the CAF its own billboards would get
    there (beyond [TM]): 1 − L/D_max, L the chords towards the sun through its boxes."""
    cloud = cu.seed_box_cloud(cu.seedbox_presets.cumulus(), seed=5)
    shading = cu.BillboardShading(max_distance=12.0)
    extent, shape = ((-25.0, -25.0), (25.0, 25.0)), (50, 40)
    pts = texel_centres(extent, shape)
    lengths = reference_lengths(cloud.boxes, pts, SUN.direction, "sum")
    want = np.clip(1 - lengths / 12.0, 0, 1)
    assert want.min() == 0 and want.max() == 1 and (want < 1).sum() > 20
    np.testing.assert_allclose(ground_caf(cloud, SUN, pts, shading), want, atol=1e-5)
    # A field: each instance shades as its cloud turned and moved would, faded by its alpha, and
    # the instances' shadows multiply.
    offsets, yaws, alphas = [(0, 0, 0), (30, 2, 0), (-30, 0, 10)], [0.0, 90.0, 0.0], [1, 1, 0.5]
    field = cu.BillboardField([cloud], offsets=offsets, yaw=yaws, alpha=alphas)
    pts = texel_centres(((-60.0, -40.0), (60.0, 40.0)), (96, 64))
    want = np.ones(len(pts))
    for offset, yaw, alpha in zip(offsets, yaws, alphas, strict=True):
        placed = cloud.rotated_y(yaw, about=(0, 0, 0)).translated(offset)
        caf = ground_caf(placed, SUN, pts, shading)
        assert (caf < 0.5).any()
        want *= 1 - alpha * (1 - caf)
    np.testing.assert_allclose(ground_caf(field, SUN, pts, shading), want, atol=1e-5)
    # In a scene: the shadow map multiplies it in, with the scene's billboard shading.
    s = scene(clouds=[cloud]).replace(billboard_shading=shading)
    np.testing.assert_allclose(
        cu.shadow_map(s, extent, shape).ravel(),
        ground_caf(cloud, SUN, texel_centres(extent, shape), shading),
        atol=1e-6,
    )
    assert cu.prepare_light(s).shadow is not None
    # cu.ground_shadow takes every sprite kind.
    np.testing.assert_array_equal(
        cu.ground_shadow(field, SUN, pts, shading), ground_caf(field, SUN, pts, shading)
    )
    for shade in (ground_caf, cu.ground_shadow):
        with pytest.raises(TypeError, match="BillboardCloud"):
            shade(scene().clouds[0], SUN, pts)
    assert (ground_caf(cloud, cu.Sun(direction=(0.3, -0.5, 0.1)), pts) == 1).all()


@pytest.mark.gl
def test_a_particle_cloud_shadow_in_the_picture(gl_context) -> None:
    particles = cu.particle_cumulus(centre=(0.0, 2.0, 0.0), n_particles=300, seed=1)
    s = scene(cu.RenderSettings(lighting="physical", shadow_resolution=64), [particles])
    lit = cu.prepare_light(s)
    cpu = cu.render_cpu(lit, CAMERA, 64, 48)
    with cu.Renderer(context=gl_context) as r:
        gl = r.render(lit, CAMERA, 64, 48)
    assert lit.shadow is not None and lit.shadow.values.min() < 0.7
    lum = cpu[..., :3].mean(-1)
    open_ground = lum[-1, 0]  # near the camera, far from the shadow: albedo/π·(E_sun·y + E_sky)
    sky_only = np.mean(np.asarray(GROUND.albedo) / math.pi * np.asarray(sky_irradiance(s.sky)))
    darkest = sky_only + (open_ground - sky_only) * lit.shadow.values.min()
    # Ground in the shadow (the sky is brighter than open ground here).
    shaded = (cpu[..., 3] == 0) & (lum < 0.95 * open_ground)
    assert shaded.sum() > 10  # the shadow is in the picture
    assert lum[shaded].min() >= darkest - 1e-4
    assert np.abs(gl[shaded] - cpu[shaded]).max() < 1e-4


@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_ground_radiance_lit_and_shadowed(lighting: str) -> None:
    s = scene(
        cu.RenderSettings(
            lighting=lighting,
            physical_resolution=16,
            shadow_resolution=96,
            haze=0.0,
            resolve=False,
            air_extinction=0.0,
            sun_angular_diameter=0.0,
            diffuse_shadows=False,
        )
    )
    lit = cu.prepare_light(s)
    assert lit.shadow is not None and lit.shadow.values.shape == (96, 96)
    img = cu.render_cpu(lit, CAMERA, 64, 48)
    # Where no cloud shades it: albedo/π·(E_sun·sun.y + E_sky), exactly.
    e_sky = np.array(sky_irradiance(s.sky))
    open_ground = (
        np.asarray(GROUND.albedo) / math.pi * (np.asarray(SUN.radiance) * SUN.direction[1] + e_sky)
    )
    bottom = img[-1, 0, :3]  # near the camera, far from the cloud's shadow
    np.testing.assert_allclose(bottom, open_ground, rtol=1e-5)
    assert img[-1, 0, 3] == 0
    shade = open_ground * 0 + np.asarray(GROUND.albedo) / math.pi * e_sky
    lum = img[..., :3].mean(-1)
    ground = (img[..., 3] == 0) & (lum < open_ground.mean() * 0.999)
    assert ground.sum() > 10  # the cloud's shadow is in the picture
    assert lum[ground].min() == pytest.approx(shade.mean(), rel=0.05)


@pytest.mark.gl
@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_ground_gl_matches_cpu_in_one_pass_and_in_layers(gl_context, lighting: str) -> None:
    settings = cu.RenderSettings(lighting=lighting, exact_noise=True, physical_resolution=16,
                                 shadow_resolution=64)  # fmt: skip
    field = cu.density_volume(scene().clouds[0], cu.Noise(seed=5, size=32), settings, 24)
    volume = cu.VolumeCloud(density=field.values / 12.0, box=field.box, sigma_t=12.0)
    for s in (
        scene(settings),
        scene(settings, [scene().clouds[0], volume.translated((14, 4, 10))]),
    ):
        lit = cu.prepare_light(s)
        with cu.Renderer(context=gl_context) as r:
            gl = r.render(lit, CAMERA, 48, 36)
        cpu = cu.render_cpu(lit, CAMERA, 48, 36)
        assert np.abs(gl - cpu).mean(axis=(0, 1)).max() <= 1e-3
        ground = cpu[..., 3] == 0
        assert ground[-1].all() and np.abs(gl[ground] - cpu[ground]).max() < 1e-4


def test_a_volume_alone_over_a_ground_is_composited() -> None:
    """A drawer that draws no ground (the volume marcher) goes through the compositor."""
    field = cu.density_volume(
        scene().clouds[0], cu.Noise(seed=5, size=32), cu.RenderSettings(lighting="paper"), 24
    )
    volume = cu.VolumeCloud(density=field.values / 12.0, box=field.box, sigma_t=12.0)
    s = scene(cu.RenderSettings(shadow_resolution=32, lighting="paper"), [volume])
    img = cu.render_cpu(s, CAMERA, 32, 24)
    sky_only = cu.render_cpu(s.replace(ground=None), CAMERA, 32, 24)
    assert np.abs(img[-1, :, :3] - sky_only[-1, :, :3]).max() > 0.01  # the ground shows
    np.testing.assert_array_equal(img[..., 3], sky_only[..., 3])
