"""Light pass: the NDT / naive light grid against a slow numpy reference of eqs. (3)–(7),
analytic Beer–Lambert cases, method and thread invariants, and bad input."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

import cumuli as cu
from cumuli.light.ndt import DEFAULT_EXTINCTION, MAX_RESOLUTION

C_DEFAULT = 0.5 * 1e-4 / (4 * math.pi)


# --------------------------------------------------------------------------------------------
# Slow numpy reference (float64 geometry; fBm through noise.fbm at float32 points).
# --------------------------------------------------------------------------------------------
def _grid_box(cloud: cu.Cloud, res: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    scale = math.sqrt(cloud.n) if cloud.model == "metaball" else 1.0
    radii = cloud.radii.astype(np.float64) * scale
    rot = cloud.rotations.astype(np.float64)
    half = np.sqrt(np.einsum("nkj,nj->nk", rot**2, radii**2))
    lo = (cloud.centres - half).min(axis=0)
    hi = (cloud.centres + half).max(axis=0)
    h = (hi - lo) / (np.array(res) - 1)
    return lo - h / 2, hi + h / 2


def _local(cloud: cu.Cloud, j: int, p: np.ndarray, scale: float = 1.0) -> np.ndarray:
    rot = cloud.rotations[j].astype(np.float64)
    return (rot.T @ (p - cloud.centres[j])) / (cloud.radii[j] * scale)


def _candidates(cloud: cu.Cloud, v: np.ndarray, d: np.ndarray) -> list[tuple[float, float, int]]:
    scale = math.sqrt(cloud.n) if cloud.model == "metaball" else 1.0
    out = []
    for j in range(cloud.n):
        o = _local(cloud, j, v, scale)
        rot = cloud.rotations[j].astype(np.float64)
        dl = (rot.T @ d) / (cloud.radii[j] * scale)
        a, b, c = dl @ dl, o @ dl, o @ o - 1.0
        disc = b * b - a * c
        if disc < 0:
            continue
        t0, t1 = (-b - math.sqrt(disc)) / a, (-b + math.sqrt(disc)) / a
        t0 = max(t0, 0.0)
        if t1 > t0:
            out.append((t0, t1, j))
    return sorted(out, key=lambda c: c[0])  # stable, like the insertion sort


def _density(cloud, j, p, rho):
    """eq. (2) gating for spheroids, eqs. (19–21) for metaballs; rho = fBm (or constant) at p."""
    if cloud.model == "metaball":
        field = sum(1.0 / (_local(cloud, i, p) @ _local(cloud, i, p)) for i in range(cloud.n))
        return rho * cloud.mean_r2 * cloud.phi if field >= 1.0 else 0.0
    q = float(np.linalg.norm(_local(cloud, j, p)))
    if q > 1.0:
        return 0.0
    gamma = math.exp(-q / ((1 - cloud.kappa) + 2 * cloud.kappa * rho))
    return rho if rho < gamma else 0.0


def reference_light(
    cloud,
    sun_dir,
    noise,
    res,
    method="ndt",
    step=0.1,
    extinction=DEFAULT_EXTINCTION,
    solid_angle=1e-4,
    constant=None,
):
    res = (res, res, res) if isinstance(res, int) else tuple(res)
    d = np.asarray(sun_dir, dtype=np.float64)
    d = d / np.linalg.norm(d)
    lo, hi = _grid_box(cloud, res)
    cell = (hi - lo) / np.array(res)
    C = 0.5 * solid_angle / (4 * math.pi)
    out = np.zeros(res[::-1])
    count = np.zeros(res[::-1], dtype=np.int64)
    for z in range(res[2]):
        for y in range(res[1]):
            for x in range(res[0]):
                v = lo + (np.array([x, y, z]) + 0.5) * cell
                cand = _candidates(cloud, v, d)
                # (a, b, attribution function) pieces to march
                pieces = []
                if method == "naive":
                    pieces = [(a, b, [(a, b, j)]) for a, b, j in cand]
                else:
                    i = 0
                    while i < len(cand):
                        first, end = i, cand[i][1]
                        i += 1
                        while i < len(cand) and cand[i][0] <= end:
                            end = max(end, cand[i][1])
                            i += 1
                        pieces.append((cand[first][0], end, cand[first:i]))
                segs = []  # (s, length, primitive)
                for a, b, chain in pieces:
                    k = 0
                    while a + k * step < b:
                        t0, t1 = a + k * step, min(a + (k + 1) * step, b)
                        s = 0.5 * (t0 + t1)
                        cover = [c for c in chain if c[0] <= s <= c[1]]
                        if len(cover) <= 1:
                            j = cover[0][2] if cover else chain[-1][2]
                        else:
                            qs = [np.linalg.norm(_local(cloud, c[2], v + s * d)) for c in cover]
                            j = cover[int(np.argmin(qs))][2]
                        segs.append((s, t1 - t0, j))
                        k += 1
                count[z, y, x] = len(segs)
                if not segs:
                    out[z, y, x] = 1.0
                    continue
                pts = np.array([v + s * d for s, _, _ in segs])
                rhos = (
                    np.full(len(segs), constant)
                    if constant is not None
                    else noise.fbm(pts.astype(np.float32)).astype(np.float64)
                )
                T, S = 1.0, 0.0
                for (_s, length, j), p, rho in zip(segs, pts, rhos, strict=True):
                    sigma = extinction * _density(cloud, j, p, rho)
                    if sigma > 0:
                        S += C * (length / step) * T
                        T *= math.exp(-sigma * length)
                out[z, y, x] = S + T
    return out, count, (lo, hi)


def spheres(centres, radii, **kw) -> cu.Cloud:
    return cu.Cloud(
        centres=np.asarray(centres, dtype=np.float32), radii=np.asarray(radii, np.float32), **kw
    )


@pytest.fixture(scope="module")
def noise() -> cu.Noise:
    return cu.Noise(seed=3, size=16)


OVERLAP = dict(centres=[[0, 0, 0], [1.2, 0.5, 0], [-0.5, 1.0, 0.8]], radii=[1.0, 0.8, 0.9])


# --------------------------------------------------------------------------------------------
def test_matches_numpy_reference_ndt_fbm(noise):
    cloud = spheres(**OVERLAP, kappa=0.6)
    sun = (0.3, 0.8, 0.2)
    grid, st = cu.light_grid(cloud, cu.Sun(sun), noise, resolution=4, return_stats=True)
    ref, count, (lo, hi) = reference_light(cloud, sun, noise, 4)
    assert grid.shape == (4, 4, 4) and grid.dtype == np.float32
    np.testing.assert_allclose(grid, ref, atol=1e-5, rtol=0)
    np.testing.assert_array_equal(st.samples, count)
    np.testing.assert_allclose(grid.box[0], lo, atol=1e-5)
    np.testing.assert_allclose(grid.box[1], hi, atol=1e-5)
    assert (grid < 0.999).any() and (grid == 1.0).any()  # both lit-through and shadowed voxels


def test_matches_numpy_reference_naive_fbm_anisotropic_grid(noise):
    cloud = spheres(**OVERLAP, kappa=0.3)
    sun = (-0.5, 0.6, 0.3)
    grid = cu.light_grid(cloud, sun, noise, resolution=(3, 4, 5), method="naive", step=0.15)
    ref, _, _ = reference_light(cloud, sun, noise, (3, 4, 5), method="naive", step=0.15)
    assert grid.shape == (5, 4, 3)
    np.testing.assert_allclose(grid, ref, atol=1e-5, rtol=0)


def test_ray_missing_everything_is_exactly_one(noise):
    cloud = spheres([[0, 0, 0], [3, 0, 0]], [1.0, 1.0])
    grid = cu.light_grid(cloud, (0, 1, 0), noise, resolution=(9, 5, 5))
    # Column x index 4 (x = 1.5) lies in the gap between the spheres: the sun ray meets nothing.
    assert (grid[:, :, 4] == 1.0).all()
    assert (grid[:, :, 1] < 1.0).any()


def _analytic(chord: float, sigma: float, step: float, C: float) -> float:
    n = int(math.floor(chord / step))
    rem = chord - n * step
    a = math.exp(-sigma * step)
    scatter = C * (sum(a**i for i in range(n)) + (rem / step) * a**n)
    return scatter + math.exp(-sigma * chord)


def test_constant_density_sphere_is_beer_lambert_plus_scattering():
    # κ = 0: γ = exp(−|q|) ≥ e⁻¹ > 0.3, so the whole sphere is cloud at density 0.3.
    r, rho, A, step = 2.0, 0.3, 1.5, 0.1
    cloud = spheres([[0, 0, 0]], [r], kappa=0.0)
    R = 7
    grid = cu.light_grid(
        cloud, (0, 1, 0), None, resolution=R, density_override=rho, extinction=A, step=step
    )
    lo, hi = (np.array(b) for b in grid.box)
    cell = (hi - lo) / R
    checked_inside = 0
    for z in range(R):
        for y in range(R):
            for x in range(R):
                v = lo + (np.array([x, y, z]) + 0.5) * cell
                h2 = r * r - v[0] ** 2 - v[2] ** 2
                if abs(h2) < 1e-3:
                    continue  # grazing ray: float rounding decides whether it hits
                if h2 < 0:
                    expected = 1.0
                else:
                    top, bottom = math.sqrt(h2), -math.sqrt(h2)
                    chord = max(0.0, top - max(v[1], bottom))
                    expected = _analytic(chord, A * rho, step, C_DEFAULT)
                    checked_inside += v[1] > bottom
                assert grid[z, y, x] == pytest.approx(expected, abs=2e-6, rel=1e-5), (x, y, z)
    assert checked_inside > 20
    # The deepest voxels see the whole diameter: exp(−σ·2r) plus a little scattering.
    assert grid.min() == pytest.approx(_analytic(2 * r, A * rho, step, C_DEFAULT), rel=0.05)


def test_monotone_along_a_line_parallel_to_the_light(noise):
    cloud = spheres([[0, 0, 0]], [2.0], kappa=0.0)
    R = 9  # odd: the centre column runs through the sphere's centre
    const = cu.light_grid(cloud, (0, 1, 0), None, resolution=R, density_override=0.4)
    col = const[R // 2, :, R // 2]  # y from bottom to top, sun above
    assert (np.diff(col) > 0).all()  # strictly brighter towards the sun inside the sphere
    # With fBm (and a grid spacing of 5 steps, so deeper rays reuse shallower samples) it still
    # never gets brighter going away from the sun.
    fbm = cu.light_grid(cloud, (0, 1, 0), noise, resolution=R, step=0.1)
    col = fbm[R // 2, :, R // 2]
    assert (np.diff(col) >= -1e-6).all()
    assert col[0] < col[-1] - 0.05


def test_ndt_equals_naive_for_disjoint_spheres(noise):
    cloud = spheres(
        [[0, 0, 0], [2.5, 0.3, 0], [0, 0.2, 2.6], [2.4, 2.4, 2.4]], [1.0, 1.1, 1.2, 0.9]
    )
    sun = cu.Sun((0.4, 0.7, 0.6))
    a, sa = cu.light_grid(cloud, sun, noise, resolution=12, return_stats=True)
    b, sb = cu.light_grid(cloud, sun, noise, resolution=12, method="naive", return_stats=True)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(sa.samples, sb.samples)
    assert (a < 0.9).any()


def test_ndt_marches_fewer_samples_than_naive_for_overlaps(noise):
    cloud = spheres(**OVERLAP)
    sun = (0.2, 1.0, 0.1)
    a, sa = cu.light_grid(cloud, sun, noise, resolution=10, return_stats=True)
    b, sb = cu.light_grid(cloud, sun, noise, resolution=10, method="naive", return_stats=True)
    assert sa.samples_total < sb.samples_total
    assert (sa.samples <= sb.samples).all()
    assert sa.samples_per_voxel == pytest.approx(sa.samples_total / 1000)
    assert sa.seconds >= 0
    # With a constant density, naive attenuates overlaps twice: never brighter, darker somewhere.
    kw = dict(resolution=10, density_override=0.3)
    cloud0 = spheres(**OVERLAP, kappa=0.0)
    a = cu.light_grid(cloud0, sun, None, **kw)
    b = cu.light_grid(cloud0, sun, None, method="naive", **kw)
    assert (b <= a + 1e-6).all() and (b < a - 1e-2).any()


def test_identical_for_any_thread_count(noise):
    cloud = spheres(**OVERLAP)
    grids = [
        cu.light_grid(cloud, (0.3, 0.8, 0.2), noise, resolution=(11, 7, 5), threads=t)
        for t in (1, 2, 3)
    ]
    np.testing.assert_array_equal(grids[0], grids[1])
    np.testing.assert_array_equal(grids[0], grids[2])


def _rot(axis, deg):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    a = math.radians(deg)
    return np.eye(3) + math.sin(a) * k + (1 - math.cos(a)) * k @ k


def test_rotated_ellipsoids(noise):
    rots = np.stack([_rot((0, 0, 1), 35), _rot((1, 1, 0), 60)]).astype(np.float32)
    cloud = cu.Cloud(
        centres=np.array([[0, 0, 0], [1.0, 0.6, 0.2]], np.float32),
        radii=np.array([[2.0, 0.6, 0.8], [1.2, 0.5, 0.7]], np.float32),
        rotations=rots,
    )
    sun = (0.2, 0.9, -0.3)
    grid = cu.light_grid(cloud, sun, noise, resolution=5)
    ref, _, (lo, hi) = reference_light(cloud, sun, noise, 5)
    np.testing.assert_allclose(grid, ref, atol=1e-5, rtol=0)
    # The box follows the rotated extents.
    np.testing.assert_allclose(grid.box[0], lo, atol=1e-5)
    # Constant density, single rotated ellipsoid: T_D = exp(−σ·chord) with the rotated chord.
    one = cu.Cloud(centres=np.zeros((1, 3)), radii=[[2.0, 0.6, 0.8]], rotations=rots[:1], kappa=0.0)
    g = cu.light_grid(
        one, sun, None, resolution=5, density_override=0.3, solid_angle=0.0, extinction=1.0
    )
    ref1, _, _ = reference_light(one, sun, None, 5, constant=0.3, solid_angle=0.0, extinction=1.0)
    np.testing.assert_allclose(g, ref1, atol=1e-5, rtol=0)
    assert g.min() < 0.7


def test_metaballs(noise):
    cloud = spheres([[0, 0, 0], [1.5, 0.3, 0], [0.5, 1.2, 0.4]], [0.8, 0.7, 0.6], model="metaball")
    sun = (0.3, 0.8, 0.2)
    grid, st = cu.light_grid(cloud, sun, noise, resolution=4, return_stats=True)
    ref, count, (lo, hi) = reference_light(cloud, sun, noise, 4)
    np.testing.assert_allclose(grid, ref, atol=1e-5, rtol=0)
    np.testing.assert_array_equal(st.samples, count)
    # The box is the primitives grown by √N (plus half a voxel).
    np.testing.assert_allclose(grid.box[1], hi, atol=1e-5)
    assert grid.min() < 0.95
    naive = cu.light_grid(cloud, sun, noise, resolution=4, method="naive")
    assert (naive <= grid + 1e-6).all()


def test_grid_records_box_and_sun_and_leaves_the_cloud_alone(noise):
    cloud = spheres(**OVERLAP)
    grid = cu.light_grid(cloud, cu.Sun((0, 2, 0)), noise, resolution=(6, 5, 4))
    assert isinstance(grid, cu.LightGrid) and not hasattr(cloud, "light")
    assert grid.sun == (0.0, 1.0, 0.0)
    lo, hi = (np.array(b) for b in grid.box)
    blo, bhi = cloud.bbox
    # Voxel centres 0 and R−1 sit on the cloud's box faces.
    res = np.array([6, 5, 4])
    np.testing.assert_allclose(lo + 0.5 * (hi - lo) / res, blo, atol=1e-5)
    np.testing.assert_allclose(lo + (res - 0.5) * (hi - lo) / res, bhi, atol=1e-5)
    assert grid.record.params.resolution == (6, 5, 4)
    assert not grid.flags.writeable  # a value: read-only
    assert type(grid * 2) is np.ndarray  # arithmetic gives plain arrays


@pytest.mark.parametrize(
    "kwargs, exc, match",
    [
        (dict(sun=(0, 0, 0)), ValueError, "sun"),
        (dict(sun=(float("nan"), 1, 0)), ValueError, "sun"),
        (dict(sun="up"), TypeError, "sun"),
        (dict(resolution=0), ValueError, "resolution"),
        (dict(resolution=1), ValueError, "resolution"),
        (dict(resolution=MAX_RESOLUTION + 1), ValueError, "resolution"),
        (dict(resolution=(4, 4)), TypeError, "resolution"),
        (dict(resolution=4.0), TypeError, "resolution"),
        (dict(step=0.0), ValueError, "step"),
        (dict(step=-0.1), ValueError, "step"),
        (dict(step=float("nan")), ValueError, "step"),
        (dict(step=1e-7), ValueError, "step"),
        (dict(method="fast"), ValueError, "method"),
        (dict(extinction=-1.0), ValueError, "extinction"),
        (dict(solid_angle=-1e-4), ValueError, "solid_angle"),
        (dict(octaves=0), ValueError, "octaves"),
        (dict(frequency=0.0), ValueError, "frequency"),
        (dict(threads=-1), ValueError, "threads"),
        (dict(noise=None), ValueError, "noise"),
        (dict(noise="noise"), TypeError, "noise"),
        (dict(density_override=-0.5), ValueError, "density_override"),
        (dict(cloud="cloud"), TypeError, "cloud"),
        (dict(params="p"), TypeError, "params"),
    ],
)
def test_bad_input(noise, kwargs, exc, match):
    cloud = spheres(**OVERLAP)
    args = dict(cloud=cloud, sun=(0, 1, 0), noise=noise, resolution=4)
    args.update(kwargs)
    with pytest.raises(exc, match=match):
        cu.light_grid(**args)
    assert not hasattr(cloud, "light")  # nothing is stored on a cloud


def test_bad_sun_object_and_empty_cloud():
    with pytest.raises(ValueError, match="direction"):
        cu.Sun((0, 0, 0))
    with pytest.raises(ValueError, match="centres"):
        cu.light_grid(cu.Cloud(centres=np.zeros((0, 3)), radii=[]), (0, 1, 0), None)


def test_many_rotated_primitives_match_reference(noise):
    # Enough primitives that the sun-plane binning of the candidate search has many bins.
    rng = np.random.default_rng(5)
    n = 40
    rots = np.stack([_rot(rng.normal(size=3), rng.uniform(0, 180)) for _ in range(n)])
    cloud = cu.Cloud(
        centres=rng.uniform(-4, 4, (n, 3)).astype(np.float32),
        radii=rng.uniform(0.3, 1.0, (n, 3)).astype(np.float32),
        rotations=rots.astype(np.float32),
        kappa=0.5,
    )
    sun = (-0.2, 0.7, 0.5)
    for method in ("ndt", "naive"):
        grid, st = cu.light_grid(
            cloud, sun, noise, resolution=5, method=method, step=0.2, return_stats=True
        )
        ref, count, _ = reference_light(cloud, sun, noise, 5, method=method, step=0.2)
        np.testing.assert_array_equal(st.samples, count)
        np.testing.assert_allclose(grid, ref, atol=1e-5, rtol=0)
    assert (count > 0).sum() > 20


def test_bench_light_quick_writes_json_and_plot(tmp_path, run_bench: Callable[..., str]):
    import json

    stdout = run_bench("bench_light.py", tmp_path, timeout=300)
    data = json.loads((tmp_path / "light.json").read_text())
    assert (tmp_path / "light.png").stat().st_size > 1000
    assert data["benchmark"] == "light" and data["quick"] is True
    assert {"cumulus", "mesh300"} == set(data["clouds"])
    assert data["clouds"]["mesh300"]["primitives"] == 300
    for cloud in data["clouds"].values():
        for row in cloud["resolutions"].values():
            # The naive method marches at least as many samples as NDT; medians are positive.
            assert row["naive_over_ndt_samples"] >= 1.0
            assert row["ndt"]["march_s"]["median"] > 0
            assert row["ndt"]["samples_per_voxel"] > 0
            # The shared grid marches fewer samples and states its difference from NDT.
            assert row["shared"]["samples_total"] < row["ndt"]["samples_total"]
            diff = row["shared_minus_ndt"]
            assert 0 < diff["mean_abs"] <= diff["p99_abs"] <= diff["max_abs"] < 1
            assert row["ndt_over_shared_time"] > 0
    assert "cpu_model" in data["machine"]
    # Each issue target says what it asks, what this run reached and whether that meets it;
    # --quick does not measure 20³ / 64³, so those are null, not a verdict.
    targets = data["targets"]
    assert set(targets) == {"light_20_ms", "naive_over_ndt_cumulus", "light_64_ms"}
    for name, limit in (("light_20_ms", 1.0), ("light_64_ms", 30.0)):
        t = targets[name]
        assert (t["limit"], t["comparison"], t["reached"], t["met"]) == (limit, "<=", None, None)
        assert t["method"] == "shared" and t["baseline"]["method"] == "ndt"
    ratio = targets["naive_over_ndt_cumulus"]
    assert ratio["limit"] == 1.8 and ratio["comparison"] == ">=" and ratio["reached"] > 0
    assert ratio["met"] is (ratio["reached"] >= 1.8)
    # The fBm floor: Noise.fbm alone on as many points as each method sampled, at both grids.
    floor = data["fbm_floor"]
    assert set(floor) == {"8", "12"}
    for r, by_method in floor.items():
        assert set(by_method) == {"shared", "ndt"}
        for m, f in by_method.items():
            row = data["clouds"]["cumulus"]["resolutions"][r][m]
            assert f["points"] == row["samples_total"] > 0
            assert f["fbm_s"]["median"] > 0 and f["ns_per_point"] > 0
            assert f["ndt_march_s"] == row["march_s"]["median"]
            assert f["fbm_share_of_ndt"] == pytest.approx(f["fbm_s"]["median"] / f["ndt_march_s"])
    assert "fBm floor" in stdout
    assert ("[met]" in stdout) is ratio["met"]


def test_zero_density_or_zero_extinction_leaves_full_light(noise):
    cloud = spheres(**OVERLAP)
    # ρ = 0 is not cloud: no extinction and no scattering anywhere.
    g0 = cu.light_grid(cloud, (0, 1, 0), None, resolution=6, density_override=0.0)
    assert (g0 == 1.0).all()
    # A = 0 and γ = 0: nothing attenuates or scatters, whatever the fBm.
    g1 = cu.light_grid(cloud, (0, 1, 0), noise, resolution=6, extinction=0.0, solid_angle=0.0)
    assert (g1 == 1.0).all()


def test_values_bounded_and_sun_forms_equivalent(noise):
    cloud = spheres(**OVERLAP)
    grid, st = cu.light_grid(cloud, cu.Sun((0.3, 0.8, 0.2)), noise, resolution=8, return_stats=True)
    # 0 < L ≤ 1 + C·(samples): transmittance ≤ 1 plus at most C per sample of scattering.
    assert (grid > 0).all()
    assert (grid <= 1.0 + C_DEFAULT * st.samples + 1e-6).all()
    # Forward scattering (eq. 6) only adds light: without it every voxel is darker or equal.
    dark = cu.light_grid(cloud, (0.3, 0.8, 0.2), noise, resolution=8, solid_angle=0.0)
    assert (dark <= grid).all() and (dark < grid).any()
    same = cu.light_grid(cloud, np.array([0.6, 1.6, 0.4]), noise, resolution=8)
    np.testing.assert_array_equal(grid, same)  # directions are normalised


def test_light_sun_survives_save_and_load(noise, tmp_path):
    cloud = spheres(**OVERLAP)
    grid = cu.light_grid(cloud, (0.0, 3.0, 4.0), noise, resolution=4)
    assert grid.sun == pytest.approx((0.0, 0.6, 0.8))
    back = cu.load_light_grid(grid.save(tmp_path / "g.npz"))
    np.testing.assert_array_equal(back, grid)
    assert back.sun == pytest.approx(grid.sun)
    np.testing.assert_allclose(np.array(back.box), np.array(grid.box))
