"""The physical mode's air: the ground and the sky fade into the horizon's colour, distant clouds
fade into the sky with their distance (aerial perspective), and the paper mode has none."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli.rendering.air import air_fades, background, cloud_depth, ground_haze


def ground_scene(**settings) -> tuple[cu.Scene, cu.Camera]:
    scene = cu.Scene(
        [], sun=cu.Sun(direction=(0.3, 0.6, 0.4), intensity=6.0), ground=cu.Ground(height=0.0),
        settings=cu.RenderSettings(**settings),
    )  # fmt: skip
    return scene, cu.Camera(position=(0, 2, 0), target=(0, 1.6, 10), fov=40)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_the_ground_and_the_sky_fade_into_the_horizon(backend: str) -> None:
    scene, cam = ground_scene(haze=0.0, resolve=False)
    img = cu.render(scene, cam, 40, 30, backend=backend)
    raw = cu.render(scene.replace(settings=scene.settings.replace(air_extinction=0.0)), cam, 40, 30,
                    backend=backend)  # fmt: skip
    horizon = np.asarray(scene.sky.horizon)
    fade = ground_haze(scene, cam, 40, 30)
    rows = np.where(fade[:, 20] > 0)[0]
    assert len(rows) > 5  # the ground is in the picture, below the horizon
    near, far = rows[-1], rows[0]  # the bottom row is the nearest ground
    assert fade[far, 20] > 0.5 > fade[near, 20] > 0
    d_far = np.abs(img[far, 20, :3] - horizon).sum()
    assert d_far < 0.5 * np.abs(raw[far, 20, :3] - horizon).sum()  # far ground: nearly sky
    # The renderers' background is the numpy twin's, and the fade is exactly the stated blend:
    # the ground by its distance, the sky by the hazy layer's path air_height/|d.y|.
    np.testing.assert_allclose(raw[..., :3], background(scene, cam, 40, 30), atol=2e-5)
    behind, front = air_fades(scene, cam, 40, 30)
    assert not front.any()  # no cloud
    np.testing.assert_allclose(behind[rows, 20], fade[rows, 20], rtol=1e-5)
    expected = raw[..., :3] + behind[..., None] * (horizon - raw[..., :3])
    np.testing.assert_allclose(img[..., :3], expected, atol=2e-5)
    dy = cam.ray_directions(40, 30)[..., 1]
    t = 2.0 / -dy[near, 20]
    assert fade[near, 20] == pytest.approx(1 - math.exp(-0.003 * t), rel=1e-4)
    top = 1 - math.exp(-0.003 * scene.settings.air_height / dy[0, 20])
    assert behind[0, 20] == pytest.approx(top, rel=1e-4)
    # The horizon is soft: the two rows around it differ less than without the air.
    sky_row = far - 1
    step = np.abs(img[sky_row, 20, :3] - img[far, 20, :3]).sum()
    assert step < 0.5 * np.abs(raw[sky_row, 20, :3] - raw[far, 20, :3]).sum()
    paper = scene.replace(settings=cu.RenderSettings(lighting="paper"))
    assert ground_haze(paper, cam, 4, 3) is None and air_fades(paper, cam, 4, 3) is None


def cloud_scene(**settings) -> cu.Scene:
    return cu.Scene(
        [cu.gaussian_cumulus(centre=(0, 0, 0), n=8, seed=4)],
        sun=cu.Sun(direction=(0.4, 0.7, -0.5), intensity=6.0), noise=cu.Noise(seed=5, size=32),
        settings=cu.RenderSettings(physical_resolution=16, haze=0.0, resolve=False, **settings),
    )  # fmt: skip


def camera_at(distance: float) -> cu.Camera:
    """The cloud from ``distance`` along −z, framed alike (fov shrinking with the distance)."""
    fov = math.degrees(2 * math.atan(12.0 / distance))
    return cu.Camera(position=(0.0, 1.0, -distance), target=(0.0, 1.0, 0.0), fov=fov)


def test_a_far_cloud_is_closer_to_the_sky_than_the_same_cloud_near() -> None:
    scene = cloud_scene()
    lit = cu.prepare_light(scene)
    clear = cu.LitScene(scene.replace(settings=scene.settings.replace(air_extinction=0.0)),
                        lit.lights, lit.shadow)  # fmt: skip
    horizon = np.asarray(scene.sky.horizon)
    kept = {}
    for distance in (40.0, 400.0):
        cam = camera_at(distance)
        img = cu.render_cpu(lit, cam, 48, 36)
        raw = cu.render_cpu(clear, cam, 48, 36)
        body = raw[..., 3] > 0.99
        assert body.sum() > 30
        # The share of the cloud's own difference from the horizon's colour that is left.
        kept[distance] = float(
            np.abs(img[body, :3] - horizon).sum() / np.abs(raw[body, :3] - horizon).sum()
        )
        depth = cloud_depth(scene, cam, 48, 36)[body]
        assert kept[distance] == pytest.approx(math.exp(-0.003 * depth.mean()), abs=0.03)
        np.testing.assert_array_equal(img[..., 3], raw[..., 3])  # coverage unchanged
    assert kept[400.0] < 0.4 < 0.8 < kept[40.0]


def test_the_box_depth_is_the_chord_midpoint() -> None:
    scene = cloud_scene()
    cam = camera_at(40.0)
    depth = cloud_depth(scene, cam, 9, 7)
    lo, hi = scene.clouds[0].layer_box()
    centre = depth[3, 4]  # the ray through the box's middle (the camera looks at it)
    assert centre == pytest.approx(40.0 + 0.5 * (lo[2] + hi[2]), rel=1e-3)
    assert np.isnan(cloud_depth(scene, cu.Camera((0, 50, 0), (0, 100, 1), fov=20), 4, 3)).all()


@pytest.mark.gl
def test_gl_and_cpu_agree_through_the_air(gl_context) -> None:
    scene = cloud_scene(air_extinction=0.01).replace(ground=cu.Ground(height=-8.0))
    scene = scene.replace(settings=scene.settings.replace(haze=0.05, exact_noise=True))
    cam = cu.Camera(position=(0.0, 2.0, -60.0), target=(0.0, 0.0, 0.0), fov=40)
    lit = cu.prepare_light(scene)
    cpu = cu.render_cpu(lit, cam, 48, 36)
    with cu.Renderer(context=gl_context) as r:
        gl = r.render(lit, cam, 48, 36)
    diff = np.abs(gl - cpu)
    assert diff.mean(axis=(0, 1)).max() <= 1e-3


def test_the_paper_mode_ignores_the_air_settings_bit_for_bit() -> None:
    base = cloud_scene(lighting="paper").replace(ground=cu.Ground(height=-8.0))
    cam = cu.Camera(position=(0.0, 2.0, -60.0), target=(0.0, 0.0, 0.0), fov=40)
    changed = base.replace(settings=base.settings.replace(
        air_extinction=0.05, air_height=100.0, sun_angular_diameter=5.0, diffuse_shadows=False,
    ))  # fmt: skip
    a = cu.render_cpu(base, cam, 32, 24)
    b = cu.render_cpu(changed, cam, 32, 24)
    np.testing.assert_array_equal(a, b)
    la, lb = cu.prepare_light(base), cu.prepare_light(changed)
    np.testing.assert_array_equal(la.shadow.values, lb.shadow.values)


def test_the_air_settings_are_checked_and_saved(tmp_path) -> None:
    for bad, error in (({"air_height": -1.0}, ValueError), ({"sun_angular_diameter": 20.0},
                       ValueError), ({"diffuse_shadows": "yes"}, TypeError)):  # fmt: skip
        with pytest.raises(error, match=next(iter(bad))):
            cu.RenderSettings(**bad)
    s = cloud_scene(air_height=30.0, sun_angular_diameter=1.0, diffuse_shadows=False)
    back = cu.load_scene(s.save(tmp_path / "s.json"))
    assert back.settings == s.settings


@pytest.mark.parametrize("phase", ["mie", "hg", "dual_hg"])
@pytest.mark.parametrize("ground", [False, True])
def test_the_core_pass_is_the_numpy_reference(phase: str, ground: bool) -> None:
    from cumuli.rendering.air import add_air, finish
    from cumuli.rendering.resolve import tent_filter

    scene = cloud_scene(air_extinction=0.01, phase=phase).replace(
        sun=cu.Sun(direction=(0.1, 0.2, -0.97), intensity=6.0)  # towards the camera: an aureole
    )
    scene = scene.replace(settings=scene.settings.replace(haze=0.05, resolve=True))
    if ground:
        scene = scene.replace(ground=cu.Ground(height=-8.0))
    cam = cu.Camera(position=(0.0, 2.0, -60.0), target=(0.0, 0.0, 0.0), fov=40)
    shadow = cu.prepare_light(scene).shadow
    rng = np.random.default_rng(3)
    img = rng.uniform(0.0, 2.0, (36, 48, 4)).astype(np.float32)
    img[..., 3] = rng.choice([0.0, 0.4, 1.0], (36, 48))  # clear, partial and covered pixels
    ref = tent_filter(add_air(img, scene, cam, shadow))
    one = finish(img, scene, cam, shadow, threads=1)
    np.testing.assert_allclose(one, ref, rtol=1e-5, atol=1e-6)
    assert np.abs(one - img).max() > 0.01  # the air changed the image
    np.testing.assert_array_equal(finish(img, scene, cam, shadow, threads=3), one)
    # The resolve alone is numpy's tent bit for bit; the paper mode is left alone.
    plain = scene.replace(settings=scene.settings.replace(haze=0.0, air_extinction=0.0))
    np.testing.assert_array_equal(finish(img, plain, cam, shadow), tent_filter(img))
    paper = scene.replace(settings=cu.RenderSettings(lighting="paper"))
    assert finish(img, paper, cam, shadow) is img


def core_pass_args(**overrides) -> dict:
    """Keyword arguments of ``_core.finish_physical`` but the image: :func:`cloud_scene`'s sun
    and sky seen from 40 units, with air, an aureole and the resolve."""
    from cumuli.rendering.params import camera_params, physical_params, sky_params, sun_params

    scene = cloud_scene()
    args = dict(
        camera=camera_params(camera_at(40.0)), sky=sky_params(scene.sky),
        sun=sun_params(scene.sun), ground=None, boxes=np.zeros((0, 2, 3), np.float32),
        air=(0.01, 10.0, 0.05), phase=physical_params(scene.settings, 1), resolve=True,
    )  # fmt: skip
    return {**args, **overrides}


@pytest.mark.parametrize("rows", [1, 33, 64, 70])
@pytest.mark.parametrize("resolve", [True, False])
def test_the_core_pass_in_place_is_the_pass_into_a_new_image(rows: int, resolve: bool) -> None:
    """Finished where it lies, an image reads the same bits as finished into a new one: the
    resolve's blocks of 32 rows read their neighbours' edge rows before those are written over
    (one row; a last block of one row; whole blocks; a partial last block), whatever the
    threads, the edge pass's unfiltered pixels included."""
    from cumuli import _core

    rng = np.random.default_rng(rows)
    img = rng.uniform(0.0, 2.0, (rows, 9, 4)).astype(np.float32)
    img[..., 3] = rng.choice([0.0, 0.4, 1.0], (rows, 9))
    unfiltered = rng.random((rows, 9)) < 0.2
    args = core_pass_args(resolve=resolve, unfiltered=unfiltered)
    new = _core.finish_physical(img, threads=1, **args)
    assert np.abs(new - img).max() > 0.01
    for threads in (1, 2, 3):
        spent = img.copy()
        out = _core.finish_physical(spent, threads=threads, out=spent, **args)
        assert out is spent
        np.testing.assert_array_equal(spent, new)
    # Into another array: the same too, and the image is left as it was.
    kept = img.copy()
    target = np.empty_like(img)
    assert _core.finish_physical(kept, threads=2, out=target, **args) is target
    np.testing.assert_array_equal(target, new)
    np.testing.assert_array_equal(kept, img)


def test_the_core_pass_refuses_a_bad_target() -> None:
    from cumuli import _core

    args = core_pass_args()
    img = np.zeros((6, 5, 4), np.float32)
    with pytest.raises(TypeError, match="float32"):
        _core.finish_physical(img, out=np.zeros((6, 5, 4)), **args)
    with pytest.raises(TypeError, match="numpy array"):
        _core.finish_physical(img, out=[0.0], **args)
    with pytest.raises(ValueError, match="shape"):
        _core.finish_physical(img, out=np.zeros((6, 5, 3), np.float32), **args)
    with pytest.raises(ValueError, match="C-contiguous"):
        _core.finish_physical(img, out=np.zeros((5, 6, 4), np.float32).transpose(1, 0, 2), **args)
    frozen = np.zeros((6, 5, 4), np.float32)
    frozen.setflags(write=False)
    with pytest.raises(ValueError, match="writable"):
        _core.finish_physical(img, out=frozen, **args)
    # A target overlapping the image but not the image itself would read rows it has written.
    big = np.zeros((7, 5, 4), np.float32)
    with pytest.raises(ValueError, match="overlap"):
        _core.finish_physical(big[:6], out=big[1:], **args)


def test_the_render_finishes_its_own_image_in_place(monkeypatch) -> None:
    """The renderer's image is finished where the march left it, to the same values as a copy
    finished into a new image; a read-only image is never written."""
    from cumuli import _core
    from cumuli.rendering.air import finish

    scene = cloud_scene(air_extinction=0.01)
    scene = scene.replace(settings=scene.settings.replace(haze=0.05, resolve=True))
    lit = cu.prepare_light(scene)
    cam = camera_at(40.0)
    before = cu.render_cpu(lit, cam, 40, 36)
    core_pass, seen = _core.finish_physical, []

    def spying(image, *args, **kw):
        out = core_pass(image, *args, **kw)
        seen.append(out is image)
        return out

    monkeypatch.setattr(_core, "finish_physical", spying)
    np.testing.assert_array_equal(cu.render_cpu(lit, cam, 40, 36), before)
    assert seen == [True]
    raw = np.random.default_rng(5).uniform(0.0, 1.0, (36, 40, 4)).astype(np.float32)
    copy = finish(raw, scene, cam, lit.shadow)
    assert copy is not raw
    spent = raw.copy()
    assert finish(spent, scene, cam, lit.shadow, in_place=True) is spent
    np.testing.assert_array_equal(spent, copy)
    frozen = raw.copy()
    frozen.setflags(write=False)
    out = finish(frozen, scene, cam, lit.shadow, in_place=True)
    assert out is not frozen
    np.testing.assert_array_equal(frozen, raw)
    np.testing.assert_array_equal(out, copy)


def test_the_core_pass_checks_its_arguments() -> None:
    from cumuli import _core

    args = core_pass_args()
    img = np.zeros((4, 5, 4), np.float32)
    assert _core.finish_physical(img, **args).shape == (4, 5, 4)
    with pytest.raises(ValueError, match="image"):
        _core.finish_physical(np.zeros((4, 5, 3), np.float32), **args)
    with pytest.raises(ValueError, match="boxes"):
        _core.finish_physical(img, **{**args, "boxes": np.zeros((1, 3), np.float32)})
    with pytest.raises(ValueError, match="air extinction"):
        _core.finish_physical(img, **{**args, "air": (-1.0, 10.0, 0.05)})
    with pytest.raises(ValueError, match="haze"):
        _core.finish_physical(img, **{**args, "air": (0.01, 10.0, float("nan"))})
