"""The cloud deck as a kind: registered once, drawn in both lighting modes on both backends
(through its baked lattice), lit by sun and sky, shading the ground and the other kinds, mixed
with every kind in one scene, saved in scene files and moved by the wind in `render_frames`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.rendering.compositor import plan

W, H = 64, 48
SUN = cu.Sun(direction=(0.3, 0.8, 0.4), intensity=2.0)
#: Looking up at the deck from below its base, to one side of the middle.
CAMERA = cu.Camera((0.0, 2.0, -40.0), (0.0, 22.0, 10.0), fov=70)


def small_deck(**kw: object) -> cu.CloudDeck:
    """A deck at test scale: a 10-unit slab over 120 × 120, a coarse lattice."""
    args: dict[str, object] = dict(
        base=20.0, top=30.0, extent=(-60.0, -60.0, 60.0, 60.0), coverage=0.6, sigma_t=0.8,
        detail_scale=8.0, map_scale=30.0, map_size=32, resolution=(32, 6, 32), seed=2,
    )  # fmt: skip
    args.update(kw)
    return cu.CloudDeck(**args)  # type: ignore[arg-type]


def scene(clouds: list[object], lighting: str = "paper", **kw: object) -> cu.Scene:
    kw.setdefault("sun", SUN)
    return cu.Scene(
        clouds, noise=cu.Noise(seed=7, size=32),
        settings=cu.RenderSettings(lighting=lighting, physical_resolution=24), **kw,
    )  # fmt: skip


@pytest.fixture(scope="module")
def deck() -> cu.CloudDeck:
    return small_deck()


def test_the_deck_is_registered_once_with_every_stage() -> None:
    kind = cu.registry.get("deck")
    assert kind is not None and kind.model is cu.CloudDeck
    assert kind.medium is not None and kind.physical_light is not None  # shades, physical
    assert kind.advance is not None  # the wind
    assert set(kind.modules) == {"model.deck", "rendering.deck", "kinds.deck"}


@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_the_deck_is_drawn_as_its_lattice(deck: cu.CloudDeck, lighting: str) -> None:
    # The deck's light and drawer are its baked volume's: the same picture, bit for bit in the
    # paper mode; in the physical mode its sun rays march at its own step (half a cell, where a
    # volume takes settings.light_step), which moves the picture by less than 2e-3 of itself
    # (0.16 % at most since the sun lattice holds four nodes per cell along the light, whose
    # spacing no longer bounds both steps alike).
    as_deck = cu.render(scene([deck], lighting), CAMERA, W, H, backend="cpu")
    as_volume = cu.render(scene([deck.to_volume()], lighting), CAMERA, W, H, backend="cpu")
    if lighting == "paper":
        np.testing.assert_array_equal(as_deck, as_volume)
    else:
        np.testing.assert_allclose(as_deck, as_volume, rtol=2e-3, atol=1e-3)
    assert (as_deck[..., 3] > 0.5).mean() > 0.3  # the camera looks into the deck
    assert np.isfinite(as_deck).all()


@pytest.mark.gl
@pytest.mark.parametrize("lighting", ["paper", "physical"])
def test_gl_and_the_cpu_twin_agree(deck: cu.CloudDeck, lighting: str) -> None:
    sc = scene([deck], lighting)
    gl = cu.render(sc, CAMERA, W, H)
    cpu = cu.render(sc, CAMERA, W, H, backend="cpu")
    diff = np.abs(gl - cpu)
    assert diff.max() < 0.02 and diff.mean() < 1e-3, (diff.max(), diff.mean())


def test_the_physical_deck_is_lit_by_the_sky() -> None:
    black = cu.Sky(zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0), sun_disc_intensity=0)
    deck = small_deck(coverage=1.0)  # overcast: its underside sees little sun
    lit = {}
    for name, sky in (("black", black), ("blue", cu.Sky())):
        img = cu.render(scene([deck], "physical", sky=sky), CAMERA, W, H, backend="cpu")
        cover = img[..., 3] > 0.9
        lit[name] = float(img[..., :3][cover].mean())
    assert lit["blue"] > 1.2 * lit["black"] > 0


def test_the_deck_shades_the_ground_where_it_covers() -> None:
    coverage = np.ones((16, 16), np.float32)
    coverage[:, :8] = 0.0  # no cloud over x < 0
    deck = small_deck(coverage=coverage)
    sc = scene([deck], sun=cu.Sun(direction=(0.0, 1.0, 0.0)), ground=cu.Ground(height=0.0))
    t = cu.shadow_map(sc, extent=((-50.0, -50.0), (50.0, 50.0)), resolution=20)
    assert t[:, :8].min() == pytest.approx(1.0)  # sunlit under the clear half
    assert t[:, 12:].mean() < 0.5  # shaded under the deck
    assert cu.prepare_light(sc).shadow is not None


def test_the_deck_shades_the_other_kinds(deck: cu.CloudDeck) -> None:
    overhead = cu.Sun(direction=(0.0, 1.0, 0.0), intensity=2.0)
    cumulus = cu.gaussian_cumulus(centre=(0.0, 5.0, 0.0), seed=1, n=8)
    puff = cu.particle_cumulus((20.0, 8.0, 0.0), 150, seed=3, radius=(1.5, 2.5))
    alone = cu.prepare_light(scene([cumulus, puff], sun=overhead))
    under = cu.prepare_light(scene([cumulus, puff, deck], sun=overhead))
    # The particles' light is passed through the media in either mode.
    assert under.lights[1].light.mean() < 0.8 * alone.lights[1].light.mean()
    # Media shade media in the physical mode: the cumulus' sun depth gains the deck's. Under an
    # overcast deck every point of it does, whatever the noise that erodes a broken one's gaps.
    overcast = small_deck(coverage=1.0)
    alone = cu.prepare_light(scene([cumulus], "physical", sun=overhead))
    under = cu.prepare_light(scene([cumulus, overcast], "physical", sun=overhead))
    extra = under.lights[0].total_depth() - alone.lights[0].total_depth()
    assert extra.min() > 1.0  # τ of the slab above it


def test_the_deck_mixes_with_every_kind(deck: cu.CloudDeck, tmp_path: Path) -> None:
    cumulus = cu.gaussian_cumulus(centre=(-10.0, 6.0, 0.0), seed=1, n=8)
    pc = cu.particle_cumulus((10.0, 6.0, 0.0), 150, seed=3, radius=(1.5, 2.5))
    density, box = pc.translated((0.0, 0.0, 15.0)).to_volume(12)
    volume = cu.VolumeCloud(density=density, box=box, sigma_t=0.6)
    model = cu.seedbox_presets.cumulus()
    bb = cu.seed_box_cloud(model, seed=5)
    bb = bb.translated(np.array((0.0, 6.0, -5.0)) - bb.centre)
    variants = [v.translated(-v.centre) for v in cu.cloud_variants(model, n=2, seed=1)]
    field = cu.BillboardField(variants, [(-25.0, 8.0, 20.0), (25.0, 8.0, 25.0)], ids=[1, 2])
    others = [cumulus, volume, pc, bb, field]
    sc = scene([*others, deck])
    assert sc.kinds[-1] == "deck" and len(plan(sc)) == 6
    with_deck = cu.render(sc, CAMERA, W, H, backend="cpu")
    without = cu.render(scene(others), CAMERA, W, H, backend="cpu")
    assert np.isfinite(with_deck).all()
    assert np.abs(with_deck - without).mean() > 0.01  # the deck is in the picture
    assert cu.load_scene(sc.save(tmp_path / "mixed.json")).kinds == sc.kinds


def test_a_scene_file_keeps_the_deck(tmp_path: Path) -> None:
    coverage = np.linspace(0, 1, 12 * 10, dtype=np.float32).reshape(12, 10)
    for deck in (small_deck(), small_deck(coverage=coverage, cloud_type="altostratus")):
        sc = scene([deck])
        back = cu.load_scene(sc.save(tmp_path / "deck.json"))
        assert back.clouds[0].to_dict() == deck.to_dict()
        np.testing.assert_array_equal(back.clouds[0].density_lattice(), deck.density_lattice())


def test_render_frames_moves_the_deck_with_the_wind(tmp_path: Path) -> None:
    deck = small_deck(wind=(6.0, 0.0))
    sc = scene([deck])
    paths = cu.render_frames(sc, [CAMERA] * 3, tmp_path, W, H, backend="cpu", progress=False,
                             pattern="f{}.exr", dt=2.0)  # fmt: skip
    frames = [cu.read_image(p) for p in paths]
    later = cu.render(sc.replace(clouds=[deck.at(4.0)]), CAMERA, W, H, backend="cpu")
    np.testing.assert_allclose(frames[2][..., :3], later[..., :3], atol=1e-6)
    assert np.abs(frames[0] - frames[2]).mean() > 1e-3  # the deck drifted
    assert cu.anim.frames.scene_after(sc, 4.0).clouds[0].time == 4.0


def test_cumuli_demo_deck_renders_the_deck_scene(tmp_path: Path, capsys) -> None:
    from cumuli.cli import main

    out = tmp_path / "deck.png"
    assert main(["demo", "--deck", "-o", str(out), "--width", "48", "--height", "32",
                 "--backend", "cpu"]) == 0  # fmt: skip
    img = cu.read_image(out)
    assert img.shape == (32, 48, 4) and img[..., :3].std() > 0.01
    assert cu.demo.deck_scene().kinds == ("deck",)
    with pytest.raises(SystemExit):  # one figure per call, not a silent choice
        main(["demo", "--deck", "--harris", "-o", str(out)])
    assert "not allowed with" in capsys.readouterr().err
