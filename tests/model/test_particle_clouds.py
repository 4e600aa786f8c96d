"""Harris 2002 particle clouds: data, generators, volumes, files."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.model.particles import (
    MAX_PARTICLES,
    ParticleCloud,
    load_particles,
    particle_cumulus,
    particle_fill,
)


def small() -> ParticleCloud:
    return ParticleCloud(
        [(0, 0, 0), (2, 0, 0), (0, 3, -1)],
        [1.0, 0.5, 2.0],
        [8, 4, 2],
        0.9,
        params={"generator": "test"},
    )


def test_fields_bounds_and_sphere() -> None:
    pc = small()
    assert pc.kind == ParticleCloud.kind == "particles"
    assert len(pc) == pc.n == 3
    assert pc.centres.dtype == np.float32 and not pc.centres.flags.writeable
    assert pc.albedo.tolist() == pytest.approx([0.9] * 3)
    lo, hi = pc.bounds()
    assert lo.tolist() == [-2, -1, -3] and hi.tolist() == [2.5, 5, 1]
    c, r = pc.sphere
    assert c.tolist() == [0.25, 2.0, -1.0]
    want = max(math.dist(p, c) + rk for p, rk in zip(pc.centres, pc.radii, strict=True))
    assert r == pytest.approx(want, rel=1e-6)


def test_values_translate_scale_merge() -> None:
    pc = small()
    moved = pc.translated((1, 2, 3))
    assert np.allclose(moved.centres, pc.centres + [1, 2, 3])
    assert moved.params["transforms"] == [{"translate": [1.0, 2.0, 3.0]}]
    assert pc.params.get("transforms") is None  # unchanged original
    big = pc.scaled(2.0, about=(0, 0, 0))
    assert np.allclose(big.centres, 2 * pc.centres) and np.allclose(big.radii, 2 * pc.radii)
    assert np.array_equal(big.tau, pc.tau)
    both = pc.merged(moved)
    assert both.n == 6 and np.array_equal(both.centres[3:], moved.centres)
    assert both.stats["parts"] == [3, 3]


def test_save_load_npz_json_and_dict(tmp_path: Path) -> None:
    pc = particle_cumulus(n_particles=50, seed=3).translated((1, 0, 0))
    for name in ("c.npz", "c.json"):
        path = pc.save(tmp_path / name)
        back = load_particles(path)
        for key in ("centres", "radii", "tau", "albedo"):
            assert np.array_equal(getattr(back, key), getattr(pc, key))
        assert back.params == json.loads(json.dumps(pc.params))
        assert back.stats == pc.stats
    doc = json.loads(json.dumps(pc.to_dict()))
    assert doc["kind"] == "particles"
    assert np.array_equal(ParticleCloud.from_dict(doc).centres, pc.centres)


def test_save_is_atomic_and_load_refuses_bad_files(tmp_path: Path) -> None:
    pc = small()
    pc.params["bad"] = object()
    with pytest.raises(TypeError, match="params"):
        pc.save(tmp_path / "x.npz")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match="npz or .json"):
        small().save(tmp_path / "x.txt")
    with pytest.raises(FileNotFoundError):
        load_particles(tmp_path / "missing.npz")
    (tmp_path / "empty.json").write_text("")
    with pytest.raises(ValueError, match="empty"):
        load_particles(tmp_path / "empty.json")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="junk.npz"):
        load_particles(tmp_path / "junk.npz")
    (tmp_path / "foreign.json").write_text(json.dumps({"format": "cumuli.cloud"}))
    with pytest.raises(ValueError, match="format"):
        load_particles(tmp_path / "foreign.json")
    doc = small().to_dict() | {"format": "cumuli.particles", "version": 1, "tau": [1, 2, 300]}
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="tau"):
        load_particles(tmp_path / "bad.json")


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"centres": np.zeros((0, 3))}, ValueError, "centres"),
        ({"centres": [[0, 0, float("nan")]]}, ValueError, "centres"),
        ({"centres": np.zeros((2, 2))}, ValueError, "centres"),
        ({"centres": [["a", "b", "c"]]}, TypeError, "centres"),
        ({"radii": [1.0, -1.0]}, ValueError, "radii"),
        ({"radii": [1.0]}, ValueError, "radii"),
        ({"tau": 0.0}, ValueError, "tau"),
        ({"tau": 101.0}, ValueError, "tau"),
        ({"albedo": [0.5, 1.5]}, ValueError, "albedo"),
        ({"albedo": "x"}, TypeError, "albedo"),
        ({"params": [1]}, TypeError, "params"),
    ],
)
def test_particle_cloud_bad_input(kwargs: dict, error: type, match: str) -> None:
    args = {"centres": np.zeros((2, 3)), "radii": 1.0} | kwargs
    with pytest.raises(error, match=match):
        ParticleCloud(**args)


def test_fill_is_seeded_thread_independent_and_inside_the_union() -> None:
    cloud = cu.gaussian_cumulus(seed=4)
    a = particle_fill(cloud, 3000, seed=11, threads=1)
    for threads in (2, 0):
        b = particle_fill(cloud, 3000, seed=11, threads=threads)
        assert np.array_equal(a.centres, b.centres) and np.array_equal(a.radii, b.radii)
    assert not np.array_equal(particle_fill(cloud, 3000, seed=12).centres, a.centres)
    # Inside the union (|q| ≤ 1 in some primitive).
    q = (a.centres[:, None, :] - cloud.centres[None]) / cloud.radii[None]
    assert (np.linalg.norm(q, axis=2).min(axis=1) <= 1 + 1e-5).all()
    rbar = cloud.radii.mean()
    assert a.radii.min() >= 0.15 * rbar * (1 - 1e-5) and a.radii.max() <= 0.3 * rbar * (1 + 1e-5)
    assert (a.tau == 8.0).all() and a.params["generator"] == "particle_fill"


def test_fill_is_uniform_over_overlapping_primitives() -> None:
    """Two overlapping unit spheres: the lens they share gets its volume share, not double."""
    cloud = cu.Cloud(np.array([(0.0, 0, 0), (1.0, 0, 0)]), np.array([1.0, 1.0]))
    pc = particle_fill(cloud, 40000, seed=3)
    in_both = (np.linalg.norm(pc.centres, axis=1) <= 1) & (
        np.linalg.norm(pc.centres - [1, 0, 0], axis=1) <= 1
    )
    lens = 5 * math.pi / 12  # volume of the intersection of two unit spheres 1 apart
    union = 2 * 4 / 3 * math.pi - lens
    assert in_both.mean() == pytest.approx(lens / union, abs=0.01)


def test_fill_with_noise_modulates_tau() -> None:
    cloud = cu.gaussian_cumulus(seed=4)
    pc = particle_fill(cloud, 2000, noise=cu.Noise(7), tau=8.0, seed=1, radius=(0.5, 0.8))
    assert pc.tau.mean() == pytest.approx(8.0, rel=1e-3)
    assert pc.tau.std() > 0.5 and pc.tau.min() > 0 and pc.tau.max() <= 100
    assert (pc.radii >= 0.5).all() and (pc.radii <= 0.8).all()
    assert pc.params["noise"] == {"seed": 7, "size": 64, "version": 2}  # the default, recorded


def test_particle_cumulus() -> None:
    pc = particle_cumulus((10, 2, 0), n_particles=200, seed=5)
    assert pc.n == 200 and pc.params["generator"] == "particle_cumulus"
    assert np.array_equal(pc.centres, particle_cumulus((10, 2, 0), 200, seed=5).centres)
    assert pc.sphere[0][0] == pytest.approx(10, abs=4)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"n": 0}, "n"),
        ({"n": MAX_PARTICLES + 1}, "n"),
        ({"radius": (1.0,)}, "radius"),
        ({"radius": (2.0, 1.0)}, "radius"),
        ({"tau": 0.0}, "tau"),
        ({"albedo": 2.0}, "albedo"),
        ({"seed": -1}, "seed"),
        ({"frequency": 0.0}, "frequency"),
        ({"threads": -2}, "threads"),
    ],
)
def test_fill_bad_input(kwargs: dict, match: str) -> None:
    with pytest.raises((ValueError, TypeError), match=match):
        particle_fill(cu.gaussian_cumulus(seed=1), **kwargs)
    with pytest.raises(TypeError, match="cloud"):
        particle_fill("cloud")  # type: ignore[arg-type]


def test_to_volume_optical_depth_through_a_particle() -> None:
    """τ_k = β_k s_k √(2π): integrating the volume through the centre gives τ (spec §2.2)."""
    pc = ParticleCloud([(0.0, 0.0, 0.0)], 3.0, 5.0)
    n = 121
    vol, (lo, hi) = pc.to_volume((n, n, n), ((-4.5, -4.5, -4.5), (4.5, 4.5, 4.5)))
    assert vol.shape == (n, n, n)
    dz = 9.0 / n
    column = vol[:, n // 2, n // 2].astype(np.float64).sum() * dz
    assert column == pytest.approx(5.0, rel=2e-3)  # blob cut at 4σ: 6e−5 of it missing
    assert vol.max() == pytest.approx(5.0 / (1.0 * math.sqrt(2 * math.pi)), rel=1e-3)
    assert np.array_equal(vol, pc.to_volume((n, n, n), (lo, hi), threads=1)[0])


def test_from_volume_importance_samples_density() -> None:
    vol = np.zeros((4, 4, 8), np.float32)
    vol[:, :, 6:] = 3.0  # only x ∈ [6, 8) voxels hold density
    vol[:, :, 4] = 1.0
    box = ((0, 0, 0), (8, 4, 4))
    pc = ParticleCloud.from_volume(vol, box, n=4000, seed=2)
    x = pc.centres[:, 0]
    assert ((x >= 4) & (x < 5)).mean() == pytest.approx(1 / 7, abs=0.02)
    assert ((x >= 6) & (x < 8)).mean() == pytest.approx(6 / 7, abs=0.02)
    assert pc.tau[x >= 6].mean() > 2 * pc.tau[x < 5].mean()
    assert pc.radii[0] == pytest.approx((8 * 4 * 4 / 4000) ** (1 / 3), rel=1e-5)
    again = ParticleCloud.from_volume(vol, box, n=4000, seed=2, threads=1)
    assert np.array_equal(again.centres, pc.centres)
    with pytest.raises(ValueError, match="positive"):
        ParticleCloud.from_volume(np.zeros((2, 2, 2)), box)
    with pytest.raises(ValueError, match="non-negative"):
        ParticleCloud.from_volume(-np.ones((2, 2, 2)), box)
    with pytest.raises(ValueError, match="density"):
        ParticleCloud.from_volume(np.ones((2, 2)), box)
