"""Noise lattice and fBm (eq. 1): numpy reference, reproducibility, statistics, bad input.

The reference is written for the table (version 1, the paper's noise), which the tests that
compare with it pin; version 2's own reference (its biased blend) is in test_noise_versions.py."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cumuli as cu
from cumuli.noise import MAX_SIZE

F32 = np.float32


# --- a deliberately slow reference of DESIGN §4, written step by step in float32 -----------------


def ref_lattice(lattice: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Trilinear lookup at texel coordinates u (N, 3), GL texel-centre convention, REPEAT."""
    size = lattice.shape[0]
    x = u.astype(F32) - F32(0.5)
    f = np.floor(x)
    w = x - f
    i0 = np.mod(f.astype(np.int64), size)
    i1 = np.mod(i0 + 1, size)

    def t(ix: np.ndarray, iy: np.ndarray, iz: np.ndarray) -> np.ndarray:
        return lattice[iz, iy, ix]  # [z, y, x]

    wx, wy, wz = w[:, 0], w[:, 1], w[:, 2]
    x0, y0, z0 = i0.T
    x1, y1, z1 = i1.T
    c00 = t(x0, y0, z0) + wx * (t(x1, y0, z0) - t(x0, y0, z0))
    c10 = t(x0, y1, z0) + wx * (t(x1, y1, z0) - t(x0, y1, z0))
    c01 = t(x0, y0, z1) + wx * (t(x1, y0, z1) - t(x0, y0, z1))
    c11 = t(x0, y1, z1) + wx * (t(x1, y1, z1) - t(x0, y1, z1))
    c0 = c00 + wy * (c10 - c00)
    c1 = c01 + wy * (c11 - c01)
    return c0 + wz * (c1 - c0)


def ref_fbm(
    noise: cu.Noise,
    points: np.ndarray,
    octaves: int = 5,
    gain: float = 0.5,
    lacunarity: float = 2.0,
    frequency: float = 1.0,
) -> np.ndarray:
    """eq. (1): Σ_{i=1..n} wⁱ · lattice(sⁱ · f · p)."""
    lattice = np.asarray(noise.lattice)
    pts = np.asarray(points, dtype=F32)
    total = np.zeros(len(pts), dtype=F32)
    amplitude, scale = F32(1.0), F32(frequency)
    for _ in range(octaves):
        amplitude = amplitude * F32(gain)
        scale = scale * F32(lacunarity)
        total = total + amplitude * ref_lattice(lattice, pts * scale)
    return total


def _points(n: int, lo: float, hi: float, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(lo, hi, (n, 3)).astype(F32)


def _edge_points() -> np.ndarray:
    """Integers, half-integers (texel centres), negatives and values straddling the wrap."""
    grid = np.arange(-130, 131, dtype=F32) / F32(4.0)
    rng = np.random.default_rng(5)
    return rng.choice(grid, size=(2000, 3)).astype(F32)


# --- eq. (1) against the reference ----------------------------------------------------------------


@pytest.mark.parametrize("size", [64, 2, 17, 128])
@pytest.mark.parametrize(
    "params",
    [
        {},
        {"octaves": 1, "gain": 1.0, "lacunarity": 1.0, "frequency": 1.0},
        {"octaves": 8, "gain": 0.6, "lacunarity": 1.7, "frequency": 0.37},
        {"octaves": 3, "gain": 0.45, "lacunarity": 2.3, "frequency": 3.0},
    ],
)
def test_fbm_matches_numpy_reference(size: int, params: dict) -> None:
    noise = cu.Noise(seed=11, size=size, version=1)
    pts = np.concatenate([_points(3000, -50, 50), _points(300, -2, 2, 1), _edge_points()])
    got = noise.fbm(pts, **params)
    want = ref_fbm(noise, pts, **params)
    assert got.dtype == np.float32 and got.shape == (len(pts),)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)
    # With -ffp-contract=off the C++ performs exactly the reference's float32 operations.
    np.testing.assert_array_equal(got, want)


def test_fbm_large_coordinates_take_the_exact_general_path() -> None:
    # Beyond 2^22 texels the fast path's int truncation is not used; the value must still be the
    # reference's (floor is the value itself, the index wraps modulo size).
    noise = cu.Noise(seed=4, size=64, version=1)
    pts = np.array(
        [[3.0e7, -5.0e6, 1.25], [-1.0e9, 2.0e8, 7.5e6], [4194304.0, -4194304.5, 0.0]], dtype=F32
    )
    np.testing.assert_array_equal(noise.fbm(pts), ref_fbm(noise, pts))
    odd = cu.Noise(seed=4, size=17, version=1)
    np.testing.assert_array_equal(odd.fbm(pts), ref_fbm(odd, pts))


def test_value_does_not_depend_on_the_other_points_in_the_call() -> None:
    # fbm_many works on blocks and switches to the general path for a whole block when one point
    # is huge; each point's value must not change with its neighbours.
    noise = cu.Noise(seed=8)
    pts = _points(300, -40, 40, 3)
    pts[100] = (1.0e8, 2.0, 3.0)
    together = noise.fbm(pts)
    alone = np.array([noise.fbm(pts[i : i + 1])[0] for i in range(len(pts))], dtype=F32)
    np.testing.assert_array_equal(together, alone)


def test_fbm_is_periodic_with_the_lattice() -> None:
    # REPEAT wrapping: a shift of size/(f·s^i) world units for every octave is a whole period.
    noise = cu.Noise(seed=2, size=16)
    pts = _points(500, -10, 10)
    shifted = pts + F32(8.0)  # 8 · 2 = 16 texels for octave 1, and a multiple for the others
    np.testing.assert_allclose(noise.fbm(shifted), noise.fbm(pts), atol=2e-6)


def test_lattice_lookup_at_texel_centres_returns_texels() -> None:
    noise = cu.Noise(seed=3, size=8)
    z, y, x = 5, 2, 7
    centre = np.array([[x + 0.5, y + 0.5, z + 0.5]], dtype=F32)
    # One octave with w = s = f = 1 is a plain lattice lookup.
    value = noise.fbm(centre, octaves=1, gain=1.0, lacunarity=1.0, frequency=1.0)
    assert value[0] == noise.lattice[z, y, x]


def test_fbm_grid_is_indexed_z_y_x_at_voxel_centres() -> None:
    noise = cu.Noise(seed=6)
    vol = noise.fbm_grid((3, 4, 5), (0.0, 1.0, 2.0), (5.0, 9.0, 8.0))
    assert vol.shape == (3, 4, 5) and vol.dtype == np.float32
    # Voxel (z=2, y=1, x=3): centre x = 0 + 3.5·1, y = 1 + 1.5·2, z = 2 + 2.5·2.
    p = np.array([[3.5, 4.0, 7.0]], dtype=F32)
    assert vol[2, 1, 3] == noise.fbm(p)[0]


# --- reproducibility ---------------------------------------------------------------------------


def test_same_seed_same_lattice_and_values_different_seed_differs() -> None:
    a, b, c = cu.Noise(seed=42), cu.Noise(seed=42), cu.Noise(seed=43)
    np.testing.assert_array_equal(a.lattice, b.lattice)
    pts = _points(1000, -20, 20)
    np.testing.assert_array_equal(a.fbm(pts), b.fbm(pts))
    assert not np.array_equal(a.lattice, c.lattice)
    assert np.mean(a.fbm(pts) != c.fbm(pts)) > 0.99
    assert a == b and a != c and hash(a) == hash(b)


def test_seed_gives_the_documented_lattice() -> None:
    # SplitMix64 → 24-bit uniforms: pin the first values so a change of generator is noticed.
    lattice = cu.Noise(seed=0, size=2, version=1).lattice.ravel()
    state = 0
    want = []
    for _ in range(8):
        state = (state + 0x9E3779B97F4A7C15) % 2**64
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) % 2**64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) % 2**64
        z ^= z >> 31
        want.append((z >> 40) / 16777216.0)
    np.testing.assert_array_equal(lattice, np.array(want, dtype=F32))


@pytest.mark.parametrize("size", [64, 17])
def test_thread_count_does_not_change_a_bit(size: int) -> None:
    noise = cu.Noise(seed=9, size=size)
    pts = _points(20011, -60, 60)  # not a multiple of the block or chunk sizes
    ref = noise.fbm(pts, threads=1)
    for threads in (2, 3, 7, 0):
        got = noise.fbm(pts, threads=threads)
        assert got.tobytes() == ref.tobytes(), f"threads={threads}"


# --- statistics -----------------------------------------------------------------------------------


def _skewness(a: np.ndarray) -> float:
    a = a.astype(np.float64)
    return float(((a - a.mean()) ** 3).mean() / a.std() ** 3)


def _excess_kurtosis(a: np.ndarray) -> float:
    a = a.astype(np.float64)
    return float(((a - a.mean()) ** 4).mean() / a.std() ** 4 - 3.0)


def test_lattice_is_uniform_on_unit_interval() -> None:
    lat = np.asarray(cu.Noise(seed=1).lattice, dtype=np.float64)
    assert lat.min() >= 0.0 and lat.max() < 1.0
    # 262144 samples: the mean's standard error is 0.289/512 ≈ 6e-4, so 3e-3 is ~5 sigma.
    assert abs(lat.mean() - 0.5) < 3e-3
    assert abs(lat.std() - 1.0 / np.sqrt(12.0)) < 2e-3
    hist, _ = np.histogram(lat, bins=10, range=(0, 1))
    np.testing.assert_allclose(hist / lat.size, 0.1, atol=3e-3)


def test_fbm_is_narrower_and_gaussian_like() -> None:
    noise = cu.Noise(seed=1)
    values = noise.fbm(_points(100_000, 0, 64, 2)).astype(np.float64)
    lattice = np.asarray(noise.lattice, dtype=np.float64)
    # Mean of eq. (1) with n=5, w=1/2: 0.5 · Σ wⁱ = 0.484375.
    assert abs(values.mean() - 0.484375) < 5e-3
    # Averaging octaves narrows the distribution well below the lattice's 0.289 ...
    assert values.std() < 0.5 * lattice.std()
    assert 0.07 < values.std() < 0.11
    # ... symmetric and much closer to a Gaussian (excess kurtosis 0) than the uniform (−1.2).
    assert abs(_skewness(values)) < 0.05
    assert -0.6 < _excess_kurtosis(values) < 0.3
    assert _excess_kurtosis(lattice) < -1.1


# --- bad and unusual input ------------------------------------------------------------------------


def test_float64_and_integer_points_are_converted() -> None:
    noise = cu.Noise(seed=3)
    pts64 = np.random.default_rng(0).uniform(-9, 9, (100, 3))
    np.testing.assert_array_equal(noise.fbm(pts64), noise.fbm(pts64.astype(F32)))
    ints = np.arange(30).reshape(10, 3)
    np.testing.assert_array_equal(noise.fbm(ints), noise.fbm(ints.astype(F32)))
    assert noise.fbm([[0.1, 0.2, 0.3]]).shape == (1,)


def test_non_contiguous_and_read_only_points() -> None:
    noise = cu.Noise(seed=3)
    base = np.random.default_rng(1).uniform(-9, 9, (200, 6)).astype(F32)
    strided = base[::2, 1:4]  # non-contiguous rows and columns
    assert not strided.flags.c_contiguous
    np.testing.assert_array_equal(noise.fbm(strided), noise.fbm(np.ascontiguousarray(strided)))
    fortran = np.asfortranarray(base[:, :3])
    np.testing.assert_array_equal(noise.fbm(fortran), noise.fbm(np.ascontiguousarray(fortran)))
    frozen = base[:, :3].copy()
    before = frozen.copy()
    frozen.setflags(write=False)
    np.testing.assert_array_equal(noise.fbm(frozen), noise.fbm(before))
    np.testing.assert_array_equal(frozen, before)


def test_empty_points() -> None:
    out = cu.Noise(seed=3).fbm(np.zeros((0, 3), dtype=F32))
    assert out.shape == (0,) and out.dtype == np.float32


@pytest.mark.parametrize(
    "points",
    [np.zeros((5, 2)), np.zeros(6), np.zeros((2, 3, 1)), np.zeros((4, 4))],
)
def test_wrong_point_shapes_are_rejected(points: np.ndarray) -> None:
    with pytest.raises(ValueError, match="points"):
        cu.Noise(seed=1).fbm(points)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_points_are_rejected(bad: float) -> None:
    pts = np.zeros((4, 3), dtype=F32)
    pts[2, 1] = bad
    with pytest.raises(ValueError, match="points"):
        cu.Noise(seed=1).fbm(pts)


def test_non_numeric_points_are_rejected() -> None:
    with pytest.raises(TypeError, match="points"):
        cu.Noise(seed=1).fbm(np.array([["a", "b", "c"]]))
    with pytest.raises(TypeError, match="points"):
        cu.Noise(seed=1).fbm([[1, 2, 3], [4, 5]])


@pytest.mark.parametrize("size", [1, 0, -3, MAX_SIZE + 1, 4096])
def test_bad_sizes_are_rejected_before_allocating(size: int) -> None:
    # 4096³ floats would be 256 GiB: a MemoryError (or a hang) here would mean no early check.
    with pytest.raises(ValueError, match="size"):
        cu.Noise(seed=1, size=size)


@pytest.mark.parametrize("kwargs", [{"size": 64.0}, {"size": True}, {"seed": 1.5}, {"seed": "1"}])
def test_non_integer_arguments_are_rejected(kwargs: dict) -> None:
    with pytest.raises(TypeError):
        cu.Noise(**{"seed": 1, **kwargs})


@pytest.mark.parametrize("seed", [-1, 2**64])
def test_out_of_range_seeds_are_rejected(seed: int) -> None:
    with pytest.raises(ValueError, match="seed"):
        cu.Noise(seed=seed)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"octaves": 0}, "octaves"),
        ({"octaves": -2}, "octaves"),
        ({"octaves": 17}, "octaves"),
        ({"gain": 0.0}, "gain"),
        ({"gain": float("nan")}, "gain"),
        ({"lacunarity": -2.0}, "lacunarity"),
        ({"frequency": float("inf")}, "frequency"),
        ({"threads": -1}, "threads"),
    ],
)
def test_bad_fbm_parameters_are_rejected(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        cu.Noise(seed=1).fbm(np.zeros((3, 3), dtype=F32), **kwargs)


def test_octave_limits_are_accepted() -> None:
    noise = cu.Noise(seed=1, version=1)
    pts = _points(50, -3, 3)
    for octaves in (1, 16):
        np.testing.assert_array_equal(
            noise.fbm(pts, octaves=octaves), ref_fbm(noise, pts, octaves=octaves)
        )


def test_lattice_view_is_read_only() -> None:
    noise = cu.Noise(seed=1, size=4)
    with pytest.raises(ValueError):
        noise.lattice[0, 0, 0] = 1.0


@settings(max_examples=60, deadline=None)
@given(
    coords=st.lists(
        st.tuples(*[st.floats(-1e4, 1e4, allow_nan=False, width=32)] * 3), min_size=1, max_size=80
    ),
    octaves=st.integers(1, 16),
    gain=st.floats(0.05, 1.5),
    lacunarity=st.floats(0.25, 3.0),
    frequency=st.floats(0.01, 10.0),
    size=st.sampled_from([2, 8, 13, 64]),
)
def test_fbm_matches_reference_for_any_parameters(
    coords: list, octaves: int, gain: float, lacunarity: float, frequency: float, size: int
) -> None:
    noise = _noise(size)
    pts = np.array(coords, dtype=F32)
    want = ref_fbm(noise, pts, octaves, gain, lacunarity, frequency)
    got = noise.fbm(pts, octaves, gain, lacunarity, frequency)
    np.testing.assert_array_equal(got, want)


_NOISES: dict[int, cu.Noise] = {}


def _noise(size: int) -> cu.Noise:
    if size not in _NOISES:
        _NOISES[size] = cu.Noise(seed=99, size=size, version=1)
    return _NOISES[size]
