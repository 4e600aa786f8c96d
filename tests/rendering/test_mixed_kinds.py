"""One scene holding every kind of drawable (RENDER_CONTRACT "Compositor"): a 2018 cumulus
(marched), a density volume, a Harris particle cloud, a Torchelsen billboard cloud and a billboard
field, drawn by GL and by the C++ twins, with and without impostors — parity, the per-pixel order of
the layers against a numpy reference of the compositing rule, the nearer cloud hiding the farther
whatever their kinds, solids splitting the kinds that can split, and scene files holding every
kind."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.rendering.compositor import plan
from cumuli.testing import assert_image_close, only

W, H = 96, 72
SUN = cu.Sun(direction=(0.4, 0.8, -0.3), intensity=2.0)
BLACK = cu.Sky(zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0), sun_disc_intensity=0)
CAMERA = cu.Camera((0.0, 6.0, -75.0), (0.0, 6.0, 10.0), fov=45)
MODEL = cu.seedbox_presets.cumulus()
KINDS = ("cloud", "volume", "particles", "billboards", "billboard_field")


@pytest.fixture(scope="module")
def drawables() -> list[object]:
    """One of each kind, side by side; the billboard cloud stands in front of the cumulus."""
    cumulus = cu.gaussian_cumulus(centre=(-20.0, 0.0, 10.0), seed=1)
    pc = cu.particle_cumulus((0.0, 2.0, 0.0), 300, seed=9, radius=(2.0, 3.5))
    density, box = pc.translated((22.0, 0.0, 10.0)).to_volume(16)
    volume = cu.VolumeCloud(density=density, box=box, sigma_t=0.6, albedo=0.9, g=0.2)
    particles = pc.translated((2.0, 14.0, 25.0))
    bb = cu.seed_box_cloud(MODEL, seed=5)
    bb = bb.translated(np.array((-8.0, 0.0, -12.0)) - bb.centre)
    variants = [v.translated(-v.centre) for v in cu.cloud_variants(MODEL, n=2, seed=1)]
    field = cu.BillboardField(
        variants, [(12.0, 16.0, 45.0), (-26.0, 18.0, 55.0), (30.0, 20.0, 60.0)],
        yaw=[0.0, 120.0, 250.0], ids=[4, 8, 15],
    )  # fmt: skip
    return [cumulus, volume, particles, bb, field]


def mixed(drawables: list[object], sky: cu.Sky | None = None, **kw: object) -> cu.Scene:
    return cu.Scene(
        drawables, sun=SUN, sky=sky or cu.Sky(), noise=cu.Noise(seed=7, size=32),
        settings=cu.RenderSettings(exact_noise=True, absorption=3.0, lighting="paper"),
        billboard_shading=cu.BillboardShading(exact_textures=True), **kw,
    )  # fmt: skip


def test_every_kind_is_one_layer_and_in_the_picture(drawables: list[object]) -> None:
    sc = mixed(drawables)
    assert sc.kinds == KINDS
    assert plan(sc) == [(kind, [k]) for k, kind in enumerate(KINDS)]
    for k in range(len(KINDS)):
        alone = cu.render(sc.replace(clouds=[drawables[k]], sky=BLACK), CAMERA, W, H,
                          backend="cpu")  # fmt: skip
        assert (alone[..., 3] > 0.3).sum() >= 10, KINDS[k]


def box_entry(box: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Slab test per pixel (RENDER_CONTRACT): the ray's entry ``max(t0, 0)``, +inf on a miss."""
    d = CAMERA.ray_directions(W, H).astype(np.float64)
    o = np.asarray(CAMERA.position, np.float64)
    lo, hi = (np.asarray(b, np.float64) for b in box)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - o) / d, (hi - o) / d
    t0 = np.nanmax(np.minimum(t1, t2), axis=-1)
    t3 = np.nanmin(np.maximum(t1, t2), axis=-1)
    entry = np.maximum(t0, 0.0)
    return np.where((t0 <= t3) & (t3 >= 0), entry, np.inf)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_layers_composite_front_to_back_by_box_entry(drawables: list[object], backend: str) -> None:
    """Under a black sky each drawable alone renders its premultiplied layer (C, 1 − T); the
    scene is those layers combined front to back per pixel in the order of the ray's entry into
    each drawable's `layer_box()` (a numpy reference of the compositor's rule)."""
    sc = mixed(drawables, BLACK)
    both = cu.render(sc, CAMERA, W, H, backend=backend).astype(np.float64)
    layers = np.stack([
        cu.render(sc.replace(clouds=[d]), CAMERA, W, H, backend=backend) for d in drawables
    ]).astype(np.float64)  # fmt: skip
    entries = np.stack([box_entry(d.layer_box()) for d in drawables])  # (5, H, W)
    order = np.argsort(entries, axis=0, kind="stable")
    colour = np.zeros((H, W, 3))
    t = np.ones((H, W, 1))
    for rank in range(len(drawables)):
        k = order[rank]
        hit = np.take_along_axis(entries, k[None], 0)[0] < np.inf
        layer = np.take_along_axis(layers, k[None, ..., None], 0)[0]
        layer = np.where(hit[..., None], layer, 0.0)
        colour += t * layer[..., :3]
        t *= 1 - layer[..., 3:]
    np.testing.assert_allclose(both[..., :3], colour, atol=1e-5)
    np.testing.assert_allclose(both[..., 3], 1 - t[..., 0], atol=1e-5)
    # The billboard cloud is in front of the cumulus where both show: the other order would
    # give another picture there.
    near, far = layers[3], layers[0]
    overlap = (entries[3] < entries[0]) & (near[..., 3] > 0.5) & (far[..., 3] > 0.5)
    assert overlap.sum() >= 5
    wrong = far[..., :3] + (1 - far[..., 3:]) * near[..., :3]
    assert np.abs(both[..., :3] - wrong)[overlap].max() > 0.05


def test_the_order_turns_with_the_camera(drawables: list[object]) -> None:
    """Seen from behind, the cumulus is in front of the billboard cloud: the same scene
    composites the other way round."""
    sc = mixed([drawables[0], drawables[3]], BLACK)
    back = cu.Camera((-14.0, 3.0, 90.0), (-14.0, 3.0, 0.0), fov=35)
    both = cu.render(sc, back, W, H, backend="cpu").astype(np.float64)
    cumulus = cu.render(sc.replace(clouds=[drawables[0]]), back, W, H, backend="cpu")
    bb = cu.render(sc.replace(clouds=[drawables[3]]), back, W, H, backend="cpu")
    expect = cumulus[..., :3] + (1 - cumulus[..., 3:]) * bb[..., :3]
    np.testing.assert_allclose(both[..., :3], expect, atol=1e-5)
    assert ((cumulus[..., 3] > 0.5) & (bb[..., 3] > 0.5)).sum() >= 5


@pytest.mark.gl
def test_all_kinds_gl_and_cpu_agree(drawables: list[object]) -> None:
    """The render pass's parity tolerance (mean |GL − CPU| ≤ 1e−3 per channel), directly and
    through impostors displayed exactly."""
    sc = mixed(drawables).replace(impostor_settings=cu.ImpostorSettings(exact=True))
    lit = cu.prepare_light(sc)
    gl = cu.render(lit, CAMERA, W, H)
    cpu = cu.render(lit, CAMERA, W, H, backend="cpu")
    assert_image_close(gl, cpu, **only(channel_mean_abs=1e-3))
    gl_i = cu.render(lit, CAMERA, W, H, impostors=cu.ImpostorCache())
    cpu_i = cu.render(lit, CAMERA, W, H, backend="cpu", impostors=cu.ImpostorCache())
    assert_image_close(gl_i, cpu_i, **only(channel_mean_abs=1e-3))


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_all_kinds_through_impostors(drawables: list[object], backend: str) -> None:
    """One impostor per drawable and per field instance (4 + 3), close to direct rendering,
    all kept from a slightly moved eye and after a gust of wind on the field."""
    sc = mixed(drawables)
    cache = cu.ImpostorCache()
    img = cu.render(sc, CAMERA, W, H, backend=backend, impostors=cache)
    direct = cu.render(sc, CAMERA, W, H, backend=backend)
    assert cache.history[-1]["updates"] == {"missing": 7}
    assert set(cache.entries) == {0, 1, 2, 3, (4, 4), (4, 8), (4, 15)}
    # The marched cumulus's pixel-sharp fBm costs most (as for the particle kinds' own test).
    assert_image_close(img, direct, **only(mean_abs=2e-2))
    moved = cu.Camera((0.2, 6.05, -75.0), (0.2, 6.05, 10.0), fov=45)
    field = drawables[4]
    blown = cu.BillboardField(field.variants, field.offsets + np.float32([0.05, 0.0, 0.0]),
                              yaw=field.yaw, ids=field.ids)  # fmt: skip
    cu.render(sc.replace(clouds=[*drawables[:4], blown]), moved, W, H, backend=backend,
              impostors=cache)  # fmt: skip
    assert cache.history[-1]["updates"] == {} and cache.history[-1]["impostors"] == 7


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_solids_in_a_mixed_scene(drawables: list[object], backend: str) -> None:
    """A solid in the particle cloud and one in the billboard cloud: through impostors both
    clouds are split around their solid, the marched cumulus keeps its impostor; directly, every
    kind stops at (or is depth-tested against) the solids. The solids show in both images."""
    pc, bb = drawables[2], drawables[3]
    solids = (cu.Solid(tuple(pc.sphere[0]), 1.5, (0.9, 0.2, 0.1)),
              cu.Solid(tuple(bb.centre), 2.0, (0.2, 0.4, 0.9)))  # fmt: skip
    sc = mixed(drawables, solids=solids)
    cache = cu.ImpostorCache()
    img = cu.render(sc, CAMERA, W, H, backend=backend, impostors=cache)
    assert cache.history[-1]["updates"] == {"split": 2, "missing": 5}
    direct = cu.render(sc, CAMERA, W, H, backend=backend)
    assert_image_close(img, direct, **only(mean_abs=2e-2))
    for solid in solids:
        from cumuli.rendering.solids import draw_solids_cpu

        hit = np.isfinite(draw_solids_cpu((solid,), SUN, CAMERA, W, H)[..., 3])
        assert hit.sum() >= 3
        assert (img[hit][:, 3] == 1).all() and (direct[hit][:, 3] == 1).all()


def test_scene_file_with_every_kind_round_trips(tmp_path: Path, drawables: list[object]) -> None:
    sc = mixed(drawables).replace(
        camera=CAMERA, lights=(cu.Sun((0.0, 1.0, 0.0), (1.0, 0.6, 0.6), 0.3),),
        solids=(cu.Solid((-8.0, 0.0, -12.0), 1.0),),
        sprite_settings=cu.SpriteSettings(ambient=(0.1, 0.1, 0.12)),
        impostor_settings=cu.ImpostorSettings(tolerance=0.25),
        billboard_shading=cu.BillboardShading(shading="fragment", k_amb=0.6),
    )  # fmt: skip
    back = cu.load_scene(sc.save(tmp_path / "every_kind.json"))
    assert back.to_dict() == sc.to_dict() and back.kinds == KINDS
    np.testing.assert_array_equal(back.clouds[4].ids, [4, 8, 15])
    np.testing.assert_array_equal(back.clouds[3].centres, drawables[3].centres)
    np.testing.assert_array_equal(back.clouds[2].centres, drawables[2].centres)
    np.testing.assert_array_equal(back.clouds[1].density, drawables[1].density)
    np.testing.assert_array_equal(
        cu.render(back, CAMERA, 32, 24, backend="cpu"),
        cu.render(sc, CAMERA, 32, 24, backend="cpu"),
    )
