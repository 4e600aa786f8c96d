"""Impostors of billboard clouds and of every billboard-field instance (Harris 2002 §3 applied to
Torchelsen & Musse 2005): display at the generation
viewpoint against direct rendering, exact GL/CPU parity, one impostor per field instance kept
by its id, the update criteria, wind (a pure translation) keeping the impostors, relighting and
content changes invalidating them, the parts protocol, and a filmed weather through impostors."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.io.images import srgb_to_linear
from cumuli.model.parts import DrawableParts
from cumuli.rendering.impostors import (
    impostor_resolution,
    required_resolution,
    translation_error,
)
from cumuli.testing import assert_image_close, only

W, H = 96, 72
SUN = cu.Sun(direction=(0.4, 0.8, -0.3), intensity=2.0)
CAMERA = cu.Camera((10.0, 8.0, -60.0), (0.0, 2.0, 10.0), fov=40)
MODEL = cu.seedbox_presets.cumulus()
VARIANTS = [v.translated(-v.centre) for v in cu.cloud_variants(MODEL, n=3, seed=1)]
OFFSETS = np.array([(-14, 0, 10), (12, 3, 25), (0, -2, 45), (25, 5, 0)], np.float32)


def cloud() -> cu.BillboardCloud:
    return cu.seed_box_cloud(MODEL, seed=5)


def field(offsets: np.ndarray = OFFSETS, **kw: object) -> cu.BillboardField:
    kw.setdefault("yaw", [0.0, 90.0, 30.0, 200.0][: len(offsets)])
    return cu.BillboardField(VARIANTS, offsets, **kw)  # type: ignore[arg-type]


def scene(drawable: object, shading: str = "vertex", **impostor: object) -> cu.Scene:
    return cu.Scene(
        [drawable], sun=SUN, billboard_shading=cu.BillboardShading(shading=shading),
        impostor_settings=cu.ImpostorSettings(**impostor),
    settings=cu.RenderSettings(lighting="paper"))  # fmt: skip


@pytest.mark.parametrize("shading", ["vertex", "fragment"])
@pytest.mark.parametrize("make", [cloud, field], ids=["cloud", "field"])
def test_display_at_the_generation_viewpoint_is_a_resampling(make, shading: str) -> None:
    """§10.3.1 for billboards: from the eye it was made at, the impostor differs from direct
    rendering by resampling and by the billboards facing the impostor camera instead of the
    view (measured 1.2e−3 for a cloud, 3.7e−3 for a field at res = f_px·2R/d), less as the
    resolution doubles."""
    d = make()
    direct = cu.render(scene(d, shading), CAMERA, W, H, backend="cpu")
    errors = []
    for res_scale in (1.0, 2.0, 4.0):
        cache = cu.ImpostorCache()
        img = cu.render(scene(d, shading, res_scale=res_scale), CAMERA, W, H, backend="cpu",
                        impostors=cache)  # fmt: skip
        n = 1 if isinstance(d, cu.BillboardCloud) else d.n
        assert cache.history[-1]["updates"] == {"missing": n}
        errors.append(float(np.abs(img - direct).mean()))
    assert errors[0] <= 1e-2 and errors[0] > errors[1] > errors[2]
    assert direct[..., 3].mean() > 0.03  # the clouds are in the picture


def test_one_impostor_per_field_instance_keyed_by_its_id() -> None:
    f = field(ids=[7, 3, 11, 5])
    cache = cu.ImpostorCache()
    cu.render(scene(f), CAMERA, W, H, backend="cpu", impostors=cache)
    assert sorted(cache.entries) == [(0, 3), (0, 5), (0, 7), (0, 11)]
    e = cache.entries[(0, 11)]
    assert e.index == 0 and e.part == 2 and e.drawable.n == 1
    # Each instance's impostor is its own tight image, sized by the resolution rule for its own
    # bounding sphere: res = pow2ceil(f_px·2R/d).
    centres, radii = f.instance_spheres()
    for (_, key), x in cache.entries.items():
        i = f.ids.tolist().index(key)
        req = required_resolution(CAMERA, H, centres[i], radii[i])
        assert x.image.shape[:2] == (impostor_resolution(req),) * 2
    assert len({x.image.shape for x in cache.entries.values()}) > 1
    assert cache.stats["impostors"] == 4 and cache.stats["texels"] == sum(
        x.image.shape[0] * x.image.shape[1] for x in cache.entries.values()
    )


@pytest.mark.gl
@pytest.mark.parametrize("shading", ["vertex", "fragment"])
def test_exact_display_gl_and_cpu_agree(shading: str, exact_impostors_agree: Callable) -> None:
    """Exact mode (texelFetch display and atlas sampling) GL against the C++ twins ≤ 1e−5 mean,
    ≤ 1e−4 max, at the generation viewpoint and from a moved eye reusing the impostors."""
    sh = cu.BillboardShading(shading=shading, exact_textures=True)
    sc = cu.Scene([cloud().translated((-30, 0, 20)), field()], sun=SUN, billboard_shading=sh,
                  impostor_settings=cu.ImpostorSettings(exact=True, tolerance=1.0),
                  settings=cu.RenderSettings(lighting="paper"))  # fmt: skip
    moved = cu.Camera((10.4, 8.2, -59.6), (0.0, 2.0, 10.0), fov=40)
    with cu.Renderer() as r:
        gl, gl_cache, cpu_cache = exact_impostors_agree(r, sc, [CAMERA, moved], W, H)
        assert gl_cache.history[0]["updates"] == {"missing": 5}
        assert gl_cache.history[-1]["updates"] == {} == cpu_cache.history[-1]["updates"]
    assert gl[..., 3].max() > 0.9


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_wind_keeps_the_impostors(backend: str) -> None:
    """A weather step moves instances by the wind: a pure translation. Every instance keeps its
    impostor, displayed moved; with the eye moved along, the frame is the same picture."""
    sc = scene(field())
    cache = cu.ImpostorCache()
    first = cu.render(sc, CAMERA, W, H, backend=backend, impostors=cache)
    wind = np.float32([2.5, 0.0, -1.5])
    blown = sc.replace(clouds=[field(OFFSETS + wind)])
    cam = cu.Camera(tuple(np.add(CAMERA.position, wind)), tuple(np.add(CAMERA.target, wind)),
                    fov=40)  # fmt: skip
    img = cu.render(blown, cam, W, H, backend=backend, impostors=cache)
    assert cache.history[-1]["updates"] == {} and cache.history[-1]["impostors"] == 4
    np.testing.assert_allclose(img, first, atol=1e-5)
    # A billboard cloud translated as a whole keeps its impostor too (its CAF, traced again for
    # the moved boxes, may differ in the last bit); seen from the old eye, α_trans decides.
    one = cu.ImpostorCache()
    before = cu.render(scene(cloud()), CAMERA, W, H, backend=backend, impostors=one)
    moved = scene(cloud().translated(wind))
    after = cu.render(moved, cam, W, H, backend=backend, impostors=one)
    assert one.history[-1]["updates"] == {}
    np.testing.assert_allclose(after, before, atol=1e-5)
    cu.render(moved, CAMERA, W, H, backend=backend, impostors=one)
    assert one.history[-1]["updates"] == {"translation": 1}


def test_update_criteria_per_instance() -> None:
    """§7.3 per instance: a lateral step regenerates exactly the instances whose α_trans reached
    the tolerance (the nearer, the sooner); coming close raises the resolution rule; an eye
    inside an instance gets a screen impostor for it; passing an instance's middle is
    "backwards"."""
    sc = scene(field(), tolerance=0.5)
    cache = cu.ImpostorCache()
    cu.render(sc, CAMERA, W, H, backend="cpu", impostors=cache)
    for dx in (3.0, 4.0):
        made = {k: (e.version, e.state) for k, e in cache.entries.items()}
        eye = (10.0 + dx, 8.0, -60.0)
        cam = cu.Camera(eye, (dx, 2.0, 10.0), fov=40)
        cu.render(sc, cam, W, H, backend="cpu", impostors=cache)
        alpha = {k: translation_error(st.view.near_point, st.view.far_point, eye)
                 for k, (_, st) in made.items()}  # fmt: skip
        redone = {k for k, e in cache.entries.items() if e.version != made[k][0]}
        assert redone == {k for k, a in alpha.items() if a >= 0.5}
        assert 0 < len(redone) < 4
        assert cache.history[-1]["updates"] == {"translation": len(redone)}
    # Towards instance 0 along the line through its centre: no translation error, but the
    # projected size doubles.
    c0 = np.asarray(cache.entries[(0, 0)].state.centre)
    e0 = np.asarray(cache.entries[(0, 0)].state.eye)
    closer = tuple(c0 + 0.45 * (e0 - c0))
    cu.render(sc, cu.Camera(closer, tuple(c0), fov=40), W, H, backend="cpu", impostors=cache)
    assert cache.history[-1]["updates"].get("resolution", 0) >= 1
    inside = cu.Camera(tuple(c0), tuple(c0 + (0.0, 0.0, 10.0)), fov=60)
    for _ in range(2):
        cu.render(sc, inside, W, H, backend="cpu", impostors=cache)
        assert cache.history[-1]["updates"].get("screen", 0) >= 1
    assert cache.entries[(0, 0)].clamp  # the instance around the eye: a screen impostor
    # From in front of instance 2, beside it, to past its middle plane (⟂ n̂₀ through c).
    c2, r2 = field().instance_spheres()[0][2], float(field().instance_spheres()[1][2])
    wide = sc.replace(impostor_settings=cu.ImpostorSettings(tolerance=5.0, cull=False))
    front = c2 + (2 * r2, 0.0, -3 * r2)
    cu.render(wide, cu.Camera(tuple(front), tuple(c2), fov=60), W, H, backend="cpu",
              impostors=cache)  # fmt: skip
    past = c2 + (2 * r2, 0.0, 2 * r2)
    assert np.dot(past - c2, c2 - front) > 0
    made = cache.entries[(0, 2)].version
    cu.render(wide, cu.Camera(tuple(past), tuple(past + (0.0, 0.0, 40.0)), fov=60), W, H,
              backend="cpu", impostors=cache)  # fmt: skip
    assert cache.history[-1]["updates"].get("backwards", 0) >= 1
    assert cache.entries[(0, 2)].version > made


def test_relighting_and_content_changes_invalidate() -> None:
    """Never reused after the light changed (sun direction or colour, extra lights, the sky's
    ambient, the shading settings): every instance regenerates, and the result matches direct
    rendering; a changed instance (yaw, fade alpha, variant) regenerates alone; a new instance
    id is "missing", a gone one is dropped."""
    base = scene(field())
    cache = cu.ImpostorCache()
    cu.render(base, CAMERA, W, H, backend="cpu", impostors=cache)
    changes = [
        base.replace(sun=cu.Sun((0.0, 1.0, 0.0), intensity=2.0)),
        base.replace(sun=cu.Sun((0.0, 1.0, 0.0), colour=(1.0, 0.6, 0.4), intensity=2.0)),
        base.replace(lights=(cu.Sun((-0.5, 0.5, 0.2), intensity=0.5),)),
        base.replace(sky=cu.Sky(zenith=(0.1, 0.2, 0.5))),
        base.replace(billboard_shading=cu.BillboardShading(k_amb=0.8)),
    ]
    for changed in changes:
        img = cu.render(changed, CAMERA, W, H, backend="cpu", impostors=cache)
        assert cache.history[-1]["updates"] == {"light": 4}
        direct = cu.render(changed, CAMERA, W, H, backend="cpu")
        assert_image_close(img, direct, **only(mean_abs=1e-2))
    last = changes[-1]
    cu.render(last, CAMERA, W, H, backend="cpu", impostors=cache)
    assert cache.history[-1]["updates"] == {}
    for kw in ({"yaw": [0.0, 91.0, 30.0, 200.0]}, {"alpha": [1.0, 0.5, 1.0, 1.0]},
               {"variant": [0, 2, 2, 0]}):  # fmt: skip
        cu.render(last.replace(clouds=[field(**kw)]), CAMERA, W, H, backend="cpu",
                  impostors=cache)  # fmt: skip
        assert cache.history[-1]["updates"] == {"cloud": 1}
        cu.render(last, CAMERA, W, H, backend="cpu", impostors=cache)  # back as it was
    spawned = field(np.concatenate([OFFSETS[1:], [[-30, 2, 30]]]), ids=[1, 2, 3, 9],
                    yaw=[90.0, 30.0, 200.0, 10.0], variant=[1, 2, 0, 2])  # fmt: skip
    cu.render(last.replace(clouds=[spawned]), CAMERA, W, H, backend="cpu", impostors=cache)
    assert cache.history[-1]["updates"] == {"missing": 1}
    assert sorted(cache.entries) == [(0, 1), (0, 2), (0, 3), (0, 9)]


def test_the_parts_protocol() -> None:
    f = field(ids=[4, 1, 2, 3], alpha=[1.0, 0.7, 1.0, 0.2])
    parts = f.impostor_parts()
    assert isinstance(parts, DrawableParts) and len(parts) == 4
    np.testing.assert_array_equal(parts.keys, [4, 1, 2, 3])
    centres, radii = f.instance_spheres()
    np.testing.assert_array_equal(parts.centres, centres)
    # Every billboard corner of an instance lies in its sphere, at any view orientation.
    for i in range(f.n):
        w = f.world_billboards(i)
        reach = np.linalg.norm(w["centres"] - centres[i], axis=1) + 0.5 * np.hypot(
            w["sizes"][:, 0], w["sizes"][:, 1]
        )
        assert reach.max() <= radii[i] + 1e-4
    # Equal signatures for equal content up to translation, the yaw and the alpha count.
    g = field(OFFSETS + 5.0, ids=[4, 1, 2, 3], alpha=[1.0, 0.7, 1.0, 0.2])
    assert g.impostor_parts().signatures == parts.signatures
    assert field(alpha=[1.0, 0.6, 1.0, 0.2]).impostor_parts().signatures[1] != parts.signatures[1]
    # A part alone draws what the instance draws in the field.
    lit = cu.prepare_light(scene(f))
    part = f.part(1)
    assert part.n == 1 and part.ids.tolist() == [1] and part.variants == f.variants
    assert part.variant.tolist() == [1]
    sub = cu.prepare_light(scene(part))
    np.testing.assert_array_equal(lit.lights[0].part(1).caf, sub.lights[0].caf)
    alone = cu.render(lit.scene.replace(clouds=[part]), CAMERA, W, H, backend="cpu")
    only = cu.render(scene(field(ids=[4, 1, 2, 3], alpha=[0.0, 0.7, 0.0, 0.0])), CAMERA, W, H,
                     backend="cpu")  # fmt: skip
    np.testing.assert_allclose(alone, only, atol=1e-6)
    # ids round-trip through scene files; the default is 0..n−1.
    back = cu.BillboardField.from_dict(f.to_dict())
    np.testing.assert_array_equal(back.ids, f.ids)
    np.testing.assert_array_equal(field().ids, np.arange(4))


def test_bad_parts_and_ids() -> None:
    with pytest.raises(ValueError, match="ids"):
        field(ids=[1, 1, 2, 3])
    with pytest.raises(ValueError, match="ids"):
        field(ids=[-1, 0, 1, 2])
    with pytest.raises(ValueError, match="ids"):
        field(ids=[0.5, 1, 2, 3])
    with pytest.raises(ValueError, match="ids"):
        field(ids=[0, 1, 2])
    with pytest.raises(ValueError, match="ids"):
        field(ids=np.array([0, 1, 2, 2**63], dtype=np.uint64))
    with pytest.raises(ValueError, match="keys"):
        DrawableParts([1, 1], np.zeros((2, 3)), [1, 1], np.zeros((2, 3)), np.zeros((2, 3)),
                      ("a", "b"))  # fmt: skip
    with pytest.raises(ValueError, match="centres"):
        DrawableParts([1, 2], np.zeros((3, 3)), [1, 1], np.zeros((2, 3)), np.zeros((2, 3)),
                      ("a", "b"))  # fmt: skip
    with pytest.raises(ValueError, match="index"):
        field().part(4)
    with pytest.raises(TypeError, match="BillboardField"):
        cu.prepare_light(scene(cloud())).lights[0].part(0)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_render_frames_of_a_weather_with_impostors(tmp_path: Path, backend: str) -> None:
    """`render_frames(weather, ..., impostors=True)`: a weather step moves the instances by the
    wind (a pure translation), so under a steady light the instances keep their impostors
    from frame to frame; new clouds are "missing", and each frame matches the direct one."""
    layer = cu.CloudLayer(40.0, 6.0, (3.0, 0.0), (cu.SkyState(0.0, (MODEL,), variants=3,
                                                              count=8),))  # fmt: skip
    make = lambda: cu.Weather(((-60.0, -60.0), (60.0, 60.0)), [layer], seed=3)  # noqa: E731
    cam = cu.Camera((0.0, 5.0, -120.0), (0.0, 40.0, 0.0), fov=55)
    cache = cu.ImpostorCache()
    paths = cu.render_frames(make(), cam, tmp_path / "imp", 48, 36, frames=4, dt=0.5,
                             backend=backend, progress=False, impostors=cache)  # fmt: skip
    assert len(paths) == 4 and all(p.is_file() for p in paths)
    first, later = cache.history[0], cache.history[1:]
    assert first["updates"] == {"missing": first["impostors"]} and first["impostors"] > 0
    assert all(set(h["updates"]) <= {"missing", "translation"} for h in later)
    assert sum(sum(h["updates"].values()) for h in later) < sum(h["impostors"] for h in later)
    w = make()
    for k in range(4):
        if k:
            w.step(0.5)
        direct = cu.render(w.scene_at(), cam, 48, 36, backend=backend)
    shown = cu.read_image(paths[-1])  # sRGB8 through the display defaults: quantised
    expected = srgb_to_linear(cu.to_srgb8(direct)[..., :3] / 255.0)
    assert np.abs(shown[..., :3] - expected).mean() <= 2e-2
    assert cu.render_frames(make(), cam, tmp_path / "b", 16, 12, frames=2, dt=0.5,
                            backend=backend, progress=False, impostors=True)  # fmt: skip
