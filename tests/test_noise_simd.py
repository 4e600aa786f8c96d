"""SIMD fBm (issue 14, item 1): every dispatch path gives the scalar path's bits.

The AVX2 and AVX-512 kernels perform the scalar kernel's float32 operations in the same order
(no FMA), so they must agree bit for bit on random points, on lattice boundaries, on negative
and huge coordinates (which take the general per-point path), at every tail length and thread
count, and for lattice sizes that take the 16-bit multiply-add index (≤ 180) or the 32-bit one.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

import cumuli as cu
from cumuli.noise import SIMD_LEVELS, set_simd_level, simd_level, simd_levels

F32 = np.float32
LEVELS = simd_levels()
WIDE = [lvl for lvl in LEVELS if lvl != "scalar"]


@pytest.fixture(autouse=True)
def _restore_level() -> Iterator[None]:
    yield
    set_simd_level("auto")


def _at(level: str, fn: Callable[[], Any]) -> Any:
    """``fn()`` evaluated with the core at SIMD ``level``."""
    set_simd_level(level)
    try:
        return fn()
    finally:
        set_simd_level("auto")


def _edge_points() -> np.ndarray:
    """Lattice texel centres and faces at the octave scales, both signs, wrap boundaries."""
    rng = np.random.default_rng(3)
    base = np.arange(-260, 261, dtype=F32) / F32(4.0)  # quarter-texel steps across two wraps
    near = np.nextafter(base, F32(np.inf)), np.nextafter(base, F32(-np.inf))
    values = np.concatenate([base, *near, np.array([0.0, -0.0, 63.5, 64.0, -64.0], F32)])
    return rng.choice(values, size=(6000, 3)).astype(F32)


def _huge_points() -> np.ndarray:
    """Beyond 2²² texels at some octave (general path) mixed with ordinary points."""
    rng = np.random.default_rng(4)
    pts = rng.uniform(-40, 40, (500, 3)).astype(F32)
    pts[::7, 0] = F32(3.0e7)
    pts[3::11, 1] = F32(-1.5e9)
    pts[5::13, 2] = F32(131072.25)  # 2¹⁷ · 2⁵ = 2²²: at the fast path's limit in octave 5
    return pts


def test_scalar_is_always_available_and_the_default_is_the_widest() -> None:
    assert LEVELS[0] == "scalar"
    assert set(LEVELS) <= set(SIMD_LEVELS)
    assert simd_level() == LEVELS[-1]


@pytest.mark.parametrize("level", WIDE)
@pytest.mark.parametrize("size", [64, 2, 128, 256, 17])
def test_wide_paths_equal_the_scalar_path(level: str, size: int) -> None:
    noise = cu.Noise(seed=21, size=size)
    rng = np.random.default_rng(size)
    pts = np.concatenate(
        [
            rng.uniform(-60, 60, (20_000, 3)).astype(F32),
            rng.uniform(-1e4, 1e4, (3000, 3)).astype(F32),  # far from the origin, still fast
            _edge_points(),
            _huge_points(),
        ]
    )
    for params in ({}, {"octaves": 8, "gain": 0.6, "lacunarity": 1.7, "frequency": 0.37}):
        want = _at("scalar", lambda p=params: noise.fbm(pts, **p))
        got = _at(level, lambda p=params: noise.fbm(pts, **p))
        np.testing.assert_array_equal(got, want)
        assert np.isfinite(got).all()


@pytest.mark.parametrize("level", LEVELS)
def test_every_tail_length_and_thread_count(level: str) -> None:
    """Counts that leave partial registers (1..40 points) and chunks split across threads."""
    noise = cu.Noise(seed=5)
    pts = np.random.default_rng(9).uniform(-30, 30, (4099, 3)).astype(F32)
    ref = _at("scalar", lambda: noise.fbm(pts, threads=1))
    set_simd_level(level)
    for n in range(1, 41):
        np.testing.assert_array_equal(noise.fbm(pts[:n], threads=1), ref[:n])
    for threads in (1, 2, 3, 0):
        assert noise.fbm(pts, threads=threads).tobytes() == ref.tobytes()


@pytest.mark.parametrize("level", WIDE)
def test_grid_and_light_pass_do_not_depend_on_the_level(level: str) -> None:
    noise = cu.Noise(seed=7)
    grid = _at("scalar", lambda: noise.fbm_grid(24, (-5, -3, -7), (9, 4, 6)))
    np.testing.assert_array_equal(
        _at(level, lambda: noise.fbm_grid(24, (-5, -3, -7), (9, 4, 6))), grid
    )
    cloud = cu.gaussian_cumulus(n=8, seed=2)
    kw = {"resolution": 10}
    light = _at("scalar", lambda: cu.light_grid(cloud, (0.3, 0.8, 0.2), noise, **kw))
    np.testing.assert_array_equal(
        _at(level, lambda: cu.light_grid(cloud, (0.3, 0.8, 0.2), noise, **kw)), light
    )


def test_bad_levels_are_refused() -> None:
    with pytest.raises(ValueError, match="level"):
        set_simd_level("sse9")
    with pytest.raises(ValueError, match="level"):
        set_simd_level(2)  # type: ignore[arg-type]
    missing = [lvl for lvl in SIMD_LEVELS if lvl not in LEVELS]
    for lvl in missing:  # only on a CPU without AVX2 / AVX-512
        with pytest.raises(ValueError, match="not supported"):
            set_simd_level(lvl)
    assert simd_level() == LEVELS[-1]  # a refused level changes nothing
