"""A 2018 cloud moved by the wind: ``wind · time`` moves its primitives and carries its fBm with
it (the noise is read at ``p − offset``), so it is the same medium wherever the wind takes it;
`Cloud.translated` keeps the world's noise, as the paper's clouds do."""

from __future__ import annotations

import json

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.anim.frames import scene_after

NOISE = cu.Noise(seed=5, size=32)


@pytest.fixture(scope="module")
def cumulus() -> cu.Cloud:
    return cu.gaussian_cumulus(seed=2)


def _points(cloud: cu.Cloud, n: int = 4000) -> np.ndarray:
    lo, hi = cloud.bbox
    rng = np.random.default_rng(0)
    return (lo + (hi - lo) * rng.random((n, 3))).astype(np.float32)


def test_wind_moves_the_cloud_and_its_place_not_its_centres(cumulus: cu.Cloud) -> None:
    moved = cu.Cloud(cumulus.centres, cumulus.radii, wind=(2.0, -1.0), time=3.0)
    assert moved.wind == (2.0, 0.0, -1.0)  # (wx, wz): horizontal, as a deck's
    assert moved.offset == (6.0, 0.0, -3.0)
    np.testing.assert_array_equal(moved.centres, cumulus.centres)
    np.testing.assert_allclose(moved.placed_centres, cumulus.centres + [6.0, 0.0, -3.0], atol=1e-5)
    np.testing.assert_allclose(moved.bbox[0], cumulus.bbox[0] + [6.0, 0.0, -3.0], atol=1e-5)
    assert moved.at(0.0).offset == (0.0, 0.0, 0.0)
    assert moved.at(1.5).offset == (3.0, 0.0, -1.5)
    assert moved.still().wind == (0.0, 0.0, 0.0) and moved.still().time == 0.0
    assert cumulus.still() is cumulus
    assert cumulus.placed_centres is cumulus.centres
    assert "wind=[2.0, 0.0, -1.0], time=3.0" in repr(moved) and "wind" not in repr(cumulus)


def test_the_wind_carries_the_noise_translation_does_not(cumulus: cu.Cloud) -> None:
    pts = _points(cumulus)
    still, _ = cumulus.density(pts, NOISE)
    assert (still > 0).mean() > 0.05
    windy = cu.Cloud(cumulus.centres, cumulus.radii, cumulus.rotations, wind=(0.5, 0.25, -1.0))
    for t in (4.0, -7.5):
        off = np.asarray(windy.at(t).offset, np.float32)
        carried, _ = windy.at(t).density(pts + off, NOISE)
        np.testing.assert_allclose(carried, still, atol=2e-5)
    translated, _ = cumulus.translated((2.0, 1.0, -4.0)).density(pts + [2.0, 1.0, -4.0], NOISE)
    assert np.abs(translated - still).mean() > 1e-2  # a different medium at its new place


def test_a_metaball_cloud_carries_its_noise_too(cumulus: cu.Cloud) -> None:
    meta = cumulus.with_model("metaball", phi=0.3)
    pts = _points(meta)
    still, _ = meta.density(pts, NOISE)
    moved = cu.Cloud(meta.centres, meta.radii, model="metaball", phi=0.3, wind=(1, 0, 0), time=9)
    carried, _ = moved.density(pts + np.float32([9.0, 0.0, 0.0]), NOISE)
    assert (still > 0).any()
    np.testing.assert_allclose(carried, still, rtol=1e-5, atol=2e-5)  # ρ = fbm·r̄²·φ


def test_transforms_keep_the_wind(cumulus: cu.Cloud) -> None:
    windy = cu.Cloud(cumulus.centres, cumulus.radii, wind=(1.0, 0.0, 0.0), time=10.0)
    for derived in (windy.translated((1, 2, 3)), windy.scaled(1.5), windy.with_model("metaball")):
        assert (derived.wind, derived.time) == (windy.wind, windy.time)
    # Scaled about its centre where it is now: the centre stays there.
    np.testing.assert_allclose(windy.scaled(1.5).centre, windy.centre, atol=1e-4)
    np.testing.assert_allclose(
        windy.translated((1, 2, 3)).bbox[0], windy.bbox[0] + [1, 2, 3], atol=1e-5
    )
    merged = cu.merge([windy, windy.translated((0, 5, 0))])
    assert (merged.wind, merged.time) == (windy.wind, windy.time)
    with pytest.raises(ValueError, match="one noise offset"):
        cu.merge([windy, cumulus])


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"wind": (1.0,)}, TypeError, "wind"),
        ({"wind": "east"}, TypeError, "wind"),
        ({"wind": (1.0, float("nan"))}, ValueError, "wind"),
        ({"wind": (1, 2, 3, 4)}, TypeError, "wind"),
        ({"time": float("inf")}, ValueError, "time"),
        ({"wind": (1e10, 0.0), "time": 1e10}, ValueError, "wind · time"),
    ],
)
def test_bad_wind_and_time_are_refused(
    cumulus: cu.Cloud, kwargs: dict, error: type, match: str
) -> None:
    with pytest.raises(error, match=match):
        cu.Cloud(cumulus.centres, cumulus.radii, **kwargs)


def test_the_core_refuses_a_non_finite_noise_offset(cumulus: cu.Cloud) -> None:
    args = cumulus.core_args()[:6]
    assert _core.CloudShape(*args).noise_offset == (0.0, 0.0, 0.0)
    assert _core.CloudShape(*args, (1.0, 2.0, 3.0)).noise_offset == (1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match="noise_offset"):
        _core.CloudShape(*args, (float("nan"), 0.0, 0.0))


def test_files_keep_the_wind(cumulus: cu.Cloud, tmp_path) -> None:
    windy = cu.Cloud(cumulus.centres, cumulus.radii, wind=(1.0, 0.5, 0.0), time=2.5)
    back = cu.Cloud.from_dict(windy.to_dict())
    assert (back.wind, back.time) == (windy.wind, windy.time)
    assert "wind" not in cumulus.to_dict()  # a still cloud's dict is as it was
    for name in ("c.npz", "c.json"):
        loaded = cu.load_cloud(windy.save(tmp_path / name))
        assert (loaded.wind, loaded.time) == (windy.wind, windy.time)
        np.testing.assert_array_equal(loaded.placed_centres, windy.placed_centres)
    with pytest.raises(TypeError, match="wind"):  # as for any field of the wrong type
        cu.Cloud.from_dict(windy.to_dict() | {"wind": [0, "x", 1]})


def test_scene_after_moves_clouds_with_a_wind_only(cumulus: cu.Cloud) -> None:
    windy = cu.Cloud(cumulus.centres, cumulus.radii, wind=(2.0, 0.0))
    scene = cu.Scene([windy, cumulus], noise=NOISE)
    later = scene_after(scene, 4.0)
    assert later.clouds[0].offset == (8.0, 0.0, 0.0)
    assert later.clouds[1] is cumulus
    assert scene_after(later, -4.0).clouds[0].offset == (0.0, 0.0, 0.0)


def test_a_drifted_copy_is_the_same_medium_elsewhere(cumulus: cu.Cloud) -> None:
    copy = cumulus.drifted((10.0, 0.0, -4.0))
    assert copy.offset == (10.0, 0.0, -4.0) and copy.params["transforms"][-1] == {
        "drift": [10.0, 0.0, -4.0]
    }
    pts = _points(cumulus)
    np.testing.assert_allclose(
        copy.density(pts + np.float32([10.0, 0.0, -4.0]), NOISE)[0],
        cumulus.density(pts, NOISE)[0],
        atol=2e-5,
    )
    windy = cu.Cloud(copy.centres, copy.radii, wind=(1.0, 0.0), time=2.0, drift=copy.drift)
    assert windy.offset == (12.0, 0.0, -4.0)  # drift + wind · time
    back = cu.Cloud.from_dict(windy.to_dict())
    assert (back.wind, back.time, back.drift) == (windy.wind, windy.time, windy.drift)
    assert windy.still().offset == (0.0, 0.0, 0.0) and windy.still().drift == (0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="one noise offset"):
        cu.merge([copy, cumulus])


def test_a_volume_file_of_a_drifting_cloud_is_the_still_ones_moved(cumulus, tmp_path) -> None:
    copy = cumulus.drifted((6.0, 0.0, 0.0))
    still = cu.read_volume(cu.write_volume(tmp_path / "still.vol", cumulus, NOISE, resolution=16))
    moved = cu.read_volume(cu.write_volume(tmp_path / "moved.vol", copy, NOISE, resolution=16))
    np.testing.assert_allclose(moved.density, still.density, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(np.subtract(moved.box, still.box), [[6, 0, 0], [6, 0, 0]], atol=1e-5)


def test_a_scene_file_keeps_its_clouds_motion(cumulus: cu.Cloud, tmp_path) -> None:
    windy = cu.Cloud(cumulus.centres, cumulus.radii, wind=(2.0, 0.0), time=3.0, drift=(1, 0, 0))
    path = tmp_path / "scene.json"
    cu.Scene([windy, cumulus], noise=NOISE).save(path)
    back = cu.load_scene(path)
    assert back.clouds[0].offset == (7.0, 0.0, 0.0) and back.clouds[0].wind == (2.0, 0.0, 0.0)
    assert back.clouds[1].offset == (0.0, 0.0, 0.0)
    assert "wind" not in json.loads(path.read_text())["clouds"][1]
