"""Stale light grids: ``light_grid`` records its parameters and the renderer honours the record.

A grid the user made with other noise / fBm / extinction / step / method / resolution / solid
angle / κ / density override, or for other primitives, must be recomputed before rendering
(`cumuli.prepare_light`, shared by both backends); a grid made with the scene's parameters is
kept as it is (the same array object), and a grid set by hand (no record) is trusted.
No GL needed: `prepare_light` is what both marchers call first.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import cumuli as cu
from cumuli.rendering.renderer import expected_light_params

SUN = cu.Sun(direction=(0.3, 0.8, 0.2))
# Small grids keep each light pass to a few milliseconds.
SETTINGS = cu.RenderSettings(light_resolution=6)


def scene_for(cloud: cu.Cloud, **settings: Any) -> cu.Scene:
    return cu.Scene(
        clouds=[cloud],
        sun=SUN,
        noise=cu.Noise(seed=7, size=16),
        settings=SETTINGS.replace(**settings),
    )


def matching_grid(scene: cu.Scene, cloud: cu.Cloud, **over: Any) -> np.ndarray:
    """A user's grid made with the scene's parameters, except ``over``."""
    kwargs = {**scene.settings.light_grid_kwargs(), **over}
    noise = kwargs.pop("noise", scene.noise)
    return cu.light_grid(cloud, scene.sun, noise, **kwargs)


def test_grid_made_with_the_light_grid_defaults_is_recomputed() -> None:
    # The audit's case: light_grid's fBm frequency (1.0) is not the settings' (0.3).
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    user = cu.light_grid(cloud, SUN, scene.noise, resolution=6)
    assert cloud.light_params["frequency"] == 1.0
    cu.prepare_light(scene)
    assert cloud.light is not user
    assert cloud.light_params == expected_light_params(cloud, scene)
    assert cloud.light_params["frequency"] == pytest.approx(0.3)
    fresh = cu.light_grid(
        cloud, SUN, scene.noise, store=False, **scene.settings.light_grid_kwargs()
    )
    np.testing.assert_array_equal(cloud.light, fresh)
    assert not np.array_equal(cloud.light, user)


def test_grid_made_with_matching_parameters_is_kept() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    grid = matching_grid(scene, cloud)
    cu.prepare_light(scene)
    assert cloud.light is grid
    # float32 rounding of the parameters is what the core sees: an equal float32 step matches.
    cloud2 = cu.gaussian_cumulus(seed=1)
    grid2 = matching_grid(scene, cloud2, step=np.float32(scene.settings.light_step))
    cu.prepare_light(scene.replace(clouds=[cloud2]))
    assert cloud2.light is grid2


@pytest.mark.parametrize(
    "over",
    [
        {"frequency": 0.31},
        {"octaves": 4},
        {"gain": 0.45},
        {"lacunarity": 2.1},
        {"extinction": 0.9},
        {"step": 0.12},
        {"method": "naive"},
        {"resolution": 7},
        {"resolution": (6, 6, 7)},
        {"solid_angle": 2e-4},
        {"density_override": 0.4},
        {"noise": cu.Noise(seed=8, size=16)},
        {"noise": cu.Noise(seed=7, size=32)},
    ],
    ids=lambda o: next(iter(o)) + "=" + str(next(iter(o.values()))),
)
def test_any_differing_parameter_recomputes_the_grid(over: dict[str, Any]) -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    stale = matching_grid(scene, cloud, **over)
    cu.prepare_light(scene)
    assert cloud.light is not stale
    assert cloud.light_params == expected_light_params(cloud, scene)


def test_kappa_override_and_model() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud, kappa=0.8)
    grid = matching_grid(scene, cloud)  # made for the cloud's own κ, the settings override it
    cu.prepare_light(scene)
    assert cloud.light is not grid and cloud.light_params["kappa"] == pytest.approx(0.8)
    kept = cloud.light
    cu.prepare_light(scene)
    assert cloud.light is kept  # the renderer's own grid is current
    # κ does not enter the metaball density: overriding it keeps a metaball grid.
    balls = cu.metaball_cumulus(seed=3)
    mscene = scene_for(balls)
    mgrid = matching_grid(mscene, balls)
    cu.prepare_light(mscene.replace(settings=mscene.settings.replace(kappa=0.9)))
    assert balls.light is mgrid


def test_moved_primitives_recompute_the_grid() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    grid = matching_grid(scene, cloud)
    cloud.centres[0] += 1.0  # the arrays are numpy views: edited in place
    cu.prepare_light(scene)
    assert cloud.light is not grid


def test_hand_set_grid_is_trusted() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    lo, hi = cloud.bbox
    hand = np.full((3, 3, 3), 0.5, np.float32)
    cloud.light, cloud.light_box = hand, (tuple(map(float, lo)), tuple(map(float, hi)))
    assert cloud.light_params is None
    cu.prepare_light(scene)
    assert cloud.light is hand
    # A grid set by hand over a recorded one drops the record: it is trusted too.
    cu.light_grid(cloud, SUN, scene.noise, resolution=6)  # light_grid's defaults: stale
    assert cloud.light_params is not None
    cloud.light = hand
    assert cloud.light_params is None
    cu.prepare_light(scene)
    assert cloud.light is hand


@pytest.mark.parametrize("suffix", [".npz", ".json"])
def test_record_survives_save_and_load(tmp_path: Path, suffix: str) -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    matching_grid(scene, cloud)
    back = cu.load_cloud(cloud.save(tmp_path / f"c{suffix}"))
    assert back.light_params == cloud.light_params
    loaded = back.light
    cu.prepare_light(scene.replace(clouds=[back]))
    assert back.light is loaded  # still current after the round trip
    # A saved grid made with other parameters is recomputed after loading.
    other = cu.gaussian_cumulus(seed=1)
    matching_grid(scene, other, extinction=0.3)
    back = cu.load_cloud(other.save(tmp_path / f"d{suffix}"))
    loaded = back.light
    cu.prepare_light(scene.replace(clouds=[back]))
    assert back.light is not loaded


def test_bad_record_in_a_file_is_refused(tmp_path: Path) -> None:
    import json

    cloud = cu.gaussian_cumulus(seed=1)
    cu.light_grid(cloud, SUN, cu.Noise(seed=7, size=16), resolution=4)
    path = cloud.save(tmp_path / "c.json")
    doc = json.loads(path.read_text())
    doc["light_params"] = {"frequency": {"nested": 1}}
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="light_params"):
        cu.load_cloud(path)
