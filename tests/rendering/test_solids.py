"""Opaque solids inside clouds (Harris 2002 §3.1.1, Fig. 7):
the analytic solid image (GL and C++), solids hiding what lies behind them in the compositor, the
marchers stopping at a solid, particles depth-tested against it (direct rendering), and impostor
splitting (layer associativity, the object between the layers)."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.rendering.painters import CPUPainter
from cumuli.rendering.params import camera_params
from cumuli.rendering.solids import composite_split, draw_solids_cpu
from cumuli.sky import sky_args
from cumuli.testing import assert_image_close, only

W, H = 64, 48
SUN = cu.Sun(direction=(0.4, 0.8, -0.3), intensity=2.0)
BLACK = cu.Sky(zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0), sun_disc_intensity=0)
CAMERA = cu.Camera(position=(0.0, 2.0, -60.0), target=(0.0, 2.0, 0.0), fov=35)
SETTINGS = cu.RenderSettings(exact_noise=True, absorption=3.0, lighting="paper")
RED = cu.Solid((0.0, 2.0, 0.0), 3.0, (0.9, 0.2, 0.1), (0.1, 0.1, 0.1))
CLOSE = cu.Camera(position=(1.0, 3.0, -14.0), target=(0.0, 2.0, 0.0), fov=40)


def analytic(solid: cu.Solid, camera: cu.Camera, w: int, h: int) -> tuple[np.ndarray, np.ndarray]:
    """Slow float64 reference of the solid image: colour and view depth per pixel."""
    d = camera.ray_directions(w, h).astype(np.float64)
    o = np.asarray(camera.position, np.float64)
    c = np.asarray(solid.centre, np.float64)
    oc = o - c
    b = d @ oc
    disc = b * b - (oc @ oc - solid.radius**2)
    t = np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)
    with np.errstate(invalid="ignore"):
        p = o + t[..., None] * d
        n = (p - c) / solid.radius
        lam = np.maximum(n @ np.asarray(SUN.direction), 0)
    rgb = np.asarray(solid.colour) * (np.asarray(solid.ambient) + lam[..., None] * SUN.radiance)
    f = camera.basis()[0].astype(np.float64)
    return rgb, t * (d @ f)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_solid_image_is_the_analytic_lambert_sphere(backend: str) -> None:
    blue = cu.Solid((1.0, 2.5, -5.0), 1.2, (0.2, 0.5, 0.9), (0.05, 0.05, 0.05))
    scene = cu.Scene(sun=SUN, solids=(RED, blue), settings=cu.RenderSettings(lighting="paper"))
    if backend == "cpu":
        img = draw_solids_cpu(scene.solids, SUN, CLOSE, W, H)
    else:
        with cu.Renderer() as r:
            from cumuli.rendering.painters import GLPainter

            img = GLPainter(r).solids(cu.prepare_light(scene), CLOSE, W, H)
    rgb_r, z_r = analytic(RED, CLOSE, W, H)
    rgb_b, z_b = analytic(blue, CLOSE, W, H)
    blue_wins = z_b < z_r
    expect_rgb = np.where(blue_wins[..., None], rgb_b, rgb_r)
    expect_z = np.minimum(z_r, z_b)
    hit = np.isfinite(expect_z)
    # Off the silhouettes' edge pixels (where float32 may decide a grazing ray either way).
    inner = hit & (np.abs(np.isfinite(img[..., 3]).astype(int) - hit) == 0)
    assert (np.isfinite(img[..., 3]) != hit).sum() <= 2
    assert inner.sum() > 100 and blue_wins.sum() > 10  # depth test among the solids
    np.testing.assert_allclose(img[inner][:, :3], expect_rgb[inner], rtol=1e-3, atol=1e-4)
    # float32 √disc near the silhouette: ~1e−5 relative.
    np.testing.assert_allclose(img[inner][:, 3], expect_z[inner], rtol=1e-4)
    assert (img[~np.isfinite(img[..., 3])][:, :3] == 0).all()


@pytest.mark.gl
def test_solid_image_gl_and_cpu_agree() -> None:
    scene = cu.Scene(
        [cu.gaussian_cumulus(seed=1)],
        sun=SUN,
        solids=(RED,),
        settings=cu.RenderSettings(lighting="paper"),
    )
    cpu = draw_solids_cpu(scene.solids, SUN, CLOSE, W, H)
    from cumuli.rendering.compositor import shared_renderer
    from cumuli.rendering.painters import GLPainter

    renderer = shared_renderer()
    renderer.make_current()
    gl = GLPainter(renderer).solids(cu.LitScene(scene, (None,)), CLOSE, W, H)
    both = np.isfinite(gl[..., 3]) & np.isfinite(cpu[..., 3])
    assert (np.isfinite(gl[..., 3]) != np.isfinite(cpu[..., 3])).sum() <= 2
    assert np.abs(gl[both] - cpu[both]).max() <= 1e-4


def scene_with(solid: cu.Solid | None, absorption: float = 3.0) -> cu.Scene:
    return cu.Scene(
        [cu.gaussian_cumulus(centre=(0.0, 0.0, 0.0), seed=1)], sun=SUN, sky=BLACK,
        noise=cu.Noise(seed=7, size=32), settings=SETTINGS.replace(absorption=absorption),
        solids=() if solid is None else (solid,),
    )  # fmt: skip


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_solids_hide_what_lies_behind_them(backend: str) -> None:
    alone = cu.render(scene_with(None), CAMERA, W, H, backend=backend).astype(np.float64)
    for z, in_front in ((-40.0, True), (40.0, False)):
        solid = cu.Solid((2.0, 3.0, z), 4.0, (0.3, 0.8, 0.3))
        img = cu.render(scene_with(solid), CAMERA, W, H, backend=backend).astype(np.float64)
        srgb = draw_solids_cpu((solid,), SUN, CAMERA, W, H)
        mask = np.isfinite(srgb[..., 3])
        assert mask.sum() > 20 and (img[mask][:, 3] == 1.0).all()
        if in_front:  # nothing of the cloud shows over the solid
            np.testing.assert_allclose(img[mask][:, :3], srgb[mask][:, :3], atol=1e-4)
        else:  # the cloud over the solid: C + T·solid
            expect = alone[..., :3] + (1 - alone[..., 3:]) * srgb[..., :3]
            np.testing.assert_allclose(img[mask][:, :3], expect[mask], atol=1e-4)
            assert (alone[mask][:, 3] > 0.5).any()
        np.testing.assert_allclose(img[~mask], alone[~mask], atol=1e-6)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_the_marcher_stops_at_a_solid_inside_the_cloud(backend: str) -> None:
    # The cloud in front of the solid, exactly: rays that miss the solid are unchanged, rays
    # that hit it gather less cloud (samples beyond the solid are not taken), and the pixel is
    # that front part over the solid.
    painter = CPUPainter()
    plain = cu.prepare_light(scene_with(None, absorption=0.003))  # thin: the solid shows
    inside = cu.prepare_light(scene_with(RED, absorption=0.003))
    if backend == "cpu":
        unclipped = painter.layer(plain, "cloud", [0], CAMERA, W, H, False)
        clipped = painter.layer(inside, "cloud", [0], CAMERA, W, H, False)
        img = cu.render(inside, CAMERA, W, H, backend="cpu")
    else:
        with cu.Renderer() as r:
            unclipped = r.drawer("cloud").draw(plain, [0], CAMERA, W, H, False)
            clipped = r.drawer("cloud").draw(inside, [0], CAMERA, W, H, False)
            img = r.render(inside, CAMERA, W, H)
    srgb = draw_solids_cpu((RED,), SUN, CAMERA, W, H)
    hit = np.isfinite(srgb[..., 3])
    np.testing.assert_array_equal(clipped[~hit], unclipped[~hit])
    assert (clipped[hit][:, 3] <= unclipped[hit][:, 3] + 1e-6).all()
    assert (unclipped[hit][:, 3] - clipped[hit][:, 3]).max() > 0.05
    expect = clipped[..., :3] + (1 - clipped[..., 3:]) * srgb[..., :3]
    np.testing.assert_allclose(img[hit][:, :3], expect[hit], atol=1e-3)


def test_the_volume_marcher_stops_at_a_solid() -> None:
    pc = cu.particle_cumulus((0, 2, 0), 150, seed=3, radius=(2.0, 3.0))
    density, box = pc.to_volume(16)
    volume = cu.VolumeCloud(density=density, box=box, sigma_t=0.8, albedo=0.9, g=0.2)
    plain = cu.prepare_light(
        cu.Scene([volume], sun=SUN, sky=BLACK, settings=cu.RenderSettings(lighting="paper"))
    )
    inside = cu.prepare_light(
        cu.Scene(
            [volume],
            sun=SUN,
            sky=BLACK,
            solids=(RED,),
            settings=cu.RenderSettings(lighting="paper"),
        )
    )
    painter = CPUPainter()
    a = painter.layer(plain, "volume", [0], CAMERA, W, H, False)
    b = painter.layer(inside, "volume", [0], CAMERA, W, H, False)
    hit = np.isfinite(draw_solids_cpu((RED,), SUN, CAMERA, W, H)[..., 3])
    np.testing.assert_array_equal(a[~hit], b[~hit])
    assert (a[hit][:, 3] - b[hit][:, 3]).max() > 0.05


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_particles_are_depth_tested_against_solids(backend: str) -> None:
    # [H] Fig. 7 left: direct splats with the depth test. Two particles covering the solid, one
    # in front of it and one behind: the pixel is the front splat over the solid.
    front = cu.ParticleCloud([(0.0, 2.0, -8.0)], 4.0)
    both = cu.ParticleCloud([(0.0, 2.0, -8.0), (0.3, 2.2, 6.0)], 4.0)
    solid = cu.Solid((0.0, 2.0, 0.0), 2.0, (0.9, 0.9, 0.2))
    ss = cu.SpriteSettings(ambient=(0.2, 0.2, 0.2))
    sc = cu.Scene(
        [both],
        sun=SUN,
        sky=BLACK,
        solids=(solid,),
        sprite_settings=ss,
        settings=cu.RenderSettings(lighting="paper"),
    )
    img = cu.render(sc, CAMERA, W, H, backend=backend).astype(np.float64)
    f = cu.render(sc.replace(clouds=[front], solids=()), CAMERA, W, H, backend=backend)
    srgb = draw_solids_cpu((solid,), SUN, CAMERA, W, H)
    hit = np.isfinite(srgb[..., 3])
    expect = f[..., :3] + (1 - f[..., 3:]) * srgb[..., :3]
    np.testing.assert_allclose(img[hit][:, :3], expect[hit], atol=1e-5)
    # Without the solid the particle behind shows there.
    no_solid = cu.render(sc.replace(solids=()), CAMERA, W, H, backend=backend)
    assert np.abs(no_solid[hit] - f[hit]).max() > 1e-2


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_split_layers_composite_back_to_the_unsplit_layer(backend: str) -> None:
    """§10.3.5: over is associative, so the m + 1 layers with no object between them composite
    to the unsplit layer (within 1e−6)."""
    pc = cu.particle_cumulus((0, 2, 0), 300, seed=5, radius=(2.0, 3.5))
    lit = cu.prepare_light(
        cu.Scene([pc], sun=SUN, sky=BLACK, settings=cu.RenderSettings(lighting="paper"))
    )
    cuts = [55.0, 60.0, 63.0]
    if backend == "cpu":
        painter = CPUPainter()
        whole = painter.layer(lit, "particles", [0], CAMERA, W, H, False)
        parts = painter.split(lit, 0, CAMERA, W, H, cuts)
    else:
        with cu.Renderer() as r:
            whole = r.drawer("particles").draw(lit, [0], CAMERA, W, H, False)
            parts = r.drawer("particles").draw_split(lit, 0, CAMERA, W, H, cuts)
    assert parts.shape == (4, H, W, 4)
    assert all(p[..., 3].max() > 0.1 for p in parts)  # every cut leaves particles on each side
    none = np.zeros((3, H, W, 4), np.float32)
    none[..., 3] = np.inf
    np.testing.assert_allclose(composite_split(parts, none), whole, atol=1e-6)


def test_an_object_between_layers_shows_through_the_front_layer() -> None:
    """§10.3.6: back to front, layer m, object m, …, object 1, layer 0: the object's pixels are
    front.rgb + (1 − front.a)·object (alpha 1); nearer solids win (depth test among solids)."""
    rng = np.random.default_rng(3)
    a = rng.uniform(0, 1, (3, 8, 8, 1)).astype(np.float32)
    layers = np.concatenate([rng.uniform(0, 1, (3, 8, 8, 3)).astype(np.float32) * a, a], axis=-1)
    solids = np.zeros((2, 8, 8, 4), np.float32)
    solids[..., 3] = np.inf
    solids[0, :4, :, :3], solids[0, :4, :, 3] = (0.2, 0.4, 0.6), 30.0  # far object, top half
    solids[1, :, :4, :3], solids[1, :, :4, 3] = (0.9, 0.1, 0.1), 10.0  # near object, left half
    out = composite_split(layers, solids).astype(np.float64)
    lay = layers.astype(np.float64)

    def over(top: np.ndarray, below: np.ndarray) -> np.ndarray:
        return top + (1 - top[..., 3:]) * below

    obj = np.ones(4)
    near = over(lay[2], np.concatenate([solids[1, 0, 0, :3], [1.0]]) * obj)
    np.testing.assert_allclose(out[5, 1], near[5, 1], atol=1e-6)  # near object only
    far = over(lay[2], over(lay[1], np.concatenate([solids[0, 0, 7, :3], [1.0]])))
    np.testing.assert_allclose(out[1, 7], far[1, 7], atol=1e-6)  # far object only
    np.testing.assert_allclose(out[1, 1], near[1, 1], atol=1e-6)  # both: the near one wins
    plain = over(lay[2], over(lay[1], lay[0]))
    np.testing.assert_allclose(out[6, 6], plain[6, 6], atol=1e-6)  # no object


def test_bad_solid_arrays() -> None:
    from cumuli import _core

    view = ((0, 0, -5), (0, 0, 0), (0, 1, 0), 40.0, 8, 8, (0, 1, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="solids"):
        _core.draw_solids(np.zeros((2, 3), np.float32), np.zeros((2, 3)), np.zeros((2, 3)), *view)
    with pytest.raises(ValueError, match="radius"):
        bad = np.array([[0, 0, 0, -1.0]], np.float32)
        _core.draw_solids(bad, np.zeros((1, 3)), np.zeros((1, 3)), *view)
    with pytest.raises(ValueError, match="one fewer"):
        composite_split(np.zeros((2, 4, 4, 4)), np.zeros((2, 4, 4, 4)))


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_impostors_split_only_around_solids_inside_the_cloud(backend: str) -> None:
    """§10.3.6: a solid inside the bounding sphere splits the cloud's impostor (every frame); one
    outside does not. The split image keeps the solid opaque where it shows."""
    pc = cu.particle_cumulus((0, 2, 0), 300, seed=5, radius=(2.0, 3.5))
    base = cu.Scene(
        [pc],
        sun=SUN,
        sprite_settings=cu.SpriteSettings(ambient=(0.1,) * 3),
        settings=cu.RenderSettings(lighting="paper"),
    )
    inside = base.replace(solids=(cu.Solid((1.0, 3.0, -1.0), 2.5, (0.9, 0.9, 0.2)),))
    outside = base.replace(solids=(cu.Solid((0.0, 3.0, -45.0), 2.5, (0.9, 0.9, 0.2)),))
    cam = cu.Camera((6.0, 6.0, -60.0), (0.0, 2.0, 0.0), fov=35)
    for scene, split in ((inside, 1), (outside, 0)):
        cache = cu.ImpostorCache()
        for _ in range(2):
            img = cu.render(scene, cam, W, H, backend=backend, impostors=cache)
        assert cache.history[-1]["split"] == split
        assert cache.history[-1]["updates"] == ({"split": 1} if split else {})
        srgb = draw_solids_cpu(scene.solids, SUN, cam, W, H)
        hit = np.isfinite(srgb[..., 3])
        assert hit.sum() > 5 and (img[hit][:, 3] == 1.0).all()
    # Split impostors against direct depth-tested splats: the same picture up to the cuts.
    direct = cu.render(inside, cam, W, H, backend=backend)
    split_img = cu.render(inside, cam, W, H, backend=backend, impostors=cu.ImpostorCache())
    assert_image_close(split_img, direct, **only(mean_abs=2e-2))


@pytest.mark.gl
def test_split_impostors_gl_and_cpu_agree_in_exact_mode() -> None:
    pc = cu.particle_cumulus((0, 2, 0), 300, seed=5, radius=(2.0, 3.5))
    scene = cu.Scene(
        [pc], sun=SUN, solids=(cu.Solid((1.0, 3.0, -1.0), 2.5),),
        impostor_settings=cu.ImpostorSettings(exact=True),
    settings=cu.RenderSettings(lighting="paper"))  # fmt: skip
    cam = cu.Camera((6.0, 6.0, -60.0), (0.0, 2.0, 0.0), fov=35)
    gl = cu.render(scene, cam, W, H, impostors=cu.ImpostorCache())
    cpu = cu.render(scene, cam, W, H, backend="cpu", impostors=cu.ImpostorCache())
    assert_image_close(gl, cpu, **only(channel_mean_abs=1e-5))


def test_solids_and_impostors_do_not_depend_on_the_thread_count() -> None:
    pc = cu.particle_cumulus((0, 2, 0), 300, seed=5, radius=(2.0, 3.5))
    scene = cu.Scene(
        [pc, cu.gaussian_cumulus(centre=(20, 0, 30), seed=1)], sun=SUN, solids=(RED,),
        noise=cu.Noise(seed=7, size=32),
    settings=cu.RenderSettings(lighting="paper"))  # fmt: skip
    one = cu.render_cpu(scene, CAMERA, W, H, threads=1, impostors=cu.ImpostorCache())
    two = cu.render_cpu(scene, CAMERA, W, H, threads=2, impostors=cu.ImpostorCache())
    np.testing.assert_array_equal(one, two)
    np.testing.assert_array_equal(
        cu.render_cpu(scene, CAMERA, W, H, threads=1), cu.render_cpu(scene, CAMERA, W, H, threads=3)
    )


def test_bad_impostor_and_composite_arrays() -> None:
    from cumuli import _core

    cam = ((0, 0, -5), (0, 0, 0), (0, 1, 0), 40.0)
    with pytest.raises(ValueError, match="planes"):
        _core.display_impostors([np.zeros((2, 2, 4), np.float32)], np.zeros((1, 13), np.float32),
                                np.zeros(1, bool), *cam, 8, 8)  # fmt: skip
    with pytest.raises(ValueError, match="one image per"):
        _core.display_impostors([], np.zeros((1, 14), np.float32), np.zeros(1, bool), *cam, 8, 8)
    plane = np.zeros((1, 14), np.float32)
    plane[0, 3:6], plane[0, 6:9], plane[0, 9:12] = (0, 0, 1), (1, 0, 0), (0, 1, 0)
    with pytest.raises(ValueError, match="half sizes"):
        _core.display_impostors([np.zeros((2, 2, 4), np.float32)], plane, np.zeros(1, bool),
                                *cam, 8, 8)  # fmt: skip
    with pytest.raises(ValueError, match="solid must have shape"):
        _core.composite_layers(np.zeros((1, 4, 4, 4), np.float32), np.zeros((1, 2, 3), np.float32),
                               camera_params(cu.Camera(*cam)), sky_args(cu.Sky()), (0, 1, 0),
                               (1, 1, 1), 0,
                               np.zeros((3, 3, 4), np.float32))  # fmt: skip


def test_marched_cloud_impostors_stop_at_a_solid_inside() -> None:
    # [H] §7.5's "better for marched clouds": through impostors a 2018 cloud holding a solid is
    # drawn stopping at it, regenerated every frame; once the solid has left, one more update
    # drops the clipped image and the impostor is reused again.
    scene = scene_with(RED, absorption=0.003)
    cache = cu.ImpostorCache()
    for _ in range(2):
        img = cu.render_cpu(scene, CAMERA, W, H, impostors=cache)
        assert cache.history[-1]["updates"] in ({"missing": 1}, {"clip": 1})
    assert cache.history[-1]["updates"] == {"clip": 1}
    direct = cu.render_cpu(scene, CAMERA, W, H)
    assert_image_close(img, direct, **only(mean_abs=2e-2))
    away = scene.replace(solids=(cu.Solid((0.0, 2.0, -45.0), 1.0),))
    cu.render_cpu(away, CAMERA, W, H, impostors=cache)
    assert cache.history[-1]["updates"] == {"clip": 1}
    cu.render_cpu(away, CAMERA, W, H, impostors=cache)
    assert cache.history[-1]["updates"] == {}


def test_a_medium_layer_shows_what_lies_behind_through_its_delta_m_view() -> None:
    """A layer's ``view_scale`` v: the background behind coverage A shows through (1 − A)^v
    (the physical mode's δ-M view of a medium), the coverage stays A; bad scales are refused."""
    from cumuli import _core

    cam = ((0, 0, -5), (0, 0, 0), (0, 1, 0), 40.0)
    layer = np.zeros((1, 4, 4, 4), np.float32)
    layer[..., 3] = 0.5  # half covering, no radiance of its own
    boxes = np.array([[[-9, -9, -9], [9, 9, 9]]], np.float32)
    args = (camera_params(cu.Camera(*cam)), sky_args(cu.Sky()), (0, 1, 0), (1, 1, 1), 0)
    sky = _core.composite_layers(np.zeros_like(layer), boxes, *args)[..., :3]
    plain = _core.composite_layers(layer, boxes, *args)
    viewed = _core.composite_layers(layer, boxes, *args, None, None, np.array([0.55], np.float32))
    np.testing.assert_allclose(plain[..., :3], 0.5 * sky, rtol=1e-6)
    np.testing.assert_allclose(viewed[..., :3], 0.5**0.55 * sky, rtol=1e-5)
    np.testing.assert_array_equal(viewed[..., 3], plain[..., 3])
    for bad in ([0.0], [1.5], [float("nan")], [0.5, 0.5]):
        with pytest.raises(ValueError, match="view_scales"):
            _core.composite_layers(layer, boxes, *args, None, None, np.array(bad, np.float32))
