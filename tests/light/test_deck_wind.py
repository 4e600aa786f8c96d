"""The wind relights nothing of a deck: it carries the whole layer (slab, weather map and fBm),
so a deck at any time is its time-0 self moved — the light step lights it once in both modes,
its ground shadow is the time-0 shadow moved, and its image is the time-0 image seen from a
camera moved as far, whatever the memo holds."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.light import memo
from cumuli.light.prepare import scene_shadow

SUN = cu.Sun(direction=(0.3, 0.8, 0.4), intensity=2.0)
WIND = (6.0, -2.0)
CAMERA = cu.Camera((0.0, 2.0, -40.0), (0.0, 22.0, 10.0), fov=70)


def small_deck(**kw: object) -> cu.CloudDeck:
    """A deck at test scale: a 10-unit slab over 120 × 120, a coarse lattice, a wind."""
    args: dict[str, object] = dict(
        base=20.0, top=30.0, extent=(-60.0, -60.0, 60.0, 60.0), coverage=0.6, sigma_t=0.8,
        detail_scale=8.0, map_scale=30.0, map_size=32, resolution=(32, 6, 32), seed=2, wind=WIND,
    )  # fmt: skip
    args.update(kw)
    return cu.CloudDeck(**args)  # type: ignore[arg-type]


def scene(clouds: list[object], lighting: str = "physical", ground: bool = True) -> cu.Scene:
    return cu.Scene(
        clouds, sun=SUN, noise=cu.Noise(seed=7, size=32),
        settings=cu.RenderSettings(lighting=lighting, physical_resolution=24),
        ground=cu.Ground(height=0.0) if ground else None,
    )  # fmt: skip


def test_a_drifting_deck_is_lit_once(counted) -> None:
    deck = small_deck()
    first = cu.prepare_light(scene([deck])).lights[0]
    assert counted == {"extinction": 1, "sun": 1, "visibility": 1}
    for t in (3.0, 10.0, -4.0):
        later = deck.at(t)
        light = cu.prepare_light(scene([later])).lights[0]
        ox, oz = later.offset
        assert light.grid is first.grid and light.sun_depth is first.sun_depth
        np.testing.assert_allclose(np.subtract(light.box, first.box), [[ox, 0, oz]] * 2, atol=1e-9)
    assert counted == {"extinction": 1, "sun": 1, "visibility": 1}


def test_the_paper_light_is_the_time_zero_light() -> None:
    deck = small_deck()
    first = cu.prepare_light(scene([deck], "paper")).lights[0]
    later = cu.prepare_light(scene([deck.at(5.0)], "paper")).lights[0]
    assert np.asarray(later) is np.asarray(first) or np.array_equal(later, first)
    assert np.asarray(first).max() > 0


def test_the_ground_shadow_moves_with_the_deck() -> None:
    deck = small_deck()
    still = scene_shadow(scene([deck]))
    later = deck.at(7.0)
    moved = scene_shadow(scene([later]))
    ox, oz = later.offset
    assert moved.values is still.values and still.values.min() < 0.9
    np.testing.assert_allclose(np.subtract(moved.extent, still.extent), [ox, oz, ox, oz], atol=1e-9)
    # Computed in place (not from the still deck) it is the same shadow to rounding.
    memo.clear()
    from cumuli.light.shadow import compute_shadow

    sc = scene([later])
    direct = compute_shadow(sc, moved.extent, moved.values.shape[::-1], 0.0)
    np.testing.assert_allclose(direct.values, moved.values, atol=2e-3)
    # A cloud that does not drift with the deck shades in place: no shortcut.
    cloud = cu.gaussian_cumulus(seed=1).translated((0.0, 10.0, 0.0))
    assert scene_shadow(scene([later, cloud])).values is not still.values


@pytest.mark.parametrize("lighting", ["physical", "paper"])
@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_the_image_moves_with_the_deck(lighting, backend) -> None:
    deck = small_deck()
    t = 4.0
    ox, oz = deck.at(t).offset
    off = np.array([ox, 0.0, oz])
    moved_cam = cu.Camera(
        tuple(np.asarray(CAMERA.position) + off), tuple(np.asarray(CAMERA.target) + off), fov=70
    )
    memo.clear()
    still = cu.render(scene([deck], lighting), CAMERA, 64, 48, backend=backend)
    later = cu.render(scene([deck.at(t)], lighting), moved_cam, 64, 48, backend=backend)
    assert still[..., 3].mean() > 0.05
    np.testing.assert_allclose(later, still, atol=2e-3)
    memo.clear()  # from nothing: the same image, bit for bit
    again = cu.render(scene([deck.at(t)], lighting), moved_cam, 64, 48, backend=backend)
    np.testing.assert_array_equal(again, later)
    # From the camera that did not move, the deck has drifted: another picture.
    there = cu.render(scene([deck.at(t)], lighting), CAMERA, 64, 48, backend=backend)
    assert np.abs(there - still).mean() > 10 * np.abs(later - still).mean() + 1e-4
