"""The light step (`cumuli.prepare_light`): explicit, recorded, never stored on a cloud.

A grid `light_grid` made with other noise / fBm / extinction / step / method / resolution /
solid angle / κ / density override, or for other primitives or another sun, is recomputed when
given to `prepare_light`; a grid made with the scene's parameters is kept as it is (the same
object), and a grid made by hand (`LightGrid(values, box)`, no record) is trusted. Clouds are
never changed. No GL needed: `prepare_light` is what both backends call first.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import cumuli as cu
from cumuli.light.prepare import clear_memo

SUN = cu.Sun(direction=(0.3, 0.8, 0.2))
# Small grids keep each light pass to a few milliseconds.
SETTINGS = cu.RenderSettings(light_resolution=6, lighting="paper")


def scene_for(cloud: cu.Cloud, **settings: Any) -> cu.Scene:
    return cu.Scene(
        clouds=[cloud],
        sun=SUN,
        noise=cu.Noise(seed=7, size=16),
        settings=SETTINGS.replace(**settings),
    )


def expected_record(cloud: cu.Cloud, scene: cu.Scene) -> cu.light.grid.LightRecord:
    return cu.light.grid.LightRecord.of(cloud, scene.noise, scene.settings.light_params())


def matching_grid(scene: cu.Scene, cloud: cu.Cloud, **over: Any) -> cu.LightGrid:
    """A user's grid made with the scene's parameters, except ``over``."""
    kwargs = {**scene.settings.light_grid_kwargs(), **over}
    noise = kwargs.pop("noise", scene.noise)
    return cu.light_grid(cloud, scene.sun, noise, **kwargs)


def test_grid_made_with_the_light_grid_defaults_is_recomputed() -> None:
    # The audit's case: light_grid's fBm frequency (1.0) is not the settings' (0.3).
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    user = cu.light_grid(cloud, SUN, scene.noise, resolution=6)
    assert user.record.params.frequency == 1.0
    lit = cu.prepare_light(scene, lights=[user])
    grid = lit.lights[0]
    assert grid is not user
    assert grid.record == expected_record(cloud, scene)
    assert grid.record.params.frequency == pytest.approx(0.3)
    fresh = cu.light_grid(cloud, SUN, scene.noise, **scene.settings.light_grid_kwargs())
    np.testing.assert_array_equal(grid, fresh)
    assert not np.array_equal(grid, user)


def test_grid_made_with_matching_parameters_is_kept() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    grid = matching_grid(scene, cloud)
    assert cu.prepare_light(scene, lights={0: grid}).lights[0] is grid
    # float32 rounding of the parameters is what the core sees: an equal float32 step matches.
    cloud2 = cu.gaussian_cumulus(seed=1)
    grid2 = matching_grid(scene, cloud2, step=np.float32(scene.settings.light_step))
    assert cu.prepare_light(scene.replace(clouds=[cloud2]), lights=[grid2]).lights[0] is grid2


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
    grid = cu.prepare_light(scene, lights=[stale]).lights[0]
    assert grid is not stale
    assert grid.record == expected_record(cloud, scene)


def test_a_grid_for_another_sun_is_recomputed() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    other = matching_grid(scene.replace(sun=cu.Sun(direction=(0, 1, 0))), cloud)
    grid = cu.prepare_light(scene, lights=[other]).lights[0]
    assert grid is not other and grid.sun == pytest.approx(SUN.direction)


def test_kappa_override_and_model() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud, kappa=0.8)
    grid = matching_grid(scene, cloud)  # made for the cloud's own κ, the settings override it
    made = cu.prepare_light(scene, lights=[grid]).lights[0]
    assert made is not grid and made.record.kappa == pytest.approx(0.8)
    assert cu.prepare_light(scene, lights=[made]).lights[0] is made  # the renderer's own grid
    # κ does not enter the metaball density: overriding it keeps a metaball grid.
    balls = cu.metaball_cumulus(seed=3)
    mscene = scene_for(balls)
    mgrid = matching_grid(mscene, balls)
    kscene = mscene.replace(settings=mscene.settings.replace(kappa=0.9))
    assert cu.prepare_light(kscene, lights=[mgrid]).lights[0] is mgrid


def test_moved_primitives_recompute_the_grid() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    grid = matching_grid(scene, cloud)
    cloud.centres[0] += 1.0  # the arrays are numpy views: edited in place
    assert cu.prepare_light(scene, lights=[grid]).lights[0] is not grid


def test_hand_made_grid_is_trusted() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    lo, hi = cloud.bbox
    hand = cu.LightGrid(np.full((3, 3, 3), 0.5, np.float32), (lo, hi))
    assert hand.record is None and hand.sun is None
    assert cu.prepare_light(scene, lights=[hand]).lights[0] is hand
    # A hand-made grid that says it was made for another sun is recomputed.
    sunny = cu.LightGrid(hand, (lo, hi), sun=(0, 1, 0))
    assert cu.prepare_light(scene, lights=[sunny]).lights[0] is not sunny


def test_prepare_light_changes_no_cloud_and_memoises() -> None:
    clear_memo()
    cloud = cu.gaussian_cumulus(seed=1)
    before = {k: v for k, v in vars(cloud).items()}
    scene = scene_for(cloud)
    first = cu.prepare_light(scene)
    assert vars(cloud).keys() == before.keys()  # nothing attached to the cloud
    second = cu.prepare_light(scene)
    assert second.lights[0] is first.lights[0]  # the same content gives the memoised grid
    assert isinstance(first, cu.LitScene) and first.scene is scene
    lit_again = cu.prepare_light(first)  # a LitScene passes through, its lights kept
    assert lit_again.lights[0] is first.lights[0]


def test_a_failed_light_step_changes_nothing() -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    with pytest.raises(TypeError, match="LightGrid"):
        cu.prepare_light(scene, lights=[np.ones((2, 2, 2))])
    with pytest.raises(ValueError, match="index"):
        cu.prepare_light(scene, lights={3: None})
    with pytest.raises(ValueError, match="one entry per cloud"):
        cu.prepare_light(scene, lights=[None, None])
    assert not hasattr(cloud, "light")


def test_record_and_grid_survive_save_and_load(tmp_path: Path) -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    scene = scene_for(cloud)
    grid = matching_grid(scene, cloud)
    back = cu.load_light_grid(grid.save(tmp_path / "g.npz"))
    np.testing.assert_array_equal(back, grid)
    assert back.record == grid.record and back.sun == grid.sun and back.box == grid.box
    kept = cu.prepare_light(scene, lights=[back]).lights[0]
    assert kept is back  # still current after the round trip
    # A saved grid made with other parameters is recomputed after loading.
    other = matching_grid(scene, cloud, extinction=0.3)
    loaded = cu.load_light_grid(other.save(tmp_path / "h.npz"))
    assert cu.prepare_light(scene, lights=[loaded]).lights[0] is not loaded


def test_bad_light_grid_files_are_refused(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        cu.load_light_grid(tmp_path / "absent.npz")
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="junk.npz"):
        cu.load_light_grid(junk)
    grid = cu.LightGrid(np.ones((2, 2, 2)), ((0, 0, 0), (1, 1, 1)))
    with pytest.raises(ValueError, match="npz"):
        grid.save(tmp_path / "g.json")
    with pytest.raises(ValueError, match="box"):
        cu.LightGrid(np.ones((2, 2, 2)), ((1, 1, 1), (0, 0, 0)))
    with pytest.raises(ValueError, match="NaN"):
        cu.LightGrid(np.full((2, 2, 2), np.nan), ((0, 0, 0), (1, 1, 1)))
