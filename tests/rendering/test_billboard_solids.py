"""Billboard clouds around opaque solids (Harris 2002 §3.1.1, Fig. 7, applied to Torchelsen &
Musse 2005's billboards): direct rendering depth-tests
every billboard against the solids (hard cuts, Fig. 7 left), `draw_split` / its CPU twin cut a
cloud's sorted billboards into m + 1 layers at the solids' sort keys, and impostors split a
billboard cloud — or only the field instance a solid is in — around it (Fig. 7 right)."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.rendering.billboards import sort_key
from cumuli.rendering.painters import CPUPainter, GLPainter
from cumuli.rendering.solids import composite_split, draw_solids_cpu
from cumuli.testing import assert_image_close, only

W, H = 64, 48
SUN = cu.Sun(direction=(0.4, 0.8, -0.3), intensity=2.0)
BLACK = cu.Sky(zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0), sun_disc_intensity=0)
CAMERA = cu.Camera(position=(4.0, 6.0, -45.0), target=(0.0, 4.0, 0.0), fov=40)
MODEL = cu.seedbox_presets.cumulus()
CLOUD = cu.seed_box_cloud(MODEL, seed=5)  # boxes centred near (0, 4, 0), R ≈ 12
PLANE = cu.Solid((0.0, 4.0, 0.0), 2.5, (0.8, 0.8, 0.85), (0.1, 0.1, 0.12))


def scene(*clouds: object, solids: tuple[cu.Solid, ...] = (PLANE,), **kw: object) -> cu.Scene:
    return cu.Scene(list(clouds) or [CLOUD], sun=SUN, solids=solids, **kw)  # type: ignore[arg-type]


def painter_for(backend: str, renderer: object) -> object:
    return CPUPainter() if backend == "cpu" else GLPainter(renderer)


class _none:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_direct_billboards_are_depth_tested_against_solids(backend: str) -> None:
    """A billboard covers a pixel only where its view depth is smaller than the solid's: a
    solid behind the cloud leaves its layer as it is, one in front of it blanks the layer where
    it covers; one inside hides the billboards behind it only."""
    with cu.Renderer() if backend == "gl" else _none() as r:
        p = painter_for(backend, r)
        free = p.layer(cu.prepare_light(scene(solids=())), "billboards", [0], CAMERA, W, H, False)
        behind = cu.Solid((0.0, 4.0, 40.0), 6.0)
        front = cu.Solid((0.6, 4.3, -30.0), 1.5)
        for solid, expect in ((behind, "same"), (front, "blank"), (PLANE, "partial")):
            lit = cu.prepare_light(scene(solids=(solid,)))
            layer = p.layer(lit, "billboards", [0], CAMERA, W, H, False)
            hit = np.isfinite(draw_solids_cpu((solid,), SUN, CAMERA, W, H)[..., 3])
            assert hit.sum() > 20
            if expect == "same":
                np.testing.assert_array_equal(layer, free)
            elif expect == "blank":
                assert (layer[hit] == 0).all()
                np.testing.assert_array_equal(layer[~hit], free[~hit])
            else:
                assert 0 < layer[hit][:, 3].mean() < 0.9 * free[hit][:, 3].mean()
                np.testing.assert_array_equal(layer[~hit], free[~hit])


@pytest.mark.gl
def test_depth_tested_billboards_gl_and_cpu_agree() -> None:
    sc = scene(billboard_shading=cu.BillboardShading(exact_textures=True))
    gl = cu.render(sc, CAMERA, W, H)
    cpu = cu.render(sc, CAMERA, W, H, backend="cpu")
    assert_image_close(gl, cpu, **only(channel_mean_abs=1e-5, max_abs=1e-4))


@pytest.mark.parametrize("shading", ["vertex", "fragment"])
@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_split_layers_composite_back_to_the_unsplit_layer(backend: str, shading: str) -> None:
    """The billboards are drawn back to front by their sort key, so cutting that order at m keys
    gives m + 1 consecutive runs: composited over each other (no object between) they are the
    unsplit layer (within 1e−6), for a cloud and for a field instance (the impostor cache splits
    instance by instance; several instances' billboards regroup by key across instances)."""
    sh = cu.BillboardShading(shading=shading, exact_textures=True)
    variants = [v.translated(-v.centre) for v in cu.cloud_variants(MODEL, n=2, seed=1)]
    field = cu.BillboardField(variants, [(0.0, 4.0, 0.0), (6.0, 3.0, 8.0)], yaw=[0.0, 40.0])
    field = field.part(0)
    with cu.Renderer() if backend == "gl" else _none() as r:
        p = painter_for(backend, r)
        for d in (CLOUD, field):
            lit = cu.prepare_light(
                cu.Scene(
                    [d],
                    sun=SUN,
                    sky=BLACK,
                    billboard_shading=sh,
                    settings=cu.RenderSettings(lighting="paper"),
                )
            )
            keys = sorted(sort_key(lit, (0.0, 4.0, z), CAMERA) for z in (-6.0, 0.0, 5.0))
            whole = p.layer(lit, d.kind, [0], CAMERA, W, H, False)
            parts = p.split(lit, 0, CAMERA, W, H, keys)
            assert parts.shape == (4, H, W, 4)
            assert all(q[..., 3].max() > 0.05 for q in parts)  # billboards on every side
            none = np.zeros((3, H, W, 4), np.float32)
            none[..., 3] = np.inf
            np.testing.assert_allclose(composite_split(parts, none), whole, atol=1e-6)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_impostors_split_a_billboard_cloud_around_a_solid(backend: str) -> None:
    """[H] §3.1.1 for a billboard cloud: the solid inside → the cloud split into 2 layers with
    the solid between them, every frame; where the solid shows, the result is the front layer
    over the solid; elsewhere it is the impostor of the cloud (close to direct rendering)."""
    # No aerial perspective: the hand-made composite below is the layers alone, before the air.
    sc = scene(sky=BLACK, settings=cu.RenderSettings(air_extinction=0.0))
    cache = cu.ImpostorCache()
    for _ in range(2):
        img = cu.render(sc, CAMERA, W, H, backend=backend, impostors=cache)
        assert cache.history[-1]["updates"] == {"split": 1} and cache.history[-1]["split"] == 1
    assert cache.stats["impostors"] == 0  # a split cloud keeps no impostor
    direct = cu.render(sc, CAMERA, W, H, backend=backend)
    solid = draw_solids_cpu((PLANE,), SUN, CAMERA, W, H)
    hit = np.isfinite(solid[..., 3])
    assert hit.sum() > 20 and (img[hit][:, 3] == 1).all()
    assert np.abs(img[~hit] - direct[~hit]).mean() <= 1e-2
    # The solid is seen through the billboards in front of it only.
    lit = cu.prepare_light(sc.replace(solids=()))
    key = sort_key(lit, PLANE.centre, CAMERA)
    with cu.Renderer() if backend == "gl" else _none() as r:
        front = painter_for(backend, r).split(lit, 0, CAMERA, W, H, [key])[1]
    dim = front[..., :3] + (1 - front[..., 3:]) * solid[..., :3]
    # Up to the impostor's resampling (the solid's pixels are bright: ~1.4).
    assert np.abs(img[hit][:, :3] - dim[hit]).mean() <= 3e-2
    assert np.abs(img[hit][:, :3] - solid[hit][:, :3]).mean() > 2e-2  # billboards in front


@pytest.mark.gl
def test_split_gl_and_cpu_agree_in_exact_mode() -> None:
    sc = scene(billboard_shading=cu.BillboardShading(exact_textures=True),
               impostor_settings=cu.ImpostorSettings(exact=True))  # fmt: skip
    with cu.Renderer() as r:
        gl = r.render(sc, CAMERA, W, H, impostors=cu.ImpostorCache())
    cpu = cu.render_cpu(sc, CAMERA, W, H, impostors=cu.ImpostorCache())
    assert_image_close(gl, cpu, **only(channel_mean_abs=1e-5, max_abs=1e-4))


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_only_the_field_instance_holding_the_solid_is_split(backend: str) -> None:
    variants = [v.translated(-v.centre) for v in cu.cloud_variants(MODEL, n=3, seed=1)]
    offsets = np.array([(-25.0, 4.0, 20.0), (0.0, 4.0, 0.0), (25.0, 6.0, 30.0)], np.float32)
    field = cu.BillboardField(variants, offsets, ids=[10, 20, 30])
    sc = scene(field)
    cache = cu.ImpostorCache()
    img = cu.render(sc, CAMERA, W, H, backend=backend, impostors=cache)
    assert cache.history[-1]["updates"] == {"split": 1, "missing": 2}
    assert sorted(cache.entries) == [(0, 10), (0, 30)]
    direct = cu.render(sc, CAMERA, W, H, backend=backend)
    hit = np.isfinite(draw_solids_cpu((PLANE,), SUN, CAMERA, W, H)[..., 3])
    assert np.abs(img[~hit] - direct[~hit]).mean() <= 1e-2
    # The aircraft flies on, out of the clouds: the instance gets its impostor back.
    away = PLANE.__class__((0.0, 40.0, -20.0), PLANE.radius, PLANE.colour, PLANE.ambient)
    cu.render(sc.replace(solids=(away,)), CAMERA, W, H, backend=backend, impostors=cache)
    assert cache.history[-1]["updates"] == {"missing": 1}
    assert sorted(cache.entries) == [(0, 10), (0, 20), (0, 30)]
    # Splitting off: the instance is drawn clipped at the solid (depth test), every frame.
    no_split = sc.replace(impostor_settings=cu.ImpostorSettings(split=False))
    cache = cu.ImpostorCache()
    for _ in range(2):
        cu.render(no_split, CAMERA, W, H, backend=backend, impostors=cache)
    assert cache.history[-1]["updates"] == {"clip": 1}
