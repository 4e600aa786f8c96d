"""The physical mode's air: the ground fades into the horizon's sky with its distance."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli.rendering.air import ground_haze


def ground_scene(**settings) -> tuple[cu.Scene, cu.Camera]:
    scene = cu.Scene(
        [], sun=cu.Sun(direction=(0.3, 0.6, 0.4), intensity=6.0), ground=cu.Ground(height=0.0),
        settings=cu.RenderSettings(**settings),
    )  # fmt: skip
    return scene, cu.Camera(position=(0, 2, 0), target=(0, 1.6, 10), fov=40)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_the_ground_fades_into_the_horizon_with_distance(backend: str) -> None:
    scene, cam = ground_scene(haze=0.0, resolve=False)
    img = cu.render(scene, cam, 40, 30, backend=backend)
    raw = cu.render(scene.replace(settings=scene.settings.replace(air_extinction=0.0)), cam, 40, 30,
                    backend=backend)  # fmt: skip
    horizon = np.asarray(scene.sky.horizon)
    fade = ground_haze(scene, cam, 40, 30)
    rows = np.where(fade[:, 20] > 0)[0]
    assert len(rows) > 5  # the ground is in the picture, below the horizon
    near, far = rows[-1], rows[0]  # the bottom row is the nearest ground
    assert fade[far, 20] > 0.5 > fade[near, 20] > 0
    d_far = np.abs(img[far, 20, :3] - horizon).sum()
    assert d_far < 0.5 * np.abs(raw[far, 20, :3] - horizon).sum()  # far ground: nearly sky
    # Exactly the stated blend, and nothing changes in the sky.
    expected = raw[..., :3] + fade[..., None] * (horizon - raw[..., :3])
    np.testing.assert_allclose(img[..., :3], expected, atol=1e-5)
    t = 2.0 / -cam.ray_directions(40, 30)[near, 20, 1]
    assert fade[near, 20] == pytest.approx(1 - math.exp(-0.003 * t), rel=1e-4)
    assert (
        ground_haze(scene.replace(settings=cu.RenderSettings(lighting="paper")), cam, 4, 3) is None
    )
