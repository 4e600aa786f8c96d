"""fBm of finite but huge input is refused, not returned as NaN.

The core computes the lattice coordinates ``p · frequency · lacunarityⁱ`` and the weights
``gainⁱ`` in float32: past 3.4e38 they overflow to inf and the lookup gives NaN. Points of
magnitude 3e38 are finite (and accepted by the array checks), so this needs its own bound.
"""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
import cumuli.gl as cgl
from cumuli.noise import MAX_FBM_MAGNITUDE

F32 = np.float32


@pytest.mark.parametrize(
    ("points", "kwargs"),
    [
        ([[3e38, 0.0, 0.0]], {}),
        ([[0.0, -1e37, 0.0]], {}),  # x 2⁵ for the fifth octave
        ([[0.0, 0.0, 1e30]], {"frequency": 1e8}),
        ([[1e20, 0.0, 0.0]], {"lacunarity": 30.0, "octaves": 16}),
    ],
)
def test_points_whose_lattice_coordinates_overflow_are_refused(points: list, kwargs: dict) -> None:
    noise = cu.Noise(seed=1, size=8)
    pts = np.array(points, dtype=F32)
    with pytest.raises(ValueError, match="points.*float32 overflow"):
        noise.fbm(pts, **kwargs)


def test_large_points_within_the_bound_stay_finite() -> None:
    assert MAX_FBM_MAGNITUDE < float(np.finfo(F32).max) / 10  # room for float32 rounding
    noise = cu.Noise(seed=1, size=8)
    # The largest octave scale is 2⁵: 3e35 · 32 ≈ 1e37, at the bound.
    pts = np.array([[3e35, -3e35, 1e30], [1e20, 0.0, -5.0], [0.0, 0.0, 0.0]], dtype=F32)
    values = noise.fbm(pts)
    assert np.isfinite(values).all()
    assert ((values >= 0) & (values < 1)).all()
    # What the bound prevents: the same call just past it used to give NaN.
    with pytest.raises(ValueError, match="points"):
        noise.fbm(pts * F32(100.0))


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"gain": 1e3, "octaves": 16}, "gain"),
        ({"gain": 1e38, "octaves": 1}, "gain"),
        ({"lacunarity": 1e3, "octaves": 16}, "lacunarity"),
        ({"frequency": 1e38}, "frequency"),
        ({"frequency": 1e30, "lacunarity": 1e2, "octaves": 5}, "lacunarity"),
    ],
)
def test_parameters_whose_scales_overflow_are_refused(kwargs: dict, name: str) -> None:
    noise = cu.Noise(seed=1, size=8)
    with pytest.raises(ValueError, match=name):
        noise.fbm(np.zeros((2, 3), dtype=F32), **kwargs)
    with pytest.raises(ValueError, match=name):
        noise.fbm_grid(2, (0, 0, 0), (1, 1, 1), **kwargs)


def test_small_lacunarity_and_gain_are_fine() -> None:
    # Scales and weights that shrink cannot overflow (they may underflow to 0, which is finite).
    noise = cu.Noise(seed=1, size=8)
    pts = np.array([[1e36, 2.0, 3.0]], dtype=F32)
    got = noise.fbm(pts, octaves=16, gain=1e-3, lacunarity=1e-3, frequency=1e-2)
    assert np.isfinite(got).all()


def test_grid_box_whose_lattice_coordinates_overflow_is_refused() -> None:
    noise = cu.Noise(seed=1, size=8)
    with pytest.raises(ValueError, match="box_min/box_max"):
        noise.fbm_grid(2, (0.0, 0.0, 0.0), (1e38, 1.0, 1.0))
    vol = noise.fbm_grid(2, (0.0, 0.0, 0.0), (1e35, 1.0, 1.0))
    assert np.isfinite(vol).all()


@pytest.mark.gl
def test_glsl_fbm_refuses_the_same_points(gl_context: cgl.GLContext) -> None:
    noise = cu.Noise(seed=1, size=8)
    with pytest.raises(ValueError, match="points.*float32 overflow"):
        cgl.fbm(noise, np.array([[3e38, 0, 0]], dtype=F32), context=gl_context)
    with pytest.raises(ValueError, match="lacunarity"):
        cgl.fbm(noise, np.zeros((1, 3), F32), lacunarity=1e3, octaves=16, context=gl_context)


@pytest.mark.parametrize("count", [1, 255, 256, 257, 3000])
@pytest.mark.parametrize("threads", [1, 2])
def test_the_core_scan_reports_the_largest_magnitude_and_non_finite_points(
    count: int, threads: int
) -> None:
    """``Noise.fbm`` takes its argument check from the pass that evaluates the points: the
    largest |coordinate| must be exact and one non-finite value anywhere (first, last, a block
    boundary) must be seen, on any thread count."""
    noise = cu.Noise(seed=3)
    rng = np.random.default_rng(count)
    pts = rng.uniform(-40.0, 40.0, (count, 3)).astype(np.float32)
    pts[count // 2, 2] = -1234.5  # the largest magnitude, negative
    out, biggest = noise._core.fbm_scan(pts, 5, 0.5, 2.0, 1.0, threads)
    assert biggest == 1234.5
    assert np.array_equal(out, noise.fbm(pts, threads=1))
    for row in sorted({0, count - 1, min(255, count - 1), min(256, count - 1)}):
        for bad in (np.nan, np.inf, -np.inf):
            q = pts.copy()
            q[row, row % 3] = bad
            _, reported = noise._core.fbm_scan(q, 5, 0.5, 2.0, 1.0, threads)
            assert np.isnan(reported), (row, bad)
            with pytest.raises(ValueError, match="NaN or infinite"):
                noise.fbm(q, threads=threads)
