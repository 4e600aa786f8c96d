"""Translated copies of a volume share one light step: a `VolumeCloud`'s medium is its lattice
over its box, so its physical light does not depend on where it stands. The light step lights
the volume with its box's low corner at the origin and moves the light to every copy (only the
shade of other drawables is computed where a copy is); the image does not depend on what the
memo held, and equals the light computed in place to float rounding."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.kinds.volume import at_origin
from cumuli.light import memo
from cumuli.light import physical as phys
from cumuli.light.moved import moved

SUN = cu.Sun(direction=(0.45, 0.75, 0.5))
PHYSICAL = cu.RenderSettings(physical_resolution=20)
BOX = ((-1.0, -0.5, -1.0), (1.0, 1.5, 1.0))


def _blob(detail: float = 0.0) -> cu.VolumeCloud:
    z, y, x = np.mgrid[-1:1:20j, -1:1:20j, -1:1:20j]
    lumpy = 1.0 - (x * x + 1.4 * y * y + z * z) + 0.15 * np.sin(5 * x) * np.cos(4 * z)
    density = (3.0 * np.clip(lumpy, 0.0, None)).astype(np.float32)
    return cu.VolumeCloud(density, box=BOX, detail=detail)


def _scene(drawables, settings=PHYSICAL) -> cu.Scene:
    return cu.Scene(drawables, sun=SUN, settings=settings)


def test_a_volume_is_its_copy_at_the_origin_moved() -> None:
    volume = _blob()
    still, offset = at_origin(volume)
    assert offset == BOX[0]
    assert still.box == ((0.0, 0.0, 0.0), (2.0, 2.0, 2.0))
    assert still.density is volume.density  # arrays shared, nothing recomputed
    assert volume.box == BOX  # the volume itself is untouched
    # At the origin already: itself, not moved.
    home = volume.translated(tuple(-np.asarray(BOX[0])))
    assert moved(home) == (home, None)
    # Copies moved by offsets that round differently in float64 share one still volume.
    a, b = volume.translated((0.1, 0.7, -0.3)), volume.translated((1e3 + 0.2, 0.0, 3.3))
    assert at_origin(a)[0].box == at_origin(b)[0].box


def test_copies_out_of_each_others_light_are_lit_once(counted) -> None:
    volume = _blob()
    copies = [volume.translated((6.0 * k, 0.0, -4.0 * k)) for k in range(4)]
    lit = cu.prepare_light(_scene(copies))
    assert counted == {"extinction": 1, "sun": 1, "visibility": 1}
    first = lit.lights[0]
    for k, light in enumerate(lit.lights):
        assert light.grid is first.grid and light.sun_depth is first.sun_depth
        off = np.array([6.0 * k, 0.0, -4.0 * k])
        np.testing.assert_allclose(np.subtract(light.box, first.box), [off, off], atol=1e-6)
        u, v, w = (np.asarray(a) for a in first.frame[:3])
        shift = [off @ u, off @ v, off @ w]
        np.testing.assert_allclose(np.subtract(light.frame[3], first.frame[3]), shift, atol=1e-6)


def test_the_light_at_the_origin_is_the_light_in_place(monkeypatch) -> None:
    """Lit at the origin and moved, a volume's light is the one computed where it stands, to
    float rounding."""
    volume = _blob().translated((12.5, 3.25, -7.75))
    memo.clear()
    shared = cu.prepare_light(_scene([volume])).lights[0]
    monkeypatch.setattr(phys, "moved", lambda d: (d, None))
    memo.clear()
    in_place = cu.prepare_light(_scene([volume])).lights[0]
    memo.clear()
    assert in_place.grid is not shared.grid
    scale = float(np.abs(in_place.grid).max())
    np.testing.assert_allclose(shared.grid, in_place.grid, atol=1e-5 * scale)
    np.testing.assert_allclose(shared.box, in_place.box, atol=1e-6)
    np.testing.assert_allclose(shared.frame[3], in_place.frame[3], atol=1e-5)
    np.testing.assert_allclose(shared.frame[4], in_place.frame[4], atol=1e-5)


def test_a_shaded_copy_computes_only_the_shade(counted) -> None:
    """Behind another volume, a copy's own terms come from the volume at the origin; its light
    is the light of the volume there behind the shading volume moved as far."""
    volume = _blob()
    ahead = tuple(np.asarray(SUN.direction) * 2.4)  # towards the sun: it shades the copy
    shader = _blob().translated(ahead)
    cu.prepare_light(_scene([volume]))
    before = dict(counted)
    off = (20.0, 1.0, -5.0)
    moved_pair = cu.prepare_light(_scene([volume.translated(off), shader.translated(off)]))
    light = moved_pair.lights[0]
    assert light.upstream is not None and light.upstream.max() > 0.5
    # The copy's extinction, sun lattice and sky visibility were the first volume's, and so were
    # the shader's (another copy of it): only the shade is new.
    new = {k: counted[k] - before[k] for k in counted}
    assert new == {"extinction": 0, "sun": 0, "visibility": 0}
    memo.clear()
    back = cu.prepare_light(_scene([volume, shader])).lights[0]
    np.testing.assert_allclose(light.upstream, back.upstream, rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(light.grid, back.grid, rtol=1e-3, atol=1e-5)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_a_copys_image_is_the_volumes_from_a_moved_camera(backend) -> None:
    volume = _blob()
    off = np.array([9.0, 0.5, -3.0])
    cam = cu.Camera(position=(0.0, 1.0, -7.0), target=(0.0, 0.5, 0.0), fov=40)
    moved_cam = cu.Camera(tuple(np.add(cam.position, off)), tuple(np.add(cam.target, off)), fov=40)
    memo.clear()
    first = cu.render(_scene([volume]), cam, 64, 48, backend=backend)
    copy = cu.render(_scene([volume.translated(tuple(off))]), moved_cam, 64, 48, backend=backend)
    assert first[..., 3].mean() > 0.05
    np.testing.assert_allclose(copy, first, atol=2e-4)
    memo.clear()  # from nothing: the same image, bit for bit
    again = cu.render(_scene([volume.translated(tuple(off))]), moved_cam, 64, 48, backend=backend)
    np.testing.assert_array_equal(again, copy)


def test_eroded_copies_share_the_light_not_the_detail(counted) -> None:
    """The sharp-volume erosion is anchored in the world and drawn, not lit: eroded copies
    share one light step and still differ in their edges' detail."""
    volume = _blob(detail=0.4)
    off = (7.3, 0.0, 2.1)
    pair = [volume, volume.translated(off)]
    lit = cu.prepare_light(_scene(pair))
    assert counted == {"extinction": 1, "sun": 1, "visibility": 1}
    assert lit.lights[1].grid is lit.lights[0].grid
    cam = cu.Camera(position=(0.0, 1.0, -7.0), target=(0.0, 0.5, 0.0), fov=40)
    moved_cam = cu.Camera(tuple(np.add(cam.position, off)), tuple(np.add(cam.target, off)), fov=40)

    def change(v: cu.VolumeCloud) -> float:
        first = cu.render(_scene([v]), cam, 64, 48, backend="cpu")
        copy = cu.render(_scene([v.translated(off)]), moved_cam, 64, 48, backend="cpu")
        return float(np.abs(copy - first).mean())

    assert change(volume) > max(1e-4, 20.0 * change(_blob()))
