"""Rendering billboard clouds and fields (Torchelsen & Musse 2005; spec §5, tests §11.3): one
billboard against the analytic rectangle and colour, GL vs CPU parity (exact and fast modes,
vertex and fragment shading), order, alpha, culling, fades, the single pass of a billboards-only
scene, the light pass (memo, relight tolerance, given light) and bad input."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import cumuli as cu
from cumuli.gl.sprites import draw_sprites_cpu
from cumuli.light.caf import (
    BillboardShading,
    absorption_factors,
    field_absorption_factors,
    instance_vertex_colours,
    vertex_colours,
)
from cumuli.model import seedbox_presets as presets
from cumuli.model.atlas import SpriteAtlas
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BillboardCloud, cloud_variants, seed_box_cloud
from cumuli.rendering.billboards import billboard_frame, cloud_spheres
from cumuli.rendering.compositor import plan

W, H = 48, 36
SUN = cu.Sun(direction=(0.4, 0.8, 0.3), intensity=1.5)
CAMERA = cu.Camera(position=(0.0, 12.0, -45.0), target=(0.0, 10.0, 0.0), fov=40)
EXACT = BillboardShading(exact_textures=True)
BACKENDS = ["cpu", pytest.param("gl", marks=pytest.mark.gl)]


def flat_atlas(rgb: float = 0.8, alpha: float = 0.5) -> SpriteAtlas:
    img = np.zeros((8, 8, 4), np.float32)
    img[..., :3], img[..., 3] = rgb, alpha
    return SpriteAtlas.from_image(img, (1, 1))


def one_billboard(centre, size=(2.0, 1.0), box_half=(1.0, 1.0, 1.0), rotation=0.0,
                  opacity=0.8, atlas=None) -> BillboardCloud:  # fmt: skip
    c = np.array(centre, np.float32)
    h = np.array(box_half, np.float32)
    return BillboardCloud(
        boxes=[[c - h, c + h]], box_level=[0], box_seed=[0], box_direction=[0], centres=[c],
        sizes=[size], texture=[0], box=[0], rotation=[rotation], opacity=opacity,
        atlas=atlas or flat_atlas(),
    )  # fmt: skip


@pytest.fixture(scope="module")
def cumulus() -> BillboardCloud:
    return seed_box_cloud(presets.cumulus(), seed=3).translated((0.0, 10.0, 0.0))


@pytest.fixture(scope="module")
def field() -> BillboardField:
    vs = [v.translated(-v.centre.astype(float)) for v in cloud_variants(presets.rain(), 3, 5)]
    offsets = [(-22.0, 14.0, 30.0), (18.0, 8.0, 15.0), (4.0, 18.0, 60.0), (-8.0, 4.0, -10.0)]
    return BillboardField(vs, offsets, variant=[0, 1, 2, 1], yaw=[0.0, 90.0, 33.0, 200.0],
                          alpha=[1.0, 0.6, 1.0, 0.3])  # fmt: skip


def render(scene: cu.Scene, backend: str, camera: cu.Camera = CAMERA, w: int = W, h: int = H):
    return cu.render(scene, camera, w, h, backend=backend)


# --- one billboard, alpha, order -------------------------------------------------------------
@pytest.mark.parametrize("backend", BACKENDS)
def test_one_billboard_is_the_analytic_rectangle_and_colour(backend: str) -> None:
    # A flat atlas and d_min = d_max: every pixel of the quad is colour·0.8·a + (1 − a)·sky with
    # a = 0.5·opacity; the quad is w·(H/2)/(Z·th) pixels wide.
    eye = cu.Camera((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), fov=60.0)
    cloud = one_billboard((0.0, 0.0, 10.0), size=(4.0, 2.0), box_half=(1.0, 2.0, 1.0))
    sh = replace(EXACT, d_min=0.7, d_max=0.7, max_distance=8.0)
    scene = cu.Scene(
        [cloud], sun=SUN, billboard_shading=sh, settings=cu.RenderSettings(lighting="paper")
    )
    img = cu.render(scene, eye, 65, 65, backend=backend).astype(np.float64)
    light = absorption_factors(cloud, SUN, max_distance=8.0)
    caf = float(light.caf[0])
    assert 0 < caf < 1
    colour = 0.5 * np.array(sh.ambient_colour(scene.sky)) + caf * 0.7 * np.array(SUN.radiance)
    a = 0.5 * 0.8
    sky = cu.Sky().colour(eye.ray_directions(65, 65), SUN)
    expect = colour * 0.8 * a + (1 - a) * sky[32, 32]
    np.testing.assert_allclose(img[32, 32, :3], expect, rtol=1e-5)
    assert img[32, 32, 3] == pytest.approx(a, rel=1e-6)
    th = math.tan(math.radians(30.0))
    width_px = 4.0 * (65 / 2) / (10.0 * th)
    height_px = 2.0 * (65 / 2) / (10.0 * th)
    covered = img[..., 3] > 0
    assert abs(covered[32].sum() - width_px) <= 1.0
    assert abs(covered[:, 32].sum() - height_px) <= 1.0
    assert not covered[0].any() and not covered[:, 0].any()


@pytest.mark.parametrize("backend", BACKENDS)
def test_alpha_is_one_minus_the_product_over_covering_billboards(backend: str) -> None:
    eye = cu.Camera((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), fov=60.0)
    clouds = [one_billboard((0.1 * k, 0.0, 10.0 + 2 * k), opacity=o)
              for k, o in enumerate((0.8, 0.5, 1.0))]  # fmt: skip
    scene = cu.Scene(
        clouds, sun=SUN, billboard_shading=EXACT, settings=cu.RenderSettings(lighting="paper")
    )
    img = cu.render(scene, eye, 33, 33, backend=backend)
    expect = 1 - (1 - 0.5 * 0.8) * (1 - 0.5 * 0.5) * (1 - 0.5 * 1.0)
    assert img[16, 16, 3] == pytest.approx(expect, rel=1e-6)


def test_order_back_to_front_whatever_the_scene_order() -> None:
    # Two overlapping billboards of different colours: reversing the drawing order changes the
    # image; the sorted pass gives the same image for either scene order.
    eye = cu.Camera((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), fov=60.0)
    near = one_billboard((0.0, 0.0, 8.0), atlas=flat_atlas(0.9, 0.7))
    far = one_billboard((0.3, 0.0, 12.0), size=(3.0, 2.0), atlas=flat_atlas(0.2, 0.7))
    sh = replace(EXACT, ambient=(0.2, 0.2, 0.25))  # not the sky's: the black sky below keeps it
    a = cu.Scene(
        [near, far], sun=SUN, billboard_shading=sh, settings=cu.RenderSettings(lighting="paper")
    )
    b = a.replace(clouds=[far, near])
    img_a, img_b = cu.render(a, eye, 33, 33, "cpu"), cu.render(b, eye, 33, 33, "cpu")
    np.testing.assert_array_equal(img_a, img_b)
    lit = cu.prepare_light(a)
    frame = billboard_frame(lit, [0, 1], eye, 33, 33)
    assert list(frame.cloud) == [1, 0]  # the far cloud first
    s = frame.sprites
    kw = {"atlas": frame.atlas, "atlas_grid": frame.grid}
    ordered = draw_sprites_cpu(s, eye, 33, 33, **kw)
    rev = type(s)(s.centres[::-1], s.half_sizes[::-1], s.colours[::-1], s.alpha[::-1],
                  s.rotation[::-1], s.texture[::-1])  # fmt: skip
    wrong = draw_sprites_cpu(rev, eye, 33, 33, **kw)
    assert np.abs(wrong - ordered).max() > 0.05
    img_layer = cu.render(a.replace(sky=cu.Sky((0, 0, 0), (0, 0, 0), (0, 0, 0), 0.5, 0.6, 0.0)),
                          eye, 33, 33, "cpu")  # fmt: skip
    np.testing.assert_allclose(img_layer, ordered, atol=1e-6)


def test_global_sort_interleaves_interpenetrating_clouds(cumulus: BillboardCloud) -> None:
    other = cumulus.translated((3.0, 0.5, 2.0))
    scene = cu.Scene(
        [cumulus, other],
        sun=SUN,
        billboard_shading=EXACT,
        settings=cu.RenderSettings(lighting="paper"),
    )
    per_cloud = render(scene, "cpu")
    glob = render(scene.replace(billboard_shading=replace(EXACT, global_sort=True)), "cpu")
    assert np.abs(per_cloud - glob).max() > 1e-3
    lit = cu.prepare_light(scene.replace(billboard_shading=replace(EXACT, global_sort=True)))
    frame = billboard_frame(lit, [0, 1], CAMERA, W, H)
    d = np.linalg.norm(frame.sprites.centres - np.array(CAMERA.position, np.float32), axis=1)
    assert (np.diff(d) <= 0).all() and set(frame.cloud) == {0, 1}
    assert (np.diff(frame.cloud) != 0).sum() > 2  # the clouds' billboards interleave


# --- parity --------------------------------------------------------------------------------------
def busy_scene(cumulus: BillboardCloud, field: BillboardField, **shading) -> cu.Scene:
    sh = replace(EXACT, height_levels=((0.0, 0.6), (0.5, 1.0), (1.0, 1.2)), **shading)
    return cu.Scene(
        [cumulus, field], sun=SUN, lights=(cu.Sun((-0.3, 0.2, -0.9), (1.0, 0.6, 0.4), 0.4),),
        billboard_shading=sh,
    settings=cu.RenderSettings(lighting="paper"))  # fmt: skip


@pytest.mark.gl
@pytest.mark.parametrize("mode", ["vertex", "fragment"])
def test_gl_and_cpu_agree_in_exact_mode(cumulus, field, mode: str) -> None:
    scene = cu.prepare_light(busy_scene(cumulus, field, shading=mode))
    gl, cpu = render(scene, "gl", w=96, h=72), render(scene, "cpu", w=96, h=72)
    diff = np.abs(gl.astype(np.float64) - cpu)
    assert (cpu[..., 3] > 0.05).mean() > 0.1  # a real picture
    assert diff.mean(axis=(0, 1)).max() <= 1e-5 and diff.max() <= 1e-4


@pytest.mark.gl
def test_gl_fast_mode_is_close_to_the_cpu(cumulus) -> None:
    # Hardware filtering over mipmaps (the default): billboards about 40 pixels across for 64
    # texels. Mipmaps blur minified sprites, which the exact CPU sampling does not: smaller
    # sprites differ more (RENDER_CONTRACT "Billboards" gives the measured means).
    cam = cu.Camera(position=(0.0, 11.0, -25.0), target=(0.0, 10.0, 0.0), fov=40)
    scene = cu.Scene([cumulus], sun=SUN, settings=cu.RenderSettings(lighting="paper"))
    assert not scene.billboard_shading.exact_textures
    gl, cpu = render(scene, "gl", cam, 320, 240), render(scene, "cpu", cam, 320, 240)
    assert (cpu[..., 3] > 0.05).mean() > 0.1
    diff = np.abs(gl.astype(np.float64) - cpu).mean(axis=(0, 1))
    assert diff.max() <= 2e-3 and diff.max() > 0  # close, and not the exact path


@pytest.mark.parametrize("backend", BACKENDS)
def test_culling_and_far_away_billboards_change_nothing(cumulus, backend: str) -> None:
    behind = cumulus.translated((0.0, 0.0, -90.0))  # behind the camera
    aside = cumulus.translated((400.0, 0.0, 0.0))  # outside the view
    base = cu.Scene(
        [cumulus], sun=SUN, billboard_shading=EXACT, settings=cu.RenderSettings(lighting="paper")
    )
    ref = render(base, backend)
    np.testing.assert_array_equal(render(base.replace(clouds=[cumulus, behind, aside]), backend),
                                  ref)  # fmt: skip
    no_cull = base.replace(billboard_shading=replace(EXACT, cull=False))
    np.testing.assert_array_equal(render(no_cull, backend), ref)


def test_cpu_render_does_not_depend_on_threads(cumulus, field) -> None:
    scene = busy_scene(cumulus, field, shading="fragment")
    a = cu.render_cpu(scene, CAMERA, W, H, threads=1)
    np.testing.assert_array_equal(a, cu.render_cpu(scene, CAMERA, W, H, threads=0))


# --- shading -----------------------------------------------------------------------------------
def test_vertex_colours_are_the_phase_one_shading(cumulus, field) -> None:
    scene = busy_scene(cumulus, field)
    lit = cu.prepare_light(scene)
    frame = billboard_frame(lit, [0, 1], CAMERA, W, H)
    _, r, u = CAMERA.basis()
    light = absorption_factors(cumulus, SUN, max_distance=None)
    extra = [(scene.lights[0], absorption_factors(cumulus, scene.lights[0]))]
    ref = vertex_colours(cumulus, SUN, light, r, u, scene.billboard_shading, scene.sky, extra)
    mine = frame.cloud == 0
    np.testing.assert_array_equal(frame.sprites.colours[mine], ref[frame.billboard[mine]])
    # A field instance: instance_vertex_colours of the sun alone (one-light scene).
    one = cu.Scene(
        [field], sun=SUN, billboard_shading=EXACT, settings=cu.RenderSettings(lighting="paper")
    )
    frame = billboard_frame(cu.prepare_light(one), [0], CAMERA, W, H)
    fl = field_absorption_factors(field, SUN)
    for i in range(field.n):
        sel = frame.cloud == i
        if not sel.any():
            continue
        ref = instance_vertex_colours(field, i, SUN, fl, r, u, EXACT, one.sky)
        np.testing.assert_allclose(frame.sprites.colours[sel], ref[frame.billboard[sel]],
                                   rtol=2e-6, atol=1e-7)  # fmt: skip


def test_fragment_shading_matches_the_corners_and_lights_the_tops(cumulus) -> None:
    # At the quad corners fragment shading equals the vertex colours; across the cloud tops
    # facing the sun are brighter than bases (directional term and CAF).
    vert = cu.Scene(
        [cumulus], sun=SUN, billboard_shading=EXACT, settings=cu.RenderSettings(lighting="paper")
    )
    frag = vert.replace(billboard_shading=replace(EXACT, shading="fragment"))
    a, b = render(vert, "cpu", w=160, h=120), render(frag, "cpu", w=160, h=120)
    cloud = (a[..., 3] > 0.5) & (b[..., 3] > 0.5)
    assert np.abs(a - b)[cloud].mean() < 0.02
    rows = np.nonzero(cloud.any(axis=1))[0]
    top, bottom = rows[: len(rows) // 4], rows[-len(rows) // 4 :]
    lum = b[..., :3].mean(axis=2)
    assert lum[top][cloud[top]].mean() > lum[bottom][cloud[bottom]].mean() + 0.05


def test_fades_and_instance_alpha(field) -> None:
    scene = cu.Scene(
        [field], sun=SUN, billboard_shading=EXACT, settings=cu.RenderSettings(lighting="paper")
    )
    frame = billboard_frame(cu.prepare_light(scene), [0], CAMERA, W, H)
    opacity = np.array([v.opacity for v in field.variants])[field.variant]
    np.testing.assert_allclose(frame.sprites.alpha, (opacity * field.alpha)[frame.cloud], rtol=1e-6)
    z0, z1, rng = 40.0, 70.0, 100.0
    faded = scene.replace(billboard_shading=replace(EXACT, fade_near=(z0, z1), fade_far=rng))
    f2 = billboard_frame(cu.prepare_light(faded), [0], CAMERA, W, H)
    f, _, _ = CAMERA.basis()
    z = (f2.sprites.centres - np.array(CAMERA.position, np.float32)) @ f

    def smooth(e0, e1, x):
        t = np.clip((x - e0) / (e1 - e0), 0, 1)
        return t * t * (3 - 2 * t)

    expect = (opacity * field.alpha)[f2.cloud] * smooth(z0, z1, z) * (1 - smooth(0.9 * rng, rng, z))
    assert 0 < len(f2.sprites) < len(frame.sprites)  # faded-out billboards are dropped
    np.testing.assert_allclose(f2.sprites.alpha, expect, rtol=1e-4, atol=1e-6)  # float32 Z
    # The impostor hook: excluded clouds are not drawn; cloud_spheres holds each cloud's quads.
    centres, radii = cloud_spheres(cu.prepare_light(scene), [0])
    for i in range(field.n):
        lo, hi = field.instance_bounds()[i]
        assert np.all(np.abs(np.clip(centres[i], lo, hi) - centres[i]) < 1e-4)
        assert radii[i] >= 0.5 * np.linalg.norm(hi - lo) * 0.5
    excl = billboard_frame(cu.prepare_light(scene), [0], CAMERA, W, H,
                           exclude=np.array([True, False, False, True]))  # fmt: skip
    assert set(excl.cloud) == set(frame.cloud) - {0, 3}


# --- the pass, the light step, scene files ----------------------------------------------------
@pytest.mark.gl
def test_billboards_only_scene_is_one_pass(cumulus, field) -> None:
    scene = busy_scene(cumulus, field)
    assert plan(scene) == [("billboards", [0, 1])]
    lit = cu.prepare_light(scene)
    with cu.Renderer() as r:
        direct = r.drawer("billboards").draw(lit, [0, 1], CAMERA, W, H, True)
        np.testing.assert_array_equal(r.render(lit, CAMERA, W, H), direct)


def test_light_pass_memo_tolerance_and_given_light(cumulus) -> None:
    from cumuli.light.billboards import BillboardLighting, clear_memo

    clear_memo()
    scene = cu.Scene([cumulus], sun=SUN, settings=cu.RenderSettings(lighting="paper"))
    first = cu.prepare_light(scene).lights[0]
    assert isinstance(first, BillboardLighting) and first.records[0].sun == SUN.direction
    assert cu.prepare_light(scene).lights[0].records is first.records  # memoised
    turn = math.radians(0.5)  # within the default 1° relight tolerance: the CAF is reused
    d = np.array(SUN.direction)
    axis = np.cross(d, (0.0, 1.0, 0.0))
    axis /= np.linalg.norm(axis)
    small = d * math.cos(turn) + np.cross(axis, d) * math.sin(turn)
    moved = scene.replace(sun=cu.Sun(tuple(small), intensity=SUN.intensity))
    again = cu.prepare_light(moved).lights[0]
    assert again.records is first.records and again.lights[0] == moved.sun
    far = scene.replace(sun=cu.Sun((0.0, 1.0, 0.0)))
    assert cu.prepare_light(far).lights[0].records is not first.records
    # Given light: used while current, refused when stale; nothing is stored on the cloud.
    assert cu.prepare_light(scene, lights=[first]).lights[0].records is first.records
    with pytest.raises(ValueError, match="relight_tolerance"):
        cu.prepare_light(far, lights=[first])
    with pytest.raises(TypeError, match="BillboardLighting"):
        cu.prepare_light(scene, lights=[np.zeros(3)])
    assert not hasattr(cumulus, "caf")
    # Extra lights each get their CAF record and add light.
    lit2 = cu.prepare_light(scene.replace(lights=(cu.Sun((0, 1, 0), intensity=0.5),)))
    assert len(lit2.lights[0].records) == 2
    a = render(scene.replace(billboard_shading=EXACT), "cpu")
    b = render(lit2.scene.replace(billboard_shading=EXACT), "cpu")
    cloud = a[..., 3] > 0.3
    assert (b[..., :3] - a[..., :3])[cloud].min() >= -1e-6 and (b - a)[cloud].max() > 0.01


def test_scene_file_round_trip_with_billboards(tmp_path, cumulus, field) -> None:
    scene = busy_scene(cumulus, field, shading="fragment", fade_near=(1.0, 5.0)).replace(
        camera=CAMERA
    )
    back = cu.load_scene(scene.save(tmp_path / "sky.json"))
    assert back.kinds == ("billboards", "billboard_field")
    assert back.billboard_shading == scene.billboard_shading
    np.testing.assert_array_equal(back.clouds[0].centres, cumulus.centres)
    np.testing.assert_array_equal(back.clouds[1].offsets, field.offsets)
    np.testing.assert_array_equal(render(back, "cpu"), render(scene, "cpu"))
    data = scene.to_dict()
    data["clouds"][1]["offsets"] = "nope"
    with pytest.raises(ValueError, match=r"scene.clouds\[1\]"):
        cu.Scene.from_dict(data)
    data = scene.to_dict()
    data["billboard_shading"]["fade_near"] = [5.0, 1.0]
    with pytest.raises(ValueError, match="billboard_shading"):
        cu.Scene.from_dict(data)


def test_bad_input(cumulus) -> None:
    with pytest.raises(ValueError, match="fade_near"):
        BillboardShading(fade_near=(3.0, 2.0))
    with pytest.raises(ValueError, match="fade_far"):
        BillboardShading(fade_far=-1.0)
    with pytest.raises(ValueError, match="sort"):
        BillboardShading(sort="random")
    with pytest.raises(TypeError, match="global_sort"):
        BillboardShading(global_sort="yes")
    with pytest.raises(ValueError, match="near"):
        BillboardShading(near=0.0)
    scene = cu.Scene([cumulus], sun=SUN, settings=cu.RenderSettings(lighting="paper"))
    lit = cu.prepare_light(scene)
    with pytest.raises(ValueError, match="exclude"):
        billboard_frame(lit, [0], CAMERA, W, H, exclude=np.array([True, False]))
    with pytest.raises(ValueError, match="exclude"):
        billboard_frame(lit, [0], CAMERA, W, H, exclude=[1, 0])
    with pytest.raises(TypeError, match="BillboardShading"):
        cu.Scene(
            [cumulus],
            billboard_shading={"d_min": 0.1},
            settings=cu.RenderSettings(lighting="paper"),
        )


@pytest.mark.gl
def test_another_context_made_meanwhile_does_not_break_cached_textures(cumulus) -> None:
    # moderngl sends calls to the current context, the last one created: the shared renderer's
    # cached atlas texture must still be its own after another renderer came and went.
    scene = cu.Scene(
        [cumulus], sun=SUN, billboard_shading=EXACT, settings=cu.RenderSettings(lighting="paper")
    )
    cpu = render(scene, "cpu")
    np.testing.assert_allclose(render(scene, "gl"), cpu, atol=1e-4)
    with cu.Renderer() as other:
        np.testing.assert_allclose(other.render(scene, CAMERA, W, H), cpu, atol=1e-4)
    np.testing.assert_allclose(render(scene, "gl"), cpu, atol=1e-4)
    with cu.Renderer():
        pass  # made and closed without drawing: it was left current
    np.testing.assert_allclose(render(scene, "gl"), cpu, atol=1e-4)


def test_drifting_field_keeps_its_light_unless_clouds_shadow_each_other(field) -> None:
    # Instances are traced in their own frames: moving them (wind) keeps the memoised CAF; with
    # shadow_between_clouds the offsets matter and the light is recomputed.
    moved = BillboardField(list(field.variants), field.offsets + np.float32(5.0),
                           variant=field.variant, yaw=field.yaw)  # fmt: skip
    for between in (False, True):
        sh = BillboardShading(shadow_between_clouds=between, max_distance=30.0)
        a = cu.prepare_light(
            cu.Scene(
                [field], sun=SUN, billboard_shading=sh, settings=cu.RenderSettings(lighting="paper")
            )
        ).lights[0]
        b = cu.prepare_light(
            cu.Scene(
                [moved], sun=SUN, billboard_shading=sh, settings=cu.RenderSettings(lighting="paper")
            )
        ).lights[0]
        assert (a.records is b.records) == (not between)
        ref = field_absorption_factors(moved, SUN, max_distance=30.0,
                                       shadow_between_clouds=between)  # fmt: skip
        np.testing.assert_array_equal(b.records[0].caf, ref.caf)


@pytest.mark.parametrize("backend", BACKENDS)
def test_clouds_with_different_atlases_share_one_pass(cumulus, backend: str) -> None:
    # A user atlas of 8×8 cells beside the generated 64×64 one: one combined texture (the flat
    # cell resampled stays flat), each cloud drawn as it is alone where they do not overlap.
    flat = one_billboard((0.0, 14.0, -20.0), size=(3.0, 3.0), atlas=flat_atlas(0.9, 0.6))
    both = cu.Scene(
        [cumulus, flat],
        sun=SUN,
        billboard_shading=EXACT,
        settings=cu.RenderSettings(lighting="paper"),
    )
    assert plan(both) == [("billboards", [0, 1])]
    img = render(both, backend, w=96, h=72)
    alone = render(both.replace(clouds=[flat]), backend, w=96, h=72)
    other = render(both.replace(clouds=[cumulus]), backend, w=96, h=72)
    only_flat = (alone[..., 3] > 0) & (other[..., 3] == 0)
    assert only_flat.sum() > 20
    np.testing.assert_allclose(img[only_flat], alone[only_flat], atol=1e-5)
    if backend == "gl":
        np.testing.assert_allclose(img, render(both, "cpu", w=96, h=72), atol=1e-4)


def test_combined_atlas_layout_and_limit(monkeypatch) -> None:
    from cumuli.rendering import billboards as bb

    a, b = cu.sprite_atlas("sunny", n=5, size=16), flat_atlas(0.3, 0.5)
    image, grid, bases = bb.combined_atlas((a, b))
    assert grid == (3, 2) and bases == (0, 5) and image.shape == (32, 48, 4)
    np.testing.assert_array_equal(image[:16, 16:32], a.sprite(1))
    np.testing.assert_allclose(image[16:32, 32:48], 0.3 * np.ones((16, 16, 4)) * [1, 1, 1, 0]
                               + [0, 0, 0, 0.5], atol=1e-7)  # fmt: skip
    assert not image.flags.writeable
    monkeypatch.setattr(bb, "MAX_ATLAS_EDGE", 40)
    with pytest.raises(ValueError, match="do not fit"):
        bb.combined_atlas((a, flat_atlas(0.4, 0.5)))


def test_fragment_shading_bad_input() -> None:
    from cumuli.gl.sprite_shading import FragmentShading
    from cumuli.gl.sprites import Sprites

    params = {"d_min": 0.2, "d_max": 1.0, "k_dir": 1.0, "directional": "linear",
              "ambient": (0.1, 0.1, 0.1), "k_amb": 0.5, "height_levels": []}  # fmt: skip
    ok = {"frame": np.zeros((2, 4)), "yrange": np.zeros((2, 2)), "caf": np.ones((2, 1)),
          "light_dirs": [(0, 1, 0)], "light_radiance": [(1, 1, 1)], "params": params}  # fmt: skip
    shading = FragmentShading(**ok)
    with pytest.raises(ValueError, match="caf"):
        FragmentShading(**{**ok, "caf": np.ones((2, 2))})
    with pytest.raises(ValueError, match="yrange"):
        FragmentShading(**{**ok, "yrange": np.zeros((3, 2))})
    with pytest.raises(ValueError, match="light_dirs"):
        FragmentShading(
            **{**ok, "light_dirs": np.zeros((18, 3)), "light_radiance": np.zeros((18, 3))}
        )
    with pytest.raises(ValueError, match="directional"):
        FragmentShading(**{**ok, "params": {**params, "directional": "cubic"}})
    with pytest.raises(ValueError, match="missing"):
        FragmentShading(**{**ok, "params": {"d_min": 0.1}})
    three = Sprites(np.zeros((3, 3)) + [0, 0, 5], np.ones(3), np.ones((3, 3)), np.ones(3))
    eye = cu.Camera((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="rows"):
        draw_sprites_cpu(three, eye, 8, 8, shading=shading)
    with pytest.raises(TypeError, match="FragmentShading"):
        draw_sprites_cpu(three, eye, 8, 8, shading={"frame": 1})


@pytest.mark.parametrize("backend", BACKENDS)
def test_too_many_billboards_are_refused_before_drawing(cumulus, monkeypatch, backend) -> None:
    from cumuli.rendering import billboards as bb

    monkeypatch.setattr(bb, "MAX_SPRITES", cumulus.n_billboards - 1)
    with pytest.raises(ValueError, match="billboards"):
        render(cu.Scene([cumulus], sun=SUN, settings=cu.RenderSettings(lighting="paper")), backend)
