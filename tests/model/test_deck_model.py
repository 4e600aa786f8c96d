"""CloudDeck, the model of a stratus / stratocumulus / altostratus layer: the C++ density against
a numpy reference of the same formulas, its lattice, determinism, the profiles per type, the
weather map and the wind, scene-file round trips, baking to a VolumeCloud and bad input."""

from __future__ import annotations

import copy
import json
import pickle

import numpy as np
import pytest

import cumuli as cu
from cumuli.model.deck import CLOUD_TYPES, DETAIL_CONTRAST, fbm_weather_map

SMALL = (24, 12, 20)


def deck(**kw: object) -> cu.CloudDeck:
    args: dict[str, object] = {"resolution": SMALL, "map_size": 32}
    args.update(kw)
    return cu.CloudDeck(**args)  # type: ignore[arg-type]


# --- a slow numpy reference of the model, in float32 as the core ------------------------------
def smooth(a: float, b: float, t: np.ndarray) -> np.ndarray:
    u = np.clip((t - np.float32(a)) / np.float32(b - a), 0, 1).astype(np.float32)
    return u * u * (np.float32(3) - np.float32(2) * u)


def profile(cloud_type: str, h: np.ndarray) -> np.ndarray:
    one = np.float32(1)
    if cloud_type == "stratus":
        p = smooth(0.0, 0.1, h) * (one - smooth(0.6, 0.95, h))
    elif cloud_type == "stratocumulus":
        p = smooth(0.0, 0.25, h) * (one - smooth(0.3, 1.0, h))
    else:
        p = smooth(0.6, 0.75, h) * (one - smooth(0.85, 1.0, h))
    return np.where((h >= 0) & (h <= 1), p, np.float32(0))


def coverage_ref(d: cu.CloudDeck, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    m = d.coverage_map()
    nz, nx = m.shape
    x0, z0, x1, z1 = (np.float32(v) for v in d.extent)
    ox, oz = (np.float32(v) for v in d.offset)
    u = (x - ox - x0) / (x1 - x0) * np.float32(nx)
    v = (z - oz - z0) / (z1 - z0) * np.float32(nz)
    cu_ = np.clip(u - np.float32(0.5), 0, nx - 1).astype(np.float32)
    cv = np.clip(v - np.float32(0.5), 0, nz - 1).astype(np.float32)
    ix, iz = np.floor(cu_).astype(int), np.floor(cv).astype(int)
    jx, jz = np.minimum(ix + 1, nx - 1), np.minimum(iz + 1, nz - 1)
    wx, wz = cu_ - ix, cv - iz
    a = m[iz, ix] + wx * (m[iz, jx] - m[iz, ix])
    b = m[jz, ix] + wx * (m[jz, jx] - m[jz, ix])
    return np.clip(a + wz * (b - a), 0, 1)


def density_ref(d: cu.CloudDeck, pts: np.ndarray) -> np.ndarray:
    pts = pts.astype(np.float32)
    x, y, z = pts[:, 0], pts[:, 1], pts[:, 2]
    base, top = np.float32(d.base), np.float32(d.top)
    h = (y - base) / (top - base)
    b = profile(d.cloud_type, h) + coverage_ref(d, x, z) - np.float32(1)
    ox, oz = (np.float32(v) for v in d.offset)
    shifted = np.stack([x - ox, y, z - oz], axis=1)
    octaves, gain, _, _ = d.detail_fbm
    weight = np.float32(sum(gain**i for i in range(1, octaves + 1)))
    f = d.noise.fbm(shifted, *d.detail_fbm) / weight
    k, half = np.float32(DETAIL_CONTRAST), np.float32(0.5)
    n = np.clip(half + k * (f - half), 0, 1).astype(np.float32)
    e = np.float32(d.detail) * (np.float32(1) - n)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.minimum(np.float32(1), (b - e) / (np.float32(1) - e))
    inside = (h >= 0) & (h <= 1) & (b > 0) & (b > e)
    return np.where(inside, np.float32(d.density) * r, np.float32(0))


def random_points(d: cu.CloudDeck, n: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x0, z0, x1, z1 = d.extent
    span = d.top - d.base
    lo = [x0 - 500, d.base - 0.1 * span, z0 - 500]
    hi = [x1 + 500, d.top + 0.1 * span, z1 + 500]
    return rng.uniform(lo, hi, size=(n, 3)).astype(np.float32)


# --- the density ------------------------------------------------------------------------------
@pytest.mark.parametrize("cloud_type", CLOUD_TYPES)
def test_density_matches_the_numpy_reference(cloud_type: str) -> None:
    d = deck(cloud_type=cloud_type, coverage=0.7, density=2.0, wind=(7.0, -3.0), time=120.0, seed=5)
    pts = random_points(d, 20000)
    got = d.density_at(pts)
    want = density_ref(d, pts)
    assert got.dtype == np.float32 and got.shape == (len(pts),)
    assert (got > 0).mean() > 0.05  # the comparison covers cloud, not only empty air
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-5)
    assert got.min() >= 0.0 and got.max() <= d.density


def test_density_matches_the_reference_with_a_given_map() -> None:
    rng = np.random.default_rng(3)
    m = rng.uniform(0, 1, size=(9, 13)).astype(np.float32)
    d = deck(coverage=m, cloud_type="stratus", detail=0.8, wind=(-4.0, 2.0), time=300.0)
    pts = random_points(d, 20000, seed=2)
    np.testing.assert_allclose(d.density_at(pts), density_ref(d, pts), rtol=0, atol=2e-5)


def test_full_coverage_without_detail_is_density_times_the_profile() -> None:
    for cloud_type in CLOUD_TYPES:
        d = deck(cloud_type=cloud_type, coverage=1.0, detail=0.0, density=1.5)
        lat = d.density_lattice()
        _, ys, _ = d.lattice_centres()
        h = (ys - np.float32(d.base)) / (np.float32(d.top) - np.float32(d.base))
        want = np.float32(1.5) * profile(cloud_type, h)
        np.testing.assert_allclose(lat, np.broadcast_to(want[None, :, None], lat.shape), atol=1e-6)


def _centres(d: cu.CloudDeck) -> np.ndarray:
    xs, ys, zs = d.lattice_centres()
    z, y, x = np.meshgrid(zs, ys, xs, indexing="ij")
    return np.stack([x, y, z], axis=-1).reshape(-1, 3)


def test_the_lattice_is_the_density_at_its_texel_centres() -> None:
    d = deck(coverage=0.5, wind=(3.0, 1.0))
    lat = d.density_lattice()
    nx, ny, nz = d.resolution
    assert lat.shape == (nz, ny, nx) and lat.dtype == np.float32 and lat.flags.c_contiguous
    np.testing.assert_array_equal(lat, d.density_at(_centres(d)).reshape(lat.shape))
    assert lat.max() > 0
    assert d.density_lattice() is lat  # memoised: the deck is immutable
    assert not lat.flags.writeable


def test_a_drifted_deck_is_its_still_self_moved() -> None:
    """The wind carries the whole deck: its slab moves by the offset, its lattice is the time-0
    one (the same array), and its density at the moved centres is that lattice to rounding."""
    d = deck(coverage=0.5, wind=(3.0, 1.0))
    later = d.at(50.0)
    ox, oz = later.offset
    assert later.still() is d and d.still() is d and d.at(80.0).still() is d
    assert later.density_lattice() is d.density_lattice()
    assert later.to_volume().density is d.to_volume().density
    for a, b in zip(later.box, d.box, strict=True):
        np.testing.assert_allclose(np.subtract(a, b), [ox, 0.0, oz], atol=1e-9)
    np.testing.assert_allclose(
        np.subtract(later.layer_box(), d.layer_box()), [[ox, 0, oz]] * 2, atol=1e-3
    )
    np.testing.assert_array_equal(later.to_volume().box, later.box)
    got = later.density_at(_centres(later)).reshape(d.density_lattice().shape)
    np.testing.assert_allclose(got, d.density_lattice(), atol=2e-3)
    assert (got > 0).mean() > 0.05
    # A deck made at a time (a scene file's) has the same still self, made once.
    made = deck(coverage=0.5, wind=(3.0, 1.0), time=50.0)
    assert made.still().time == 0.0 and made.still() is made.still()
    np.testing.assert_array_equal(made.density_lattice(), d.density_lattice())
    assert deck(coverage=0.5, time=50.0).still().time == 50.0  # no wind: nothing moved


def test_seeds_and_threads() -> None:
    one = deck(seed=11).density_lattice(threads=1)
    two = deck(seed=11).density_lattice(threads=2)
    np.testing.assert_array_equal(one, two)
    other = deck(seed=12).density_lattice()
    assert not np.array_equal(one, other)
    d = deck(seed=11)
    pts = random_points(d, 5000)
    np.testing.assert_array_equal(d.density_at(pts, threads=1), d.density_at(pts, threads=2))


# --- the profiles per type ----------------------------------------------------------------------
def mean_per_height(cloud_type: str) -> np.ndarray:
    d = cu.CloudDeck(cloud_type=cloud_type, resolution=(48, 40, 48), map_size=64)
    return d.density_lattice().mean(axis=(0, 2)).astype(np.float64)


def test_each_type_follows_its_profile() -> None:
    h = (np.arange(40) + 0.5) / 40
    means = {t: mean_per_height(t) for t in CLOUD_TYPES}
    com = {t: float((h * m).sum() / m.sum()) for t, m in means.items()}
    extent = {t: float((m > 0.1 * m.max()).mean()) for t, m in means.items()}
    # Altostratus is thin and high; stratus low; stratocumulus densest low-middle.
    assert com["altostratus"] > 0.7 > com["stratocumulus"]
    assert com["altostratus"] > com["stratus"] + 0.3
    assert com["stratus"] < 0.45
    assert extent["altostratus"] < 0.35 < extent["stratus"]
    assert 0.1 < h[int(np.argmax(means["stratocumulus"]))] < 0.45
    assert means["altostratus"][h < 0.55].max() == 0.0
    # Stratocumulus tapers: its upper third holds much less than its lower-middle.
    sc = means["stratocumulus"]
    assert sc[h > 0.7].mean() < 0.3 * sc[(h > 0.15) & (h < 0.45)].mean()


def test_a_full_stratocumulus_overcast_has_a_real_optical_depth() -> None:
    d = cu.CloudDeck(coverage=1.0, resolution=(32, 64, 32))
    lat = d.density_lattice()
    tau = d.sigma_t * lat.sum(axis=1) * (d.top - d.base) / d.resolution[1]
    assert 10.0 < float(tau.mean()) < 20.0


# --- the weather map ----------------------------------------------------------------------------
def test_zero_coverage_gives_an_empty_deck() -> None:
    assert not deck(coverage=0.0).density_lattice().any()
    assert not deck(coverage=np.zeros((5, 7))).density_lattice().any()
    assert not deck(coverage=0.0).coverage_map().any()


def test_the_fbm_map_has_the_mean_coverage() -> None:
    for c in (0.2, 0.6, 0.9):
        m = deck(coverage=c, map_size=64).coverage_map()
        assert m.shape == (64, 64) and m.dtype == np.float32
        assert abs(float(m.mean()) - c) < 1e-3
        assert 0.0 <= m.min() and m.max() <= 1.0
        assert m.min() < 0.5 < m.max()  # a map, not a constant
    np.testing.assert_array_equal(
        fbm_weather_map(0.4, (-1e3, -1e3, 1e3, 1e3), size=16, seed=3),
        fbm_weather_map(0.4, (-1e3, -1e3, 1e3, 1e3), size=16, seed=3),
    )


def test_a_zero_half_of_the_map_is_empty() -> None:
    m = np.ones((16, 16), np.float32)
    m[:, :8] = 0.0  # x < 0 (the map's left half) has no cloud
    d = deck(coverage=m, resolution=(64, 8, 32))
    lat = d.density_lattice()
    xs, _, _ = d.lattice_centres()
    texel = (d.extent[2] - d.extent[0]) / 16
    assert not lat[:, :, xs < -0.5 * texel].any()  # bilinear reaches half a texel across
    assert lat[:, :, xs > 0.5 * texel].mean() > 0.2


# --- the wind -----------------------------------------------------------------------------------
def test_the_wind_moves_the_map() -> None:
    m = np.random.default_rng(4).uniform(0, 1, size=(12, 12)).astype(np.float32)
    wind, t = (6.0, -2.5), 200.0
    moving = deck(coverage=m, detail=0.0, wind=wind)
    x0, z0, x1, z1 = moving.extent
    ox, oz = wind[0] * t, wind[1] * t
    shifted = deck(coverage=m, detail=0.0, extent=(x0 + ox, z0 + oz, x1 + ox, z1 + oz))
    later = moving.at(t)
    assert later.time == t and moving.time == 0.0 and later.offset == (ox, oz)
    pts = random_points(moving, 20000)
    np.testing.assert_allclose(later.density_at(pts), shifted.density_at(pts), atol=1e-5)
    assert not np.allclose(moving.density_at(pts), later.density_at(pts), atol=1e-3)


def test_the_whole_deck_drifts_with_the_wind() -> None:
    d = deck(coverage=0.7, wind=(5.0, 3.0))
    later = d.at(100.0)
    assert later.coverage_map() is d.coverage_map()  # the map does not depend on the time
    pts = random_points(d, 20000)
    pts[:, [0, 2]] = np.clip(pts[:, [0, 2]], -7000, 6000)  # stay where the map is, not clamped
    moved = pts + np.array([500.0, 0.0, 300.0], np.float32)
    np.testing.assert_allclose(later.density_at(moved), d.density_at(pts), atol=1e-4)


# --- scene files and baking ---------------------------------------------------------------------
def test_round_trip_with_an_fbm_map() -> None:
    d = deck(cloud_type="altostratus", coverage=0.45, wind=(1.5, 2.0), time=7.25, seed=99)
    data = json.loads(json.dumps(d.to_dict()))
    assert data["kind"] == "deck" and data["coverage"] == 0.45
    back = cu.CloudDeck.from_dict(data)
    assert back.to_dict() == d.to_dict()
    np.testing.assert_array_equal(back.density_lattice(), d.density_lattice())


def test_round_trip_with_an_array_map() -> None:
    m = np.random.default_rng(8).uniform(0, 1, size=(10, 6)).astype(np.float32)
    d = deck(coverage=m, cloud_type="stratus", base=300.0, top=650.5, extent=(0, 0, 4000, 9000))
    back = cu.CloudDeck.from_dict(json.loads(json.dumps(d.to_dict())))
    assert isinstance(back.coverage, np.ndarray)
    np.testing.assert_array_equal(back.coverage_map(), m)
    assert back.to_dict() == d.to_dict()
    np.testing.assert_array_equal(back.density_lattice(), d.density_lattice())


def test_copies_and_pickles_are_the_same_deck() -> None:
    d = deck(coverage=0.5, wind=(2.0, 1.0), time=10.0)
    lat = d.density_lattice()
    for other in (copy.deepcopy(d), pickle.loads(pickle.dumps(d)), copy.copy(d)):
        assert other.to_dict() == d.to_dict()
        np.testing.assert_array_equal(other.density_lattice(), lat)


def test_the_noise_version_is_the_default_and_old_files_keep_the_table() -> None:
    d = deck(seed=3)
    assert d.noise_version == 2 and d.noise == cu.Noise(3, 64, 2)
    assert d.to_dict()["noise_version"] == 2
    old = d.to_dict()
    del old["noise_version"]  # a deck saved before noise versions existed
    back = cu.CloudDeck.from_dict(json.loads(json.dumps(old)))
    assert back.noise_version == 1 and back.noise == cu.Noise(3, 64, 1)
    table = deck(seed=3, noise_version=1)
    np.testing.assert_array_equal(back.density_lattice(), table.density_lattice())
    assert not np.array_equal(back.coverage_map(), d.coverage_map())  # the version matters
    assert not np.array_equal(back.density_lattice(), d.density_lattice())


def test_from_dict_refuses_unknown_fields() -> None:
    with pytest.raises(ValueError, match="clouds.0 has unknown field"):
        cu.CloudDeck.from_dict({"kind": "deck", "colour": 1}, "clouds.0")
    with pytest.raises(ValueError, match="clouds.0: top must be greater than base"):
        cu.CloudDeck.from_dict({"base": 10.0, "top": 5.0}, "clouds.0")


def test_to_volume_and_boxes() -> None:
    d = deck(base=1000.0, top=1800.0, extent=(-3000, -2000, 5000, 4000))
    lo, hi = d.layer_box()
    np.testing.assert_array_equal(lo, np.float32([-3000, 1000, -2000]))
    np.testing.assert_array_equal(hi, np.float32([5000, 1800, 4000]))
    for a, b in zip(d.bounds(), d.layer_box(), strict=True):
        np.testing.assert_array_equal(a, b)
    v = d.to_volume()
    assert isinstance(v, cu.VolumeCloud) and v.sigma_t == d.sigma_t
    np.testing.assert_array_equal(v.density, d.density_lattice())
    for a, b in zip(v.layer_box(), d.layer_box(), strict=True):
        np.testing.assert_array_equal(a, b)
    assert "stratocumulus" in repr(d) and "CloudDeck" in repr(d)
    assert cu.CloudDeck.kind == "deck" and "CloudDeck" in cu.__all__


# --- bad input ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "error", "name"),
    [
        ({"base": float("nan")}, ValueError, "base"),
        ({"top": float("inf")}, ValueError, "top"),
        ({"base": 2000.0, "top": 2000.0}, ValueError, "top"),
        ({"base": 2500.0}, ValueError, "top"),
        ({"extent": (100, 0, 100, 10)}, ValueError, "extent"),
        ({"extent": (0, 0, 10)}, TypeError, "extent"),
        ({"extent": (0, float("nan"), 10, 10)}, ValueError, "extent"),
        ({"coverage": 1.5}, ValueError, "coverage"),
        ({"coverage": float("nan")}, ValueError, "coverage"),
        ({"coverage": True}, TypeError, "coverage"),
        ({"coverage": np.ones((4, 4, 2))}, ValueError, "coverage"),
        ({"coverage": np.ones(4)}, ValueError, "coverage"),
        ({"coverage": np.array([["a", "b"]])}, TypeError, "coverage"),
        ({"coverage": np.full((3, 3), np.nan)}, ValueError, "coverage"),
        ({"coverage": np.full((3, 3), 1.01)}, ValueError, "coverage"),
        ({"coverage": -np.ones((3, 3))}, ValueError, "coverage"),
        ({"cloud_type": "cumulonimbus"}, ValueError, "stratus, stratocumulus, altostratus"),
        ({"cloud_type": 3}, ValueError, "cloud_type"),
        ({"density": -1.0}, ValueError, "density"),
        ({"sigma_t": float("nan")}, ValueError, "sigma_t"),
        ({"detail": 1.5}, ValueError, "detail"),
        ({"detail_scale": 0.0}, ValueError, "detail_scale"),
        ({"wind": (1.0,)}, TypeError, "wind"),
        ({"wind": "ab"}, TypeError, "wind"),
        ({"wind": (1.0, "x")}, TypeError, "wind"),
        ({"wind": (1.0, float("inf"))}, ValueError, "wind"),
        ({"wind": (1e14, 0.0), "time": 1e3}, ValueError, "wind"),
        ({"time": float("nan")}, ValueError, "time"),
        ({"seed": -1}, ValueError, "seed"),
        ({"resolution": (1024, 1024, 1024)}, ValueError, "resolution"),
        ({"resolution": (1, 8, 8)}, ValueError, "resolution"),
        ({"resolution": (8, 8)}, TypeError, "resolution"),
        ({"resolution": (8.0, 8, 8)}, TypeError, "resolution"),
        ({"map_size": 1}, ValueError, "map_size"),
        ({"octaves": 0}, ValueError, "octaves"),
        ({"noise_version": 3}, ValueError, "noise_version"),
        ({"noise_version": 1.0}, TypeError, "noise_version"),
    ],
)
def test_bad_input_names_the_parameter(kwargs: dict, error: type, name: str) -> None:
    with pytest.raises(error, match=name):
        cu.CloudDeck(**kwargs)


def test_bad_points_and_threads() -> None:
    d = deck()
    with pytest.raises(ValueError, match="points"):
        d.density_at(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="points"):
        d.density_at(np.array([[0.0, np.nan, 0.0]]))
    with pytest.raises(ValueError, match="threads"):
        d.density_lattice(threads=-1)
    with pytest.raises(ValueError, match="time"):
        d.at(float("inf"))
