"""One light for every kind: particle clouds and billboards in the physical mode take the media's
sun, phase, octaves and sky (RENDER_CONTRACT "Sprites", "One light"), GL and CPU alike; the
paper mode keeps the papers' own shading bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli.light import sprite_physical
from cumuli.light.physical import first_order_depth_scale, phase_values
from cumuli.model import seedbox_presets
from cumuli.rendering.particle_layers import draw_particle_clouds_cpu
from cumuli.rendering.particles import draw_particles_cpu

W, H = 240, 120
#: Most a sprite cloud's mean lit-side or shadow-side luminance may differ from the marched
#: cloud's beside it, as a factor. Measured at 240×120 (CPU): particles 1.08 lit / 1.40 shadow,
#: billboards 0.76 / 1.02; with the papers' own shading in the physical mode, particles were
#: 2.95 / 2.76 times as bright (billboards 0.99 / 0.69) and a darker zenith left them as they
#: were.
RATIO = 1.6


def _scene(**kw: object) -> cu.Scene:
    """A marched cumulus, a particle cumulus and a billboard cloud side by side in the physical
    default, the sun to the right, in front."""
    marched = cu.gaussian_cumulus(centre=(-32.0, 0.0, 0.0), seed=1)
    particles = cu.particle_cumulus((0.0, 0.0, 0.0), 2500, seed=1, radius=(1.2, 2.6))
    bb = cu.seed_box_cloud(seedbox_presets.cumulus(), seed=3)
    bb = bb.translated(tuple(np.array([30.0, 2.0, 0.0]) - np.asarray(bb.sphere()[0])))
    base = {
        "sun": cu.Sun(direction=(0.6, 0.45, -0.65), colour=(1.0, 0.97, 0.92), intensity=6.0),
        "sky": cu.Sky(),
        "camera": cu.Camera(position=(0.0, 3.0, -75.0), target=(0.0, 3.0, 0.0), fov=62.0),
    }
    base.update(kw)
    return cu.Scene([marched, particles, bb], **base)  # type: ignore[arg-type]


def _sides(img: np.ndarray, scene: cu.Scene) -> tuple[float, float]:
    """Mean luminance of the third of a cloud's covered pixels (alpha > 0.6) nearest the sun on
    screen, and of the third farthest from it."""
    mask = img[..., 3] > 0.6
    lum = img[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
    _, r, u = scene.camera.basis()
    sun = np.asarray(scene.sun.direction)
    s2 = np.array([sun @ r, sun @ u])
    s2 /= np.linalg.norm(s2)
    ii, jj = np.nonzero(mask)
    assert ii.size > 50, "the cloud must cover the image"
    proj = (jj - jj.mean()) * s2[0] - (ii - ii.mean()) * s2[1]
    lo, hi = np.quantile(proj, [1 / 3, 2 / 3])
    values = lum[ii, jj]
    return float(values[proj >= hi].mean()), float(values[proj <= lo].mean())


def _each(scene: cu.Scene, backend: str = "cpu") -> list[tuple[float, float]]:
    return [
        _sides(cu.render(scene.replace(clouds=[c]), width=W, height=H, backend=backend), scene)
        for c in scene.clouds
    ]


@pytest.fixture(scope="module")
def measured() -> list[tuple[float, float]]:
    return _each(_scene())


def test_sprites_sit_in_the_marched_clouds_light(measured: list) -> None:
    (m_lit, m_dark), *sprites = measured
    assert m_lit > m_dark  # the marched cloud has a lit side
    for lit, dark in sprites:
        assert 1 / RATIO <= lit / m_lit <= RATIO
        assert 1 / RATIO <= dark / m_dark <= RATIO
        assert lit > dark  # and so do the sprites


def test_the_sky_lights_the_sprites_shadow_side(measured: list) -> None:
    dark = _each(_scene(sky=cu.Sky(zenith=(0.05, 0.1, 0.2))))
    for (_, before), (_, after) in zip(measured[1:], dark[1:], strict=True):
        assert after < 0.98 * before  # a darker zenith darkens the shaded side


def test_gl_and_cpu_draw_the_same_mixed_scene() -> None:
    scene = _scene()
    cpu = cu.render(scene, width=W, height=H, backend="cpu")
    gl = cu.render(scene, width=W, height=H, backend="gl")
    assert np.abs(gl - cpu).mean(axis=(0, 1)).max() <= 1e-3


def test_the_paper_mode_keeps_harris_shading_bit_for_bit() -> None:
    scene = _scene(settings=cu.RenderSettings(lighting="paper"))
    k = 1
    lit = cu.prepare_light(scene.replace(clouds=[scene.clouds[k]]))
    layer = draw_particle_clouds_cpu(lit, [0], scene.camera, W, H, with_sky=False)
    own = draw_particles_cpu(
        scene.clouds[k], lit.lights[0], (scene.sun,), scene.camera, W, H, scene.sprite_settings
    )
    assert np.array_equal(layer, own)
    physical = cu.prepare_light(lit.scene.replace(settings=cu.RenderSettings()))
    moved = draw_particle_clouds_cpu(physical, [0], scene.camera, W, H, with_sky=False)
    assert not np.allclose(moved, own, atol=1e-3)


def test_the_octaves_are_the_media_phase_in_full_sun() -> None:
    settings = cu.RenderSettings()
    cos = np.linspace(-1, 1, 9)
    zero = np.zeros_like(cos)
    single = sprite_physical.sun_octaves(settings, zero, cos, 1)
    np.testing.assert_allclose(single, phase_values(settings, cos))
    # In full sun no light has scattered yet: the Poisson-weighted orders beyond the first vanish.
    full = sprite_physical.sun_octaves(settings, zero, cos, 4)
    np.testing.assert_allclose(full, single)
    deep = sprite_physical.sun_octaves(settings, zero + 2.0, cos, 4)
    deep_single = sprite_physical.sun_octaves(settings, zero + 2.0, cos, 1)
    k = first_order_depth_scale(settings)  # single scattering reached by the δ-M sun
    np.testing.assert_allclose(deep_single, phase_values(settings, cos) * np.exp(-2.0 * k))
    assert (deep > deep_single).all()  # inside, the higher orders add light


def test_a_particle_proxy_holds_what_its_own_light_pass_sees() -> None:
    cloud = cu.particle_cumulus((3.0, 1.0, -2.0), 300, seed=2, radius=(1.0, 2.0))
    settings = cu.SpriteSettings()
    passed = sprite_physical.passed(cloud, settings)
    assert (passed <= 1.0).all() and (passed > np.exp(-cloud.tau)).all()  # forward scattering
    off = sprite_physical.passed(cloud, cu.SpriteSettings(forward=False))
    np.testing.assert_allclose(off, np.exp(-cloud.tau.astype(np.float64)))
    lo, hi, sigma = sprite_physical.particle_extinction(cloud, settings)
    cell = (hi - lo)[0] / sigma.shape[2]
    r = cloud.radii.astype(np.float64)
    want = np.sum(-np.log(passed) / (2 * r) * 4 / 3 * math.pi * r**3)
    assert sigma.sum() * cell**3 == pytest.approx(want, rel=1e-4)  # the splat keeps it all
    # Built about the bounding sphere's centre: a moved cloud has the same lattice.
    moved = sprite_physical.particle_extinction(cloud.translated((10.0, 0.0, 5.0)), settings)
    np.testing.assert_allclose(moved[0], lo, atol=1e-4)
    np.testing.assert_allclose(moved[2], sigma, rtol=1e-3)


def test_a_billboard_proxy_holds_its_boxes_absorption() -> None:
    boxes = np.array([[[0.0, 0.0, 0.0], [4.0, 2.0, 3.0]], [[4.0, 0.0, 0.0], [6.0, 1.0, 1.0]]])
    lo, hi, sigma = sprite_physical.box_extinction(boxes, 8.0, cells=16)
    k = sprite_physical.CAF_RATE / 8.0
    centres = sprite_physical.cell_centres(lo, hi, sigma.shape).reshape(*sigma.shape, 3)
    inner = np.all((centres > 0.5) & (centres < [3.5, 1.5, 2.5]), axis=-1)
    outer = np.any((centres < -0.5) | (centres > [6.5, 2.5, 3.5]), axis=-1)
    assert np.allclose(sigma[inner], k) and np.all(sigma[outer] == 0)
    cell = (hi - lo)[0] / sigma.shape[2]
    assert sigma.sum() * cell**3 == pytest.approx(k * (24.0 + 2.0), rel=0.1)
    assert not sprite_physical.box_extinction(boxes, math.inf)[2].any()


def test_a_billboard_proxy_absorbs_as_the_caf_does() -> None:
    """Up from each box centre, the proxy's optical depth is the CAF's exp curve's (−ln CAF)."""
    cloud = cu.seed_box_cloud(seedbox_presets.cumulus(), seed=3)
    lo, hi, sigma = sprite_physical.box_extinction(cloud.boxes, 10.0)
    light = cu.absorption_factors(cloud, cu.Sun(direction=(0.0, 1.0, 0.0)), max_distance=10.0,
                                  overlap="union", curve="exp")  # fmt: skip
    cell = (hi - lo)[0] / sigma.shape[2]
    steps = (np.arange(4000) + 0.5) * cell / 20
    tau = []
    for c in cloud.box_centres.astype(np.float64):
        p = c + steps[:, None] * np.array([0.0, 1.0, 0.0])
        i = np.floor((p - lo) / cell).astype(int)
        ok = np.all((i >= 0) & (i < sigma.shape[::-1]), axis=1)
        tau.append(sigma[i[ok, 2], i[ok, 1], i[ok, 0]].sum() * cell / 20)
    want = -np.log(light.caf.astype(np.float64))
    # Within 15 % on average (measured 10 %: cells at the boxes' faces count in part).
    assert np.mean(np.abs(np.array(tau) - want)) < 0.15 * np.mean(want)


def test_corners_are_where_the_rasteriser_puts_the_vertices() -> None:
    camera = cu.Camera(position=(1.0, 2.0, -20.0), target=(0.0, 3.0, 0.0), fov=50.0)
    w, h = 200, 120
    centres = np.array([[0.5, 3.0, 1.0], [-2.0, 2.0, 4.0]])
    half = np.array([[1.5, 0.8], [2.0, 2.0]])
    rotation = np.array([30.0, -75.0])
    pts = sprite_physical.corners(centres, half, rotation, camera)
    f, r, u = (np.asarray(v, np.float64) for v in camera.basis())
    th = math.tan(math.radians(camera.fov) / 2)
    aspect = w / h
    st = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    for k in range(2):  # RENDER_CONTRACT "Sprites": pixel → (s, t), at each projected corner
        v = centres[k] - np.asarray(camera.position)
        z = v @ f
        jc, ic = w / 2 * ((v @ r) / (z * th * aspect) + 1), h / 2 * (1 - (v @ u) / (z * th))
        hx, hy = half[k] * (h / 2) / (z * th)
        psi = math.radians(rotation[k])
        for corner, (s0, t0) in zip(pts[k], st, strict=True):
            q = corner - np.asarray(camera.position)
            zq = q @ f  # the sprite lies in the view plane through its centre
            assert zq == pytest.approx(z, rel=1e-6)
            dx = w / 2 * ((q @ r) / (zq * th * aspect) + 1) - jc
            dy = h / 2 * (1 - (q @ u) / (zq * th)) - ic
            s = (dx * math.cos(psi) - dy * math.sin(psi)) / hx
            t = (-dx * math.sin(psi) - dy * math.cos(psi)) / hy
            assert (s, t) == pytest.approx((s0, t0), abs=1e-5)  # a float32 basis


def test_the_scene_shadow_is_a_ratio_clipped_to_one() -> None:
    got = sprite_physical.shadow_factor(
        np.array([0.2, 0.5, 0.0, 0.3]), np.array([0.4, 0.4, 0.0, 0.6])
    )
    np.testing.assert_allclose(got, [0.5, 1.0, 1.0, 0.5])
    np.testing.assert_array_equal(sprite_physical.shadow_factor(np.array([0.3]), None), [1.0])


def test_without_sky_light_the_shaded_side_loses_the_sky() -> None:
    scene = _scene()
    dark = _each(scene.replace(settings=cu.RenderSettings(sky_light=False)))
    lit = _each(scene)
    for (_, without), (_, with_sky) in zip(dark[1:], lit[1:], strict=True):
        assert without < 0.8 * with_sky
