"""The GL physical atlases are packed and uploaded once per light frame: a frame drawn again with
the same light reuses them, and a new light is never drawn with the old one's."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.rendering import physical_gl


@pytest.mark.gl
def test_same_light_reuses_the_packing_and_new_light_replaces_it(renderer: cu.Renderer) -> None:
    settings = cu.RenderSettings(lighting="physical", physical_resolution=16)
    scene = cu.Scene([cu.gaussian_cumulus(n=8, seed=4)], noise=cu.Noise(seed=1, size=32),
                     settings=settings)  # fmt: skip
    cam = scene.default_camera()
    a = cu.prepare_light(scene)
    b = cu.prepare_light(scene.replace(sun=cu.Sun(direction=(-0.6, 0.3, 0.5))))
    first = renderer.render(a, cam, 40, 30)
    packed = physical_gl._last_pack[0]
    held = physical_gl._uploaded[renderer.gl.ctx]
    again = renderer.render(a, cam, 40, 30)
    assert physical_gl._last_pack[0] is packed  # reused, and so are its GL objects
    assert physical_gl._uploaded[renderer.gl.ctx] is held
    np.testing.assert_array_equal(first, again)
    other = renderer.render(b, cam, 40, 30)
    assert physical_gl._last_pack[0] is not packed
    assert physical_gl._uploaded[renderer.gl.ctx] is not held  # the old ones released
    physical_gl._last_pack[0] = None  # packed afresh: the same image
    np.testing.assert_array_equal(renderer.render(b, cam, 40, 30), other)
    assert not np.array_equal(first, other)
