"""Iwasaki 2011 database: VolumeDatabase validation and the evolving-cloud generator."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu


@pytest.fixture(scope="module")
def cloud() -> cu.Cloud:
    return cu.gaussian_cumulus(centre=(0, 0, 0), n=12, seed=4)


@pytest.fixture(scope="module")
def noise() -> cu.Noise:
    return cu.Noise(seed=7, size=32)


def test_database_holds_volumes_read_only() -> None:
    vols = np.random.default_rng(0).random((3, 4, 5, 6)).astype(np.float64)
    db = cu.VolumeDatabase(vols, (0, 0, 0), (6, 5, 4))
    assert db.n == len(db) == 3
    assert db.shape == (4, 5, 6)
    assert db.volumes.dtype == np.float32 and db.volumes.flags.c_contiguous
    np.testing.assert_array_equal(db.volumes, vols.astype(np.float32))
    with pytest.raises(ValueError):
        db.volumes[0, 0, 0, 0] = 1.0


@pytest.mark.parametrize(
    ("volumes", "match"),
    [
        (np.zeros((4, 4, 4), np.float32), "4 dimensions"),
        (np.zeros((0, 4, 4, 4), np.float32), "empty"),
        (np.full((2, 3, 3, 3), np.nan, np.float32), "NaN"),
        (np.full((2, 3, 3, 3), -0.5, np.float32), "negative"),
        (np.zeros((2, 3, 3, 3), np.complex64), "dtype"),
    ],
)
def test_database_rejects_bad_volumes(volumes: np.ndarray, match: str) -> None:
    with pytest.raises((ValueError, TypeError), match=match):
        cu.VolumeDatabase(volumes, (0, 0, 0), (1, 1, 1))


def test_database_rejects_absurd_sizes_before_allocating() -> None:
    # A broadcast view: 2^40 values described without memory behind them.
    huge = np.broadcast_to(np.float32(0), (1 << 10, 1 << 10, 1 << 10, 1 << 10)).view()
    with pytest.raises(ValueError, match="volumes"):
        cu.VolumeDatabase(huge, (0, 0, 0), (1, 1, 1))


def test_database_rejects_bad_box() -> None:
    vols = np.zeros((2, 2, 2, 2), np.float32)
    with pytest.raises(ValueError, match="box_max"):
        cu.VolumeDatabase(vols, (0, 0, 0), (1, 0, 1))
    with pytest.raises(ValueError, match="box_min"):
        cu.VolumeDatabase(vols, (0, np.nan, 0), (1, 1, 1))


def test_generator_shape_box_and_similar_successors(cloud: cu.Cloud, noise: cu.Noise) -> None:
    db = cu.evolving_cloud_volumes(cloud, noise, 6, (12, 10, 14), seed=1, threads=2)
    assert db.volumes.shape == (6, 12, 10, 14)
    lo, hi = cloud.bbox
    assert np.all(np.array(db.box_min) <= lo) and np.all(np.array(db.box_max) >= hi)
    assert (db.volumes > 0).mean() > 0.05  # a cloud is there
    assert db.volumes[:, 0].max() == 0 and db.volumes[:, -1].max() == 0  # padding is empty
    d = db.similarity()
    # Successive volumes are more alike than volumes further apart.
    for k in range(4):
        assert d[k, k + 1] < d[k, k + 2]


def test_generator_is_reproducible_and_thread_independent(cloud: cu.Cloud, noise: cu.Noise) -> None:
    a = cu.evolving_cloud_volumes(cloud, noise, 3, 12, jitter=0.1, seed=5, threads=1)
    b = cu.evolving_cloud_volumes(cloud, noise, 3, 12, jitter=0.1, seed=5, threads=2)
    c = cu.evolving_cloud_volumes(cloud, noise, 3, 12, jitter=0.1, seed=6, threads=2)
    np.testing.assert_array_equal(a.volumes, b.volumes)
    assert a.box == b.box
    assert not np.array_equal(a.volumes, c.volumes)  # the seed draws the per-primitive drift


def test_generator_first_frame_is_the_cloud_density(cloud: cu.Cloud, noise: cu.Noise) -> None:
    """Frame 0 (no growth, drift or wind yet) voxelises cumuli.Cloud.density at voxel centres."""
    db = cu.evolving_cloud_volumes(cloud, noise, 2, (10, 12, 14), threads=2)
    d, h, w = db.shape
    lo, hi = np.array(db.box_min), np.array(db.box_max)
    step = (hi - lo) / np.array([w, h, d])
    z, y, x = np.meshgrid(np.arange(d), np.arange(h), np.arange(w), indexing="ij")
    pts = lo + (np.stack([x, y, z], -1).reshape(-1, 3) + 0.5) * step
    rho, _ = cloud.density(pts, noise)
    ref = rho.reshape(d, h, w)
    got = db.volumes[0]
    # Voxel centres computed in another float order can fall on the other side of a primitive's
    # surface or of the ρ < γ test: allow a few boundary voxels, the rest must agree closely.
    close = np.isclose(got, ref, atol=1e-5)
    assert close.mean() > 0.99
    assert (ref > 0).sum() > 100


def test_generator_constant_density_and_growth(cloud: cu.Cloud) -> None:
    db = cu.evolving_cloud_volumes(cloud, None, 4, 12, constant=0.5, growth=0.5, jitter=0.0)
    assert set(np.unique(db.volumes)) <= {0.0, 0.5}
    filled = (db.volumes > 0).sum(axis=(1, 2, 3))
    assert np.all(np.diff(filled) > 0)  # the cloud grows


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        ({"n_frames": 0}, ValueError),
        ({"n_frames": 2.5}, TypeError),
        ({"resolution": 0}, ValueError),
        ({"resolution": (4, 4)}, TypeError),
        ({"n_frames": 1 << 16, "resolution": 64}, ValueError),  # size checked before allocating
        ({"growth": -1.0}, ValueError),
        ({"jitter": -0.1}, ValueError),
        ({"wind": (0, np.inf, 0)}, ValueError),
        ({"box": ((0, 0, 0), (0, 1, 1))}, ValueError),
    ],
)
def test_generator_bad_input(cloud: cu.Cloud, noise: cu.Noise, kwargs: dict, error: type) -> None:
    args = {"n_frames": 2, "resolution": 8} | kwargs
    with pytest.raises(error):
        cu.evolving_cloud_volumes(cloud, noise, **args)


def test_generator_needs_noise_or_constant(cloud: cu.Cloud, noise: cu.Noise) -> None:
    with pytest.raises(ValueError, match="noise or constant"):
        cu.evolving_cloud_volumes(cloud, None, 2, 8)
    with pytest.raises(ValueError, match="noise or constant"):
        cu.evolving_cloud_volumes(cloud, noise, 2, 8, constant=1.0)
    with pytest.raises(TypeError, match="cloud"):
        cu.evolving_cloud_volumes("cloud", noise, 2, 8)  # type: ignore[arg-type]
