"""The physical mode's sky visibility by marching each voxel's rays (the default sky rays).

``_core.sky_visibility(..., method="march")`` marches, from every voxel with medium within one
voxel, the sphere quadrature's directions to the lattice's box, in steps of ``step`` voxels
(the smallest voxel side) from the voxel's centre, the last step weighing only its part inside
the box, summing the trilinear extinction (clamped to the edges) until the optical depth passes
6. The core takes runs of eight neighbours along x, one per SIMD lane: their rays are one ray
moved by whole voxels, so the lanes share every sample's position in its cell and read their
corners with plain vector loads. These tests check it against a numpy twin of that march, on
awkward lattices (odd sizes, stretched voxels, medium on the box's faces and in its last row,
rows whose length is not a multiple of eight), and its contract: the same bits at every SIMD
level and thread count.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from cumuli import _core

F = np.float32
ORDER, N_THETA = 3, 3
CUT = 6.0  # the march's optical-depth cut


def _trilinear_clamped(ext: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``ext`` ([z][y][x]) at voxel coordinates ``u`` (N, 3) as (x, y, z), centres at i + ½,
    clamped to the edges."""
    d, h, w = ext.shape
    s = u - 0.5
    i0 = np.floor(s).astype(int)
    f = s - i0
    out = np.zeros(len(u))
    for corner in itertools.product((0, 1), repeat=3):
        idx = [np.clip(i0[:, a] + corner[a], 0, (w, h, d)[a] - 1) for a in range(3)]
        wgt = np.prod([f[:, a] if corner[a] else 1 - f[:, a] for a in range(3)], axis=0)
        out += wgt * ext[idx[2], idx[1], idx[0]]
    return out


def _near_medium(ext: np.ndarray) -> np.ndarray:
    """Voxels with medium in their 3×3×3 neighbourhood."""
    near = ext > 0
    for axis in range(3):
        grown = near.copy()
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[axis], hi[axis] = slice(1, None), slice(None, -1)
        grown[tuple(lo)] |= near[tuple(hi)]
        grown[tuple(hi)] |= near[tuple(lo)]
        near = grown
    return near


def _march_twin(ext: np.ndarray, lo, hi, step: float = 1.0) -> np.ndarray:
    """The visibility's SH moments (D, H, W, order²) by the march, written plainly."""
    d, h, w = ext.shape
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    vs = (hi - lo) / (w, h, d)
    dirs, weights = _core.sphere_quadrature(N_THETA)
    basis = _core.sh_eval(ORDER, dirs).astype(float)
    out = np.zeros((d, h, w, ORDER * ORDER))
    out[..., 0] = float(F(math.sqrt(4 * math.pi)))  # the open sky (float32) where none is near
    near = _near_medium(ext)
    # The ray's length and its number of segments in float32, as the core takes them: where a
    # length is close to a whole number of steps the two precisions could part by a segment.
    lo32, hi32 = np.asarray(lo, F), np.asarray(hi, F)
    vs32 = (hi32 - lo32) / np.array((w, h, d), F)
    dt32 = F(step) * vs32.min()
    for z, y, x in zip(*np.nonzero(near), strict=True):
        p32 = lo32 + (np.array([x, y, z], F) + F(0.5)) * vs32
        vis = np.zeros(ORDER * ORDER)
        for k, dk in enumerate(dirs.astype(float)):
            with np.errstate(divide="ignore"):
                inv = F(1) / dirs[k]
            face = np.where(inv >= 0, hi32, lo32)
            length = float(((face - p32) * inv).min())
            n = max(1, math.ceil(F(length) / dt32))
            # Steps of dt from the voxel's centre, the last one weighing only its part in the box.
            weight = np.full(n, float(dt32))
            weight[-1] = length - (n - 1) * float(dt32)
            u = np.array([x, y, z]) + 0.5 + ((np.arange(n) + 0.5) * float(dt32))[:, None] * dk / vs
            parts = _trilinear_clamped(ext, u) * weight
            before = np.concatenate([[0.0], np.cumsum(parts)[:-1]])
            tau = parts[before <= CUT].sum()  # a sample is taken while τ so far ≤ the cut
            vis += math.exp(-tau) * weights[k] * basis[k]
        out[z, y, x] = vis
    return out


def _blob(shape: tuple[int, int, int], seed: int, density: float) -> np.ndarray:
    """A lumpy medium filling part of a lattice, with some on the box's faces."""
    rng = np.random.default_rng(seed)
    d, h, w = shape
    zz, yy, xx = np.meshgrid(
        np.linspace(-1, 1, d), np.linspace(-1, 1, h), np.linspace(-1, 1, w), indexing="ij"
    )
    r = np.sqrt(xx**2 + 1.3 * yy**2 + zz**2)
    ext = density * np.clip(1.0 - r, 0.0, None) * rng.uniform(0.3, 1.7, shape)
    ext[0, 0, :] = density * 0.5  # medium along an edge of the box: rays start on its faces
    ext[-1, -1, -2:] = density * 0.7  # and in the lattice's last voxels: runs past its end
    return ext.astype(F)


CASES = {
    # shape (D, H, W), box, density per unit. Box sizes with no simple ratios to the voxels, so
    # that no ray's length is a whole number of steps (where float32 and float64 could take
    # different segment counts).
    "odd cube": ((7, 5, 9), ((0.13, 0.02, -0.3), (9.07, 4.99, 6.61)), 1.5),
    "stretched voxels": ((6, 11, 4), ((-2.13, 0.07, 1.31), (2.29, 3.41, 4.17)), 4.0),
    "optically thick": ((8, 8, 8), ((0.01, 0.03, 0.05), (2.02, 2.07, 2.11)), 40.0),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_march_is_its_numpy_twin(case: str) -> None:
    """Every voxel's moments match a plain numpy march of the same rays (float32 positions in
    the core, float64 here: agreement to 1e-4 of the open sky's √4π)."""
    shape, (lo, hi), density = CASES[case]
    ext = _blob(shape, 3, density)
    got = _core.sky_visibility(ext, lo, hi, ORDER, N_THETA, 1.0, 2)
    want = _march_twin(ext, lo, hi)
    assert shape[2] % 8 != 0 or case == "optically thick"  # runs that end past their row
    assert np.abs(got - want).max() < 1e-4 * math.sqrt(4 * math.pi)
    # The cut matters in the thick case, and the medium darkens the sky there.
    if case == "optically thick":
        assert got[4, 4, 4, 0] < 0.05 * math.sqrt(4 * math.pi)


def test_a_finer_step_is_the_numpy_twin_too() -> None:
    """Half-voxel segments (more samples per ray than lanes hold in one pass) agree too."""
    shape, (lo, hi), density = CASES["odd cube"]
    ext = _blob(shape, 5, density)
    got = _core.sky_visibility(ext, lo, hi, ORDER, N_THETA, 0.5, 1)
    assert np.abs(got - _march_twin(ext, lo, hi, 0.5)).max() < 1e-4 * math.sqrt(4 * math.pi)


def test_every_simd_level_and_thread_count_gives_the_same_bits() -> None:
    """The lanes' AVX2 kernel and the portable one perform the same float operations in the
    same order, and each voxel's sums run over the directions in their order."""
    shape, (lo, hi), density = CASES["stretched voxels"]
    ext = _blob(shape, 7, density)
    results = []
    try:
        for level in _core.simd_levels():
            _core.set_simd_level(level)
            for threads in (1, 2, 3):
                results.append(_core.sky_visibility(ext, lo, hi, ORDER, N_THETA, 1.0, threads))
    finally:
        _core.set_simd_level("auto")
    assert len(results) >= 3
    for r in results[1:]:
        assert np.array_equal(r, results[0])


def test_a_single_voxel_of_medium_is_seen_from_its_neighbours_only() -> None:
    """Voxels two or more away from any medium get the open sky exactly; the medium's own
    voxel and its neighbours see less of it."""
    ext = np.zeros((6, 6, 6), F)
    ext[2, 3, 1] = 5.0
    box = (0.01, 0.02, 0.03), (6.07, 6.11, 5.93)
    vis = _core.sky_visibility(ext, *box, ORDER, N_THETA, 1.0, 2)
    near = _near_medium(ext)
    open_sky = float(F(math.sqrt(4 * math.pi)))  # stored as a float32
    assert np.all(vis[~near][:, 0] == open_sky)
    assert np.all(vis[~near][:, 1:] == 0.0)
    assert vis[2, 3, 1, 0] < open_sky * 0.95
    assert np.abs(vis - _march_twin(ext, *box)).max() < 1e-4 * open_sky
