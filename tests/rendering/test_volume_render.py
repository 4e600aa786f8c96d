"""Volume rendering of database frames: CPU reference, analytic cases, GL parity, bad input."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

import cumuli as cu

BOX = ((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))
CAMERA = cu.Camera(position=(0.0, 0.0, 6.0), target=(0.0, 0.0, 0.0), fov=30.0)
SKY = cu.Sky(zenith=(0.2, 0.4, 0.9), horizon=(0.6, 0.7, 0.8))


def test_empty_volume_shows_the_sky() -> None:
    vol = np.zeros((4, 4, 4), np.float32)
    light = np.ones((4, 4, 4, 4), np.float32)
    img = cu.render_volume(vol, light, BOX, CAMERA, 16, 12, cu.Sun(), SKY)
    assert img.shape == (12, 16, 4) and img.dtype == np.float32
    np.testing.assert_array_equal(img[..., 3], 0.0)
    # The render pass's sky (cumuli.Sky.colour) along the camera's rays.
    ref = SKY.colour(CAMERA.ray_directions(16, 12), cu.Sun())
    np.testing.assert_allclose(img[..., :3], ref, rtol=1e-5, atol=1e-6)
    # Row 0 looks up (+y): a brighter zenith channel on top than at the bottom.
    assert img[0, 8, 2] > img[-1, 8, 2]


def test_uniform_volume_matches_emission_absorption() -> None:
    """Centre pixel through a uniform cube with constant light:
    colour = (1 − e^{−σρL})·S + e^{−σρL}·sky."""
    rho, sigma_t, tau_sun, e_sky = 0.4, 1.3, 0.6, (1.0, 2.0, 3.0)
    vol = np.full((5, 5, 5), rho, np.float32)
    light = np.empty((5, 5, 5, 4), np.float32)
    light[..., 0] = tau_sun
    light[..., 1:] = e_sky
    sun = cu.Sun(direction=(0, 1, 0), colour=(1.0, 0.9, 0.8), intensity=2.0)
    g = 0.3
    img = cu.render_volume(
        vol, light, BOX, CAMERA, 5, 5, sun, SKY, sigma_t=sigma_t, g=g, albedo=0.9
    )
    px = img[2, 2]
    d = np.array([0.0, 0.0, -1.0])
    cos = float(d @ np.array(sun.direction))
    hg = (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * cos) ** 1.5)
    s = 0.9 * (np.array(sun.radiance) * tau_sun * hg + np.array(e_sky) / (4 * math.pi))
    t = math.exp(-sigma_t * rho * 2.0)
    expect = (1 - t) * s + t * SKY.colour(d.astype(np.float32), sun)
    np.testing.assert_allclose(px[:3], expect, rtol=1e-4)
    assert px[3] == pytest.approx(1 - t, rel=1e-5)


@pytest.fixture(scope="module")
def lit_frame() -> tuple[np.ndarray, np.ndarray, tuple]:
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), n=10, seed=2)
    db = cu.evolving_cloud_volumes(cloud, cu.Noise(seed=3, size=32), 2, 16, density_scale=2.0)
    lighting = cu.VolumeLighting(
        db, cu.Sun(direction=(0.4, 0.8, 0.3)), SKY, sh_order=3, sh_samples=3, ms_points=16
    )
    frame = cu.AnimationFrame(0, 0, 1, 0.5, True)
    anim_density = cu.blend_volumes(db[0], db[1], 0.5)
    return anim_density, lighting.light(frame), db.box


def _camera_for(box: tuple) -> cu.Camera:
    lo, hi = np.array(box[0]), np.array(box[1])
    c = (lo + hi) / 2
    return cu.Camera(position=tuple(c + np.array([0, 0.2, 2.2]) * (hi - lo).max()),
                           target=tuple(c), fov=40)  # fmt: skip


def test_cloud_frame_renders_a_cloud(lit_frame: tuple) -> None:
    vol, light, box = lit_frame
    img = cu.render_volume(vol, light, box, _camera_for(box), 32, 24, cu.Sun(), SKY, threads=1)
    alpha = img[..., 3]
    assert alpha.max() > 0.5 and alpha.min() == 0.0
    assert np.isfinite(img).all()
    again = cu.render_volume(vol, light, box, _camera_for(box), 32, 24, cu.Sun(), SKY, threads=2)
    np.testing.assert_array_equal(img, again)


@pytest.mark.gl
def test_gl_matches_cpu(lit_frame: tuple, gl_context) -> None:
    vol, light, box = lit_frame
    cam = _camera_for(box)
    sun = cu.Sun(direction=(0.4, 0.8, 0.3), colour=(1.0, 0.95, 0.9), intensity=3.0)
    cpu = cu.render_volume(vol, light, box, cam, 48, 36, sun, SKY, backend="cpu", g=0.4)
    gl = cu.render_volume(
        vol, light, box, cam, 48, 36, sun, SKY, backend="gl", g=0.4, context=gl_context
    )
    assert gl.shape == cpu.shape == (36, 48, 4)
    # Same formulas in float32 on both sides; the only differences are exp/sqrt rounding and the
    # pixel-centre arithmetic, far below one 8-bit display step.
    err = np.abs(gl - cpu)
    assert err.mean() < 1e-5
    assert err.max() < 1e-3
    with cu.VolumeRenderer(gl_context) as renderer:
        again = renderer.render(vol, light, box, cam, 48, 36, sun, SKY, g=0.4)
    np.testing.assert_array_equal(again, gl)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"backend": "vulkan"}, ValueError, "backend"),
        ({"light": np.ones((4, 4, 4, 3), np.float32)}, ValueError, "light"),
        ({"volume": np.full((4, 4, 4), np.nan, np.float32)}, ValueError, "NaN"),
        ({"width": 0}, ValueError, "width"),
        ({"step": 1e-9}, ValueError, "step"),
        (
            {"camera": SimpleNamespace(position=(0, 5, 0), target=(0, 0, 0), up=(0, 1, 0), fov=30)},
            ValueError,
            "up",
        ),
        ({"camera": (0, 0, 5)}, TypeError, "camera"),
        ({"box": ((0, 0, 0),)}, TypeError, "box"),
        ({"sun": (0, 1, 0)}, TypeError, "sun"),
        ({"g": 1.0}, ValueError, "g"),
    ],
)
def test_render_bad_input(kwargs: dict, error: type, match: str) -> None:
    args = {
        "volume": np.zeros((4, 4, 4), np.float32),
        "light": np.ones((4, 4, 4, 4), np.float32),
        "box": BOX,
        "camera": CAMERA,
        "width": 8,
        "height": 6,
        "sun": cu.Sun(),
    } | kwargs
    with pytest.raises(error, match=match):
        cu.render_volume(**args)
