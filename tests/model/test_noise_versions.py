"""Noise versions: version 2 (hash) the default and checked against a numpy reference of its
hash, version 1 (table, the paper's) unchanged bit for bit, on every SIMD path and thread count,
in scene files (old files without a version read as 1), and bad versions."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.noise import (
    DEFAULT_VERSION,
    NOISE_VERSIONS,
    PAPER_VERSION,
    set_simd_level,
    simd_levels,
)

F32 = np.float32
U32 = np.uint32
#: A scene file as cumuli wrote them before noise versions existed (scene-file version 1, clouds
#: without a kind, ``"noise": {"seed", "size"}``).
OLD_SCENE = Path(__file__).resolve().parents[1] / "data" / "scene_before_noise_versions.json"

# Digests of the table version's values for seed 7 (lattice, and fBm at `_golden_points()` with
# default and with octaves=8, gain=0.6, lacunarity=1.7, frequency=0.37), computed with the core
# as it was before noise versions existed: version 1 must keep giving these bits.
OLD_LATTICE = "a143d5cb908f04832b625114946ca4f3e41ededcbbf66ed50ba7eb4611a6300f"
OLD_FBM = "084116da4346aede0c2fb15fba9bcb30c14d27984d0b5932c5c775546385359c"
OLD_FBM8 = "c48b1cbc3ac7b7c6558e304f06299c6ac59ef8ea8a4f0c002ed6d6fe69eaa92b"


def _golden_points() -> np.ndarray:
    return np.random.default_rng(2024).uniform(-50, 50, (4096, 3)).astype(F32)


def _digest(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()


def splitmix_lattice(seed: int, size: int) -> np.ndarray:
    """Version 1's lattice written independently: SplitMix64's stream, top 24 bits / 2²⁴."""
    n = size**3
    mask = (1 << 64) - 1
    state = (seed + 0x9E3779B97F4A7C15 * np.arange(1, n + 1, dtype=object)) & mask
    out = np.empty(n, dtype=F32)
    for i, z in enumerate(state):
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        out[i] = F32((z ^ (z >> 31)) >> 40) / F32(16777216.0)
    return out.reshape(size, size, size)


def hash_biased(key: int, size: int) -> np.ndarray:
    """Version 2's lattice plus 1, written independently in numpy: (index + key) times m1, fold
    the high half down, times m2, the top 23 bits as the mantissa of a float in [1, 2)."""
    i = np.arange(size**3, dtype=U32)
    with np.errstate(over="ignore"):
        h = (i + U32(key)) * U32(0x21F0AAAD)
        h ^= h >> U32(16)
        h = h * U32(0x735A2D97)
    return ((h >> U32(9)) | U32(0x3F800000)).view(F32).reshape(size, size, size)


def ref_fbm_biased(biased: np.ndarray, pts: np.ndarray, octaves: int = 5) -> np.ndarray:
    """Version 2's fBm step by step in float32: each octave blends the biased values (GL
    texel-centre trilinear, REPEAT) and takes 1 off the blend."""
    size = biased.shape[0]
    total = np.zeros(len(pts), dtype=F32)
    amp, scale = F32(1.0), F32(1.0)
    for _ in range(octaves):
        amp, scale = amp * F32(0.5), scale * F32(2.0)
        x = pts * scale - F32(0.5)
        f = np.floor(x)
        w = x - f
        i0 = np.mod(f.astype(np.int64), size)
        i1 = np.mod(i0 + 1, size)
        (x0, y0, z0), (x1, y1, z1) = i0.T, i1.T
        wx, wy, wz = w.T

        def t(ix: np.ndarray, iy: np.ndarray, iz: np.ndarray) -> np.ndarray:
            return biased[iz, iy, ix]

        c00 = t(x0, y0, z0) + wx * (t(x1, y0, z0) - t(x0, y0, z0))
        c10 = t(x0, y1, z0) + wx * (t(x1, y1, z0) - t(x0, y1, z0))
        c01 = t(x0, y0, z1) + wx * (t(x1, y0, z1) - t(x0, y0, z1))
        c11 = t(x0, y1, z1) + wx * (t(x1, y1, z1) - t(x0, y1, z1))
        c0 = c00 + wy * (c10 - c00)
        c1 = c01 + wy * (c11 - c01)
        total = total + amp * ((c0 + wz * (c1 - c0)) - F32(1.0))
    return total


def test_version_1_is_the_old_table_bit_for_bit() -> None:
    n = cu.Noise(seed=7, version=PAPER_VERSION)
    assert n.version == PAPER_VERSION == 1 and cu.Noise(seed=7) != n
    assert _digest(n.lattice) == OLD_LATTICE
    pts = _golden_points()
    assert _digest(n.fbm(pts)) == OLD_FBM
    kw = {"octaves": 8, "gain": 0.6, "lacunarity": 1.7, "frequency": 0.37}
    assert _digest(n.fbm(pts, **kw)) == OLD_FBM8


def test_the_default_is_the_hash_everywhere() -> None:
    assert DEFAULT_VERSION == 2
    hashed = cu.Noise(seed=7, version=2)
    assert cu.Noise(seed=7) == hashed and cu.Noise(7, 32).version == 2
    np.testing.assert_array_equal(cu.Noise(seed=7).lattice, hashed.lattice)
    assert cu._core.Noise(7).version == 2  # the core's default agrees
    assert cu.Scene().noise == cu.Noise(seed=0, version=2)


def test_version_1_lattice_is_the_seed_stream() -> None:
    lattice = cu.Noise(seed=3, size=8, version=1).lattice
    np.testing.assert_array_equal(lattice, splitmix_lattice(3, 8))


@pytest.mark.parametrize("size", [64, 16, 17])
def test_version_2_lattice_is_the_hash(size: int) -> None:
    n = cu.Noise(seed=11, size=size, version=2)
    assert n.version == 2 and 0 <= n.key < 2**32
    biased = hash_biased(n.key, size)
    np.testing.assert_array_equal(n.lattice, biased - F32(1.0))
    assert n != cu.Noise(seed=11, size=size, version=1)
    pts = np.random.default_rng(size).uniform(-40, 40, (3000, 3)).astype(F32)
    np.testing.assert_array_equal(n.fbm(pts), ref_fbm_biased(biased, pts))


def test_version_2_keys_differ_by_seed_and_values_are_uniform() -> None:
    a, b = cu.Noise(seed=1, version=2), cu.Noise(seed=2, version=2)
    assert a.key != b.key
    lat = a.lattice.ravel().astype(np.float64)
    assert lat.min() >= 0.0 and lat.max() < 1.0
    counts = np.histogram(lat, bins=32, range=(0.0, 1.0))[0]
    expected = lat.size / 32
    chi2 = float(((counts - expected) ** 2 / expected).sum())
    assert chi2 < 70.0  # 31 degrees of freedom: p ≈ 1e-4
    # Neighbouring texels along each axis are uncorrelated (|r| ≪ 4 standard errors).
    v = a.lattice.astype(np.float64)
    for axis in range(3):
        r = np.corrcoef(v.ravel(), np.roll(v, 1, axis=axis).ravel())[0, 1]
        assert abs(r) < 4 / np.sqrt(v.size)


@pytest.mark.parametrize("version", [1, 2])
def test_every_simd_path_and_thread_count_agree(version: int) -> None:
    n = cu.Noise(seed=5, version=version)
    rng = np.random.default_rng(9)
    pts = np.concatenate([rng.uniform(-80, 80, (5000, 3)), rng.uniform(-1, 1, (37, 3))]).astype(F32)
    # The scalar reference: fBm point by point from the lattice, as the slow path computes it.
    results = []
    try:
        for level in simd_levels():
            set_simd_level(level)
            for threads in (1, 2, 3):
                results.append(n.fbm(pts, octaves=6, threads=threads))
    finally:
        set_simd_level("auto")
    for r in results[1:]:
        np.testing.assert_array_equal(r, results[0])


def test_version_2_changes_the_values_not_their_range() -> None:
    pts = _golden_points()
    v1 = cu.Noise(seed=7, version=1).fbm(pts)
    v2 = cu.Noise(seed=7, version=2).fbm(pts)
    assert not np.array_equal(v1, v2)
    assert abs(float(v1.mean()) - float(v2.mean())) < 0.02
    assert 0.0 <= float(v2.min()) and float(v2.max()) < 1.0


@pytest.mark.parametrize("version", [0, 3, -1, 99])
def test_bad_version_is_refused(version: int) -> None:
    with pytest.raises(ValueError, match="version"):
        cu.Noise(seed=1, version=version)
    with pytest.raises(ValueError, match="version"):
        cu._core.Noise(1, 64, version)  # the core refuses it too


@pytest.mark.parametrize("version", ["2", 2.0, True, None])
def test_version_of_the_wrong_type_is_refused(version: object) -> None:
    with pytest.raises(TypeError, match="version"):
        cu.Noise(seed=1, version=version)  # type: ignore[arg-type]


def test_versions_are_named() -> None:
    assert NOISE_VERSIONS == {1: "table", 2: "hash"}
    assert repr(cu.Noise(seed=4, size=8, version=2)) == "Noise(seed=4, size=8, version=2)"


def test_scene_files_keep_the_version_and_old_files_read_as_table() -> None:
    from dataclasses import replace

    from cumuli.demo import cumulus_scene

    scene = replace(cumulus_scene(), noise=cu.Noise(seed=3, version=2))
    data = scene.to_dict()
    assert data["noise"] == {"seed": 3, "size": 64, "version": 2}
    assert cu.Scene.from_dict(json.loads(json.dumps(data))).noise == cu.Noise(seed=3, version=2)
    del data["noise"]["version"]  # a file written before noise versions existed
    assert cu.Scene.from_dict(data).noise.version == 1
    data["noise"]["version"] = 7
    with pytest.raises(ValueError, match="version"):
        cu.Scene.from_dict(data)


def test_an_old_scene_file_reads_as_the_table_and_keeps_it() -> None:
    raw = json.loads(OLD_SCENE.read_text(encoding="utf-8"))
    assert "version" not in raw["noise"]  # the committed file predates noise versions
    scene = cu.load_scene(OLD_SCENE)
    assert scene.noise == cu.Noise(seed=7, size=64, version=1)
    # Saved again, the file now says so: it does not turn into the default on the next load.
    assert scene.to_dict()["noise"] == {"seed": 7, "size": 64, "version": 1}
    camera = scene.camera
    assert camera is not None
    table = cu.render_cpu(scene, camera, 24, 16)
    hashed = cu.render_cpu(scene.replace(noise=cu.Noise(seed=7, version=2)), camera, 24, 16)
    assert table[..., 3].max() > 0.1
    assert not np.array_equal(table, hashed)  # reading it as the default would change the image


def test_a_fresh_scene_file_records_the_default_version(tmp_path: Path) -> None:
    scene = cu.Scene([cu.gaussian_cumulus(n=6, seed=1)])
    assert scene.noise.version == DEFAULT_VERSION == 2
    path = scene.save(tmp_path / "fresh.json")
    assert json.loads(path.read_text(encoding="utf-8"))["noise"]["version"] == 2
    assert cu.load_scene(path).noise == cu.Noise(seed=0, version=2)


def test_the_paper_figures_pin_the_paper_noise() -> None:
    from cumuli.demo import benchmark_scenes, cumulus_scene, default_scene, sunset_scene

    paper = cu.RenderSettings(lighting="paper")
    assert cumulus_scene(settings=paper).noise == cu.Noise(seed=7, version=PAPER_VERSION)
    assert default_scene(settings=paper).noise == cu.Noise(seed=7, version=PAPER_VERSION)
    figures = benchmark_scenes(("cumulus", "metaball", "lsystem"))
    assert {s.noise for s in figures.values()} == {cu.Noise(seed=7, version=PAPER_VERSION)}
    # cumuli's own scenes, in the physical mode, take the default.
    assert cumulus_scene().noise == default_scene().noise == cu.Noise(seed=7)
    assert sunset_scene().noise.version == DEFAULT_VERSION
