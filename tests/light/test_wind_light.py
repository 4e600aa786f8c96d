"""The wind relights nothing of a cloud's own: a 2018 cloud the wind carries (its noise with it)
is the same medium wherever it is, so the light step gives it its still self's light, moved —
the extinction lattice, the sun's lattice, the sky visibility and, where no other cloud shades
it, the whole light — in both modes; only the shade of other clouds is computed where it is.
The image is the still cloud's seen from a camera moved as far, whatever the memo holds."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.light import memo

SUN = cu.Sun(direction=(0.45, 0.75, 0.5))
NOISE = cu.Noise(seed=7, size=32)
PHYSICAL = cu.RenderSettings(physical_resolution=16)
PAPER = cu.RenderSettings(lighting="paper", light_resolution=24)
WIND = (1.5, 0.0, -0.5)


@pytest.fixture(scope="module")
def windy() -> cu.Cloud:
    base = cu.gaussian_cumulus(seed=1)
    return cu.Cloud(base.centres, base.radii, base.rotations, wind=WIND)


def _scene(clouds, settings=PHYSICAL) -> cu.Scene:
    return cu.Scene(clouds, sun=SUN, noise=NOISE, settings=settings)


def test_a_cloud_alone_keeps_its_light_at_every_time(windy, counted) -> None:
    first = cu.prepare_light(_scene([windy])).lights[0]
    assert counted == {"extinction": 1, "sun": 1, "visibility": 1}
    for t in (2.0, 7.0, -3.0):
        light = cu.prepare_light(_scene([windy.at(t)])).lights[0]
        off = np.asarray(windy.at(t).offset)
        assert light.grid is first.grid and light.sun_depth is first.sun_depth
        np.testing.assert_allclose(np.subtract(light.box, first.box), [off, off], atol=1e-9)
        u, v, w = (np.asarray(a) for a in first.frame[:3])
        shift = [off @ u, off @ v, off @ w]
        np.testing.assert_allclose(np.subtract(light.frame[3], first.frame[3]), shift, atol=1e-9)
        np.testing.assert_allclose(np.subtract(light.frame[4], first.frame[4]), shift, atol=1e-9)
    assert counted == {"extinction": 1, "sun": 1, "visibility": 1}


def test_shaded_by_another_only_the_shade_is_new(windy, counted) -> None:
    """Behind a cloud that shades it, a windy cloud's own terms come from its still self; its
    light is the light of the still cloud behind the shading cloud moved back as far."""
    lo, hi = windy.layer_box()
    size = float(np.max(np.subtract(hi, lo)))
    ahead = np.asarray(SUN.direction) * 1.2 * size  # towards the sun: it shades the windy one
    t = 4.0
    other = cu.gaussian_cumulus(seed=3).translated(tuple(ahead))
    shader = cu.Cloud(other.centres, other.radii, other.rotations, wind=WIND)  # the same wind
    cu.prepare_light(_scene([windy]))
    before = dict(counted)
    moved = cu.prepare_light(_scene([windy.at(t), shader.at(t)])).lights[0]
    assert moved.upstream is not None and moved.upstream.max() > 0.5
    # The windy cloud's extinction, sun lattice and sky visibility were the still one's; the
    # shading cloud's were new (one each).
    new = {k: counted[k] - before[k] for k in counted}
    assert new == {"extinction": 1, "sun": 1, "visibility": 1}
    memo.clear()
    back = cu.prepare_light(_scene([windy, shader])).lights[0]
    np.testing.assert_allclose(moved.upstream, back.upstream, rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(moved.grid, back.grid, rtol=1e-3, atol=1e-5)


def test_the_paper_light_grid_moves_with_the_cloud(windy, counted) -> None:
    from cumuli.light.ndt import cloud_light

    first = cloud_light(windy, _scene([windy], PAPER))
    later = cloud_light(windy.at(5.0), _scene([windy.at(5.0)], PAPER))
    np.testing.assert_array_equal(np.asarray(later), np.asarray(first))
    off = np.asarray(windy.at(5.0).offset)
    np.testing.assert_allclose(np.subtract(later.box, first.box), [off, off], atol=1e-9)
    assert later.record != first.record  # a grid of the moved cloud, not of the still one


@pytest.mark.parametrize("settings", [PHYSICAL, PAPER], ids=["physical", "paper"])
@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_the_image_moves_with_the_cloud(windy, settings, backend) -> None:
    t = 3.0
    off = np.asarray(windy.at(t).offset)
    cam = cu.Camera(position=(0.0, 2.0, -60.0), target=(0.0, 0.0, 0.0), fov=40)
    moved_cam = cu.Camera(position=tuple(np.asarray(cam.position) + off), target=tuple(off), fov=40)
    memo.clear()
    still = cu.render(_scene([windy], settings), cam, 80, 60, backend=backend)
    later = cu.render(_scene([windy.at(t)], settings), moved_cam, 80, 60, backend=backend)
    assert still[..., 3].mean() > 0.05
    np.testing.assert_allclose(later, still, atol=1e-4)
    memo.clear()  # from nothing: the same image, bit for bit
    again = cu.render(_scene([windy.at(t)], settings), moved_cam, 80, 60, backend=backend)
    np.testing.assert_array_equal(again, later)
    # The paper's translation (the world's noise) is another medium: another picture.
    other = cu.render(
        _scene([windy.still().translated(tuple(off))], settings), moved_cam, 80, 60,
        backend=backend,
    )  # fmt: skip
    assert np.abs(other - still).mean() > 10 * np.abs(later - still).mean() + 1e-4


def test_copies_drifted_apart_are_lit_once(windy, counted) -> None:
    """A field of copies of one cloud, each drifted with its noise, out of one another's light:
    one cloud's light step for the field, each copy's light the first's moved."""
    still = windy.still()
    copies = [still.drifted((200.0 * k, 0.0, 0.0)) for k in range(4)]
    lit = cu.prepare_light(_scene(copies))
    assert counted == {"extinction": 1, "sun": 1, "visibility": 1}
    for k, light in enumerate(lit.lights):
        assert light.grid is lit.lights[0].grid
        np.testing.assert_allclose(
            np.subtract(light.box, lit.lights[0].box), [[200.0 * k, 0, 0]] * 2, atol=1e-9
        )


@pytest.mark.parametrize("settings", [PHYSICAL, PAPER], ids=["physical", "paper"])
def test_the_wind_keeps_a_clouds_impostor(windy, settings) -> None:
    """Harris 2002's impostors: a cloud the wind moved (its light moved with it) keeps its
    impostor, displayed moved with the cloud; a cloud translated through the world's noise is
    another cloud."""
    cam = cu.Camera(position=(0.0, 2.0, -60.0), target=(0.0, 0.0, 0.0), fov=40)
    t = 2.0
    off = np.asarray(windy.at(t).offset)
    moved_cam = cu.Camera(tuple(np.add(cam.position, off)), tuple(off), fov=40)
    cache = cu.ImpostorCache()
    first = cu.render(_scene([windy], settings), cam, 64, 48, backend="cpu", impostors=cache)
    later = cu.render(
        _scene([windy.at(t)], settings), moved_cam, 64, 48, backend="cpu", impostors=cache
    )
    assert cache.history[-1]["updates"] == {}
    np.testing.assert_allclose(later, first, atol=1e-5)
    other = windy.still().translated(tuple(off))
    cu.render(_scene([other], settings), moved_cam, 64, 48, backend="cpu", impostors=cache)
    assert cache.history[-1]["updates"] == {"cloud": 1}
