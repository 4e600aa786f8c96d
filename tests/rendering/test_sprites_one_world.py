"""One light for every kind: particle clouds and billboards in the physical mode take the media's
sun, phase, octaves and sky (RENDER_CONTRACT "Sprites", "One light"), GL and CPU alike; the
paper mode keeps the papers' own shading bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli.light import sprite_physical
from cumuli.light.physical import phase_values
from cumuli.model import seedbox_presets
from cumuli.rendering.particle_layers import draw_particle_clouds_cpu
from cumuli.rendering.particles import draw_particles_cpu

W, H = 240, 120
#: Most a sprite cloud's mean lit-side or shadow-side luminance may differ from the marched
#: cloud's beside it, as a factor (measured at 240×120: particles 1.2 lit / 1.4 shadow,
#: billboards 0.8 / 0.9; before this light, particles were 3.0 / 2.8 times as bright).
RATIO = 2.0


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


def test_an_empty_grid_sees_the_whole_sky() -> None:
    scene = _scene()
    quad = sprite_physical.sky_quadrature(scene)
    lo, hi, shape = sprite_physical.grid_box((0, 0, 0), (4, 2, 3))
    vis = sprite_physical.visibility(np.zeros(shape), lo, hi).reshape(*shape, -1)
    got = sprite_physical.sky_at(np.array([[1.0, 1.0, 1.0]]), (lo, hi, vis), quad)
    np.testing.assert_allclose(got[0], quad[1].sum(axis=0), rtol=1e-9)
    # A uniform sky of radiance L gives the fluence 4πL.
    flat = cu.Sky(zenith=(0.5, 0.5, 0.5), horizon=(0.5, 0.5, 0.5), ground=(0.5, 0.5, 0.5))
    _, weights = sprite_physical.sky_quadrature(scene.replace(sky=flat))
    np.testing.assert_allclose(weights.sum(axis=0), 4 * math.pi * 0.5, rtol=1e-5)


def test_a_box_hides_the_sky_behind_it() -> None:
    boxes = np.array([[[0.0, 0.0, 0.0], [4.0, 4.0, 4.0]]])
    lo, hi, vis = sprite_physical.billboard_grid(boxes, 1.0)
    quad = sprite_physical.sky_quadrature(_scene())
    inside = sprite_physical.sky_at(np.array([[2.0, 2.0, 2.0]]), (lo, hi, vis), quad)
    assert (inside[0] < 0.05 * quad[1].sum(axis=0)).all()


def test_the_octaves_are_the_media_phase_at_full_sun() -> None:
    single = cu.RenderSettings(multiple_scattering=False)
    cos = np.linspace(-1, 1, 9)
    np.testing.assert_allclose(
        sprite_physical.sun_octaves(single, np.ones_like(cos), cos), phase_values(single, cos)
    )
    many = cu.RenderSettings()
    full = sprite_physical.sun_octaves(many, np.ones_like(cos), cos)
    half = sprite_physical.sun_octaves(many, np.full_like(cos, 0.5), cos)
    assert (half < full).all() and (full > phase_values(many, cos)).all()
