"""`Noise.fbm_grid`: the same values as fBm at its voxel centres, in memory proportional to the
output (filled slab by slab), and its bad input."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import cumuli as cu
import cumuli.noise as cnoise

PARAMS = [{}, {"octaves": 8, "gain": 0.6, "lacunarity": 1.7, "frequency": 0.37}]


def _reference_grid(noise: cu.Noise, shape, box_min, box_max, **kwargs) -> np.ndarray:
    """The straightforward way: a float64 meshgrid of the voxel centres through `Noise.fbm`."""
    d, h, w = shape
    lo, hi = np.array(box_min, np.float64), np.array(box_max, np.float64)
    step = (hi - lo) / np.array([w, h, d])
    xs = lo[0] + (np.arange(w) + 0.5) * step[0]
    ys = lo[1] + (np.arange(h) + 0.5) * step[1]
    zs = lo[2] + (np.arange(d) + 0.5) * step[2]
    z, y, x = np.meshgrid(zs, ys, xs, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    return noise.fbm(pts, **kwargs).reshape(d, h, w)


@pytest.mark.parametrize("params", PARAMS)
@pytest.mark.parametrize("slab", [1, 7 * 33 * 65, 3 * 33 * 65 + 5, cnoise.GRID_SLAB_VOXELS])
def test_grid_is_bit_identical_to_fbm_at_voxel_centres(
    monkeypatch: pytest.MonkeyPatch, slab: int, params: dict
) -> None:
    # Slabs of one plane, of several planes with a remainder, and the whole volume at once.
    monkeypatch.setattr(cnoise, "GRID_SLAB_VOXELS", slab)
    noise = cu.Noise(seed=12)
    shape, lo, hi = (17, 33, 65), (-3.3, 1e-3, 7.0), (2.2, 9.1, 8.5)
    got = noise.fbm_grid(shape, lo, hi, **params)
    want = _reference_grid(noise, shape, lo, hi, **params)
    assert got.shape == shape and got.dtype == np.float32 and got.flags.c_contiguous
    assert got.tobytes() == want.tobytes()


def test_grid_does_not_depend_on_the_thread_count() -> None:
    noise = cu.Noise(seed=3, size=17)
    box = ((9, 40, 31), (-5, -5, -5), (5, 6, 7))
    one = noise.fbm_grid(*box, threads=1)
    for threads in (2, 3, 0):
        assert noise.fbm_grid(*box, threads=threads).tobytes() == one.tobytes(), threads


def test_grid_memory_is_proportional_to_the_output(monkeypatch: pytest.MonkeyPatch) -> None:
    # 1 M voxels (4 MiB out). Building every point first, as float64 meshgrids and a stack, took
    # 16x the output (64 MiB); slabs of 64 Ki voxels need the output plus < 1 MiB.
    monkeypatch.setattr(cnoise, "GRID_SLAB_VOXELS", 1 << 16)
    noise = cu.Noise(seed=1)
    tracemalloc.start()
    try:
        vol = noise.fbm_grid((64, 128, 128), (0, 0, 0), (10, 10, 10))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert vol.nbytes == 4 << 20
    assert peak < 1.5 * vol.nbytes, f"peak {peak / 2**20:.1f} MiB for a 4 MiB volume"
    assert np.isfinite(vol).all() and vol.std() > 0.01


def test_default_slab_bounds_the_point_buffer() -> None:
    # One slab's float32 points are at most 48 MiB, and a whole plane always fits (2048²).
    assert cnoise.GRID_SLAB_VOXELS * 3 * 4 <= 48 << 20
    assert cnoise.GRID_SLAB_VOXELS >= cnoise.MAX_GRID_EDGE**2


# --- bad input ------------------------------------------------------------------------------------

BOX = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))


@pytest.mark.parametrize(
    ("shape", "exc"),
    [
        (0, ValueError),
        (-4, ValueError),
        ((4, 0, 4), ValueError),
        ((4, 4, -1), ValueError),
        ((4, 4), TypeError),
        ((4, 4, 4, 4), TypeError),
        ((4.0, 4, 4), TypeError),
        (4.5, TypeError),
        (True, TypeError),
        ((4, True, 4), TypeError),
        ("abc", TypeError),
        (None, TypeError),
        (cnoise.MAX_GRID_EDGE + 1, ValueError),
        ((1, 1, 10**9), ValueError),
    ],
)
def test_bad_shapes_are_rejected(shape: object, exc: type) -> None:
    with pytest.raises(exc, match="shape"):
        cu.Noise(seed=1, size=8).fbm_grid(shape, *BOX)


@pytest.mark.parametrize("shape", [2048, (2048, 2048, 65), (1024, 1024, 257)])
def test_absurd_sizes_are_refused_before_allocating(
    shape: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Each edge is allowed, the voxel count is not (8 Gi voxels would be 32 GiB out). Nothing
    # may be allocated first: np.empty / the core failing here means the check came too late.
    def no_alloc(*args: object, **kwargs: object) -> None:
        raise AssertionError("allocated before checking the size")

    monkeypatch.setattr(cnoise.np, "empty", no_alloc)
    noise = cu.Noise(seed=1, size=8)
    monkeypatch.setattr(noise, "_core", None)  # any use of the core would raise AttributeError
    with pytest.raises(ValueError, match="voxels"):
        noise.fbm_grid(shape, *BOX)


@pytest.mark.parametrize(
    ("box_min", "box_max", "name"),
    [
        ((0, 0, 0), (1, 1, 0), "box_max must be greater"),
        ((0, 0, 0), (1, -1, 1), "box_max must be greater"),
        ((2, 0, 0), (1, 1, 1), "box_max must be greater"),
        ((1, 1, 1), (1, 1, 1), "box_max must be greater"),
        ((float("nan"), 0, 0), (1, 1, 1), "box_min"),
        ((0, 0, 0), (1, float("nan"), 1), "box_max"),
        ((float("-inf"), 0, 0), (1, 1, 1), "box_min"),
        ((0, 0, 0), (1, 1, float("inf")), "box_max"),
        ((-1e300, 0, 0), (1e300, 1, 1), "float32 range"),
        ((0, 0, 0), (1e39, 1, 1), "float32 range"),
        ((0, 0), (1, 1, 1), "box_min"),
        ((0, 0, 0), "abc", "box_max"),
    ],
)
def test_bad_boxes_are_rejected(box_min: object, box_max: object, name: str) -> None:
    with pytest.raises((ValueError, TypeError), match=name):
        cu.Noise(seed=1, size=8).fbm_grid(4, box_min, box_max)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"octaves": 0}, "octaves"),
        ({"octaves": 17}, "octaves"),
        ({"gain": -1.0}, "gain"),
        ({"lacunarity": float("nan")}, "lacunarity"),
        ({"frequency": 0.0}, "frequency"),
        ({"threads": -1}, "threads"),
    ],
)
def test_bad_fbm_parameters_are_rejected(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        cu.Noise(seed=1, size=8).fbm_grid(4, *BOX, **kwargs)
