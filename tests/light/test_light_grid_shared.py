"""Light grids that share their samples: ``light_grid(method="shared")``.

Each sun-parallel line of a grid sheared along the sun is marched once (NDT's union march, step
Δ' = λ/round(λ/Δ) with λ the distance between voxel layers along the line) and read back at every
voxel layer; a voxel blends the four lines around it. Tested against a slow numpy reference of
exactly that definition, and against the per-voxel NDT grid within the bounds that
docs/clouds-2018.md states.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_light_grid import (
    C_DEFAULT,
    _analytic,
    _candidates,
    _density,
    _grid_box,
    _local,
    _rot,
    spheres,
)

import cumuli as cu
from cumuli.light.ndt import DEFAULT_EXTINCTION

# The stated difference between "shared" and the per-voxel "ndt" grid on the default cumulus
# (docs/clouds-2018.md, "Light precompute"): mean |ΔL| and max |ΔL| over the voxels.
BOUND_MEAN = 0.02
BOUND_MAX = 0.3
# With the sun along a grid axis every line runs through voxel centres: only the step and the
# anchoring of the samples differ.
AXIS_BOUND_MEAN = 0.005
AXIS_BOUND_MAX = 0.1


def reference_shared(
    cloud: cu.Cloud,
    sun_dir,
    noise,
    res,
    step: float = 0.1,
    extinction: float = DEFAULT_EXTINCTION,
    solid_angle: float = 1e-4,
    constant: float | None = None,
) -> np.ndarray:
    """The shared-sample light grid, step by step in float64 geometry (see ndt.hpp)."""
    res = (res, res, res) if isinstance(res, int) else tuple(res)
    d = np.asarray(sun_dir, dtype=np.float64)
    d = d / np.linalg.norm(d)
    lo, hi = _grid_box(cloud, res)
    cell = (hi - lo) / np.array(res)
    C = 0.5 * solid_angle / (4 * math.pi)
    a = 0
    for k in (1, 2):
        if abs(d[k]) / cell[k] > abs(d[a]) / cell[a]:
            a = k
    b, c = (a + 1) % 3, (a + 2) % 3
    ra, rb, rc = res[a], res[b], res[c]
    sb = d[b] / d[a] * cell[a] / cell[b]
    sc = d[c] / d[a] * cell[a] / cell[c]
    toward = 1 if d[a] > 0 else -1
    lam = cell[a] / abs(d[a])
    per_layer = max(1, round(lam / step))
    sub = lam / per_layer
    js = np.arange(ra)
    lob, hib = np.floor(-sb * js).astype(int), np.floor(rb - 1 - sb * js).astype(int) + 1
    loc, hic = np.floor(-sc * js).astype(int), np.floor(rc - 1 - sc * js).astype(int) + 1
    S: dict[tuple[int, int, int], float] = {}
    for lb in range(lob.min(), hib.max() + 1):
        for lc in range(loc.min(), hic.max() + 1):
            served = [j for j in js if lob[j] <= lb <= hib[j] and loc[j] <= lc <= hic[j]]
            if not served:
                continue
            j_lo, j_hi = min(served), max(served)
            j_start = j_lo if toward > 0 else j_hi
            origin = np.empty(3)
            origin[a] = lo[a] + (j_start + 0.5) * cell[a]
            origin[b] = lo[b] + (lb + sb * j_start + 0.5) * cell[b]
            origin[c] = lo[c] + (lc + sc * j_start + 0.5) * cell[c]
            cand = _candidates(cloud, origin, d)
            samples = []  # (mid, length, far end, primitive)
            i = 0
            while i < len(cand):
                first, end = i, cand[i][1]
                i += 1
                while i < len(cand) and cand[i][0] <= end:
                    end = max(end, cand[i][1])
                    i += 1
                chain, A, B = cand[first:i], cand[first][0], end
                k = math.floor(A / sub)
                while (k + 1) * sub <= A:
                    k += 1
                while k * sub < B:
                    t0, t1 = max(k * sub, A), min((k + 1) * sub, B)
                    k += 1
                    if not t1 > t0:
                        continue
                    s = 0.5 * (t0 + t1)
                    cover = [ch for ch in chain if ch[0] <= s <= ch[1]]
                    if not cover:
                        ended = [ch for ch in chain if ch[1] < s]
                        j = ended[-1][2] if ended else chain[0][2]
                    elif len(cover) == 1 or cloud.model == "metaball":
                        j = cover[0][2]
                    else:
                        qs = [np.linalg.norm(_local(cloud, ch[2], origin + s * d)) for ch in cover]
                        j = cover[int(np.argmin(qs))][2]
                    samples.append((s, t1 - t0, t1, j))
            pts = np.array([origin + s * d for s, *_ in samples]).reshape(-1, 3)
            if constant is not None:
                rhos = np.full(len(samples), constant)
            elif samples:
                rhos = noise.fbm(pts.astype(np.float32)).astype(np.float64)
            else:
                rhos = np.zeros(0)
            value, n = 1.0, len(samples)
            for j in range(j_hi, j_lo - 1, -1) if toward > 0 else range(j_lo, j_hi + 1):
                t_layer = abs(j - j_start) * per_layer * sub
                while n > 0 and samples[n - 1][2] > t_layer:
                    n -= 1
                    _, length, _, prim = samples[n]
                    rho = _density(cloud, prim, pts[n], rhos[n])
                    if rho > 0:
                        value = C * length / step + math.exp(-extinction * rho * length) * value
                S[(lb, lc, j)] = value
    out = np.zeros(res[::-1])
    for j in range(ra):
        for ib in range(rb):
            for ic in range(rc):
                ub, uc = ib - sb * j, ic - sc * j
                kb, kc = math.floor(ub), math.floor(uc)
                wb, wc = ub - kb, uc - kc
                s00, s01 = S[(kb, kc, j)], S[(kb, kc + 1, j)]
                s10, s11 = S[(kb + 1, kc, j)], S[(kb + 1, kc + 1, j)]
                value = (1 - wb) * ((1 - wc) * s00 + wc * s01) + wb * ((1 - wc) * s10 + wc * s11)
                idx = [0, 0, 0]
                idx[a], idx[b], idx[c] = j, ib, ic
                out[idx[2], idx[1], idx[0]] = value
    return out


@pytest.fixture(scope="module")
def noise() -> cu.Noise:
    return cu.Noise(seed=3, size=16)


OVERLAP = dict(centres=[[0, 0, 0], [1.2, 0.5, 0], [-0.5, 1.0, 0.8]], radii=[1.0, 0.8, 0.9])


@pytest.mark.parametrize(
    "sun",
    [(0.3, 0.8, 0.2), (-0.7, 0.2, 0.3), (0.1, -0.4, -0.9), (0.0, 1.0, 0.0), (0.5, -0.5, 0.5)],
)
def test_matches_the_numpy_reference(noise, sun):
    cloud = spheres(**OVERLAP)
    res = (6, 5, 4)
    grid = cu.light_grid(cloud, sun, noise, resolution=res, method="shared")
    ref = reference_shared(cloud, sun, noise, res)
    np.testing.assert_allclose(grid, ref, atol=2e-5, rtol=0)
    assert grid.min() < 0.95


def test_rotated_ellipsoids_and_metaballs_match_the_reference(noise):
    rots = np.stack([_rot((0, 0, 1), 35), _rot((1, 1, 0), 60)]).astype(np.float32)
    cloud = cu.Cloud(
        centres=np.array([[0, 0, 0], [1.0, 0.6, 0.2]], np.float32),
        radii=np.array([[2.0, 0.6, 0.8], [1.2, 0.5, 0.7]], np.float32),
        rotations=rots,
    )
    sun = (0.2, 0.9, -0.3)
    grid = cu.light_grid(cloud, sun, noise, resolution=5, method="shared")
    np.testing.assert_allclose(grid, reference_shared(cloud, sun, noise, 5), atol=2e-5, rtol=0)
    balls = spheres([[0, 0, 0], [1.5, 0.3, 0], [0.5, 1.2, 0.4]], [0.8, 0.7, 0.6], model="metaball")
    grid = cu.light_grid(balls, sun, noise, resolution=4, method="shared")
    np.testing.assert_allclose(grid, reference_shared(balls, sun, noise, 4), atol=2e-5, rtol=0)
    assert grid.min() < 0.95


def test_within_the_stated_bound_of_the_per_voxel_grid():
    cloud = cu.gaussian_cumulus(seed=0)
    noise = cu.Noise(seed=7)
    for sun, mean_bound, max_bound in (
        ((0.3, 0.8, 0.2), BOUND_MEAN, BOUND_MAX),
        ((-0.6, -0.3, 0.7), BOUND_MEAN, BOUND_MAX),
        ((0.0, 1.0, 0.0), AXIS_BOUND_MEAN, AXIS_BOUND_MAX),
    ):
        ndt, s_ndt = cu.light_grid(cloud, sun, noise, resolution=20, return_stats=True)
        shared, s_sh = cu.light_grid(
            cloud, sun, noise, resolution=20, method="shared", return_stats=True
        )
        diff = np.abs(shared - ndt)
        assert diff.mean() <= mean_bound, (sun, diff.mean())
        assert diff.max() <= max_bound, (sun, diff.max())
        assert abs(float((shared - ndt).mean())) < 0.2 * mean_bound  # no bias
        # Each sample is marched once for every voxel behind it.
        assert s_sh.samples_total * 4 < s_ndt.samples_total
        assert s_sh.samples.shape == ndt.shape and s_sh.samples.max() > 0


def test_constant_density_sphere_is_beer_lambert_with_the_sun_on_an_axis():
    """Lines through voxel centres, constant density: transmittance is exactly exp(−σ·chord);
    the scattering term is the per-voxel one up to the step Δ' ≠ Δ."""
    r, rho, A, step = 2.0, 0.3, 1.5, 0.1
    cloud = spheres([[0, 0, 0]], [r], kappa=0.0)
    R = 7
    kw = dict(resolution=R, density_override=rho, extinction=A, step=step)
    grid = cu.light_grid(cloud, (0, 1, 0), None, method="shared", **kw)
    lo, hi = (np.array(v) for v in grid.box)
    cell = (hi - lo) / R
    checked = 0
    for z in range(R):
        for y in range(R):
            for x in range(R):
                v = lo + (np.array([x, y, z]) + 0.5) * cell
                h2 = r * r - v[0] ** 2 - v[2] ** 2
                if abs(h2) < 1e-3:
                    continue
                if h2 < 0:
                    assert grid[z, y, x] == 1.0
                    continue
                top, bottom = math.sqrt(h2), -math.sqrt(h2)
                chord = max(0.0, top - max(v[1], bottom))
                expected = _analytic(chord, A * rho, step, C_DEFAULT)
                assert grid[z, y, x] == pytest.approx(expected, abs=C_DEFAULT * 3, rel=1e-5)
                checked += chord > 0
    assert checked > 10
    # No sun-parallel line ever gets brighter going away from the sun.
    assert (np.diff(grid, axis=1) >= -1e-7).all()


def test_identical_for_any_thread_count_and_simd_level(noise):
    from cumuli.noise import set_simd_level, simd_levels

    cloud = spheres(**OVERLAP)
    kw = dict(resolution=(11, 7, 5), method="shared")
    grids = [cu.light_grid(cloud, (0.3, 0.8, 0.2), noise, threads=t, **kw) for t in (1, 2, 3)]
    try:
        for level in simd_levels():
            set_simd_level(level)
            grids.append(cu.light_grid(cloud, (0.3, 0.8, 0.2), noise, **kw))
    finally:
        set_simd_level("auto")
    for g in grids[1:]:
        np.testing.assert_array_equal(g, grids[0])


def test_rays_missing_everything_and_records(noise):
    cloud = spheres([[0, 0, 0], [4, 0, 0]], [1.0, 1.0])
    grid, st = cu.light_grid(
        cloud, (0, 1, 0), noise, resolution=9, method="shared", return_stats=True
    )
    # The column between the spheres sees no primitive: exactly I₀ = 1 and no samples.
    assert (grid[:, :, 4] == 1.0).all() and (st.samples[:, :, 4] == 0).all()
    assert st.method == "shared" and st.samples_total > 0 and st.seconds >= 0
    assert grid.record.params.method == "shared"
    with pytest.raises(ValueError, match="method"):
        cu.light_grid(cloud, (0, 1, 0), noise, method="sheared")
