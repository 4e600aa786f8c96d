"""Gaussian cumulus (§3.6.1): counts, clamps, radii, the hollow and containment filters."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli
from cumuli import _core
from cumuli._util.structs import core_struct

SIGMA = np.array([3.8, 1.7, 3.7], dtype=np.float64)
HOLLOW = np.array([0.75, 1.0 / 3.0, 0.75]) * SIGMA


def test_draws_n_primitives_and_reports_each_step() -> None:
    c = cumuli.gaussian_cumulus(n=35, seed=3)
    s = c.stats
    assert s["drawn"] == 35
    assert s["kept"] == c.n == 35 - s["removed_by_hollow"] - s["removed_by_containment"]
    assert c.model == "spheroid"
    assert c.params["generator"] == "gaussian_cumulus" and c.params["args"]["seed"] == 3
    raw = cumuli.gaussian_cumulus(n=35, seed=3, hollow=False, remove_contained=False)
    assert raw.n == 35 and raw.stats["removed_by_hollow"] == 0


@pytest.mark.parametrize("seed", range(5))
def test_centres_within_clamp_box_and_flat_base(seed: int) -> None:
    centre = np.array([10.0, 5.0, -3.0])
    c = cumuli.gaussian_cumulus(centre=centre, n=200, seed=seed, hollow=False)
    off = c.centres.astype(np.float64) - centre
    tol = 1e-4
    assert (off[:, 0] >= -2 * SIGMA[0] - tol).all() and (off[:, 0] <= 2 * SIGMA[0] + tol).all()
    assert (off[:, 2] >= -2 * SIGMA[2] - tol).all() and (off[:, 2] <= 2 * SIGMA[2] + tol).all()
    assert (off[:, 1] <= 2 * SIGMA[1] + tol).all()
    # Nothing below the base plane y = C_y + μ_y, and saturating clamps put many on it.
    assert (off[:, 1] >= -tol).all()
    assert np.isclose(off[:, 1], 0.0, atol=tol).sum() > 50


def test_resample_mode_keeps_clamps_without_piling_on_them() -> None:
    c = cumuli.gaussian_cumulus(n=300, seed=1, hollow=False, clamp_mode="resample")
    off = c.centres
    assert (off[:, 1] >= 0).all() and (off[:, 1] <= 2 * SIGMA[1] + 1e-4).all()
    assert np.isclose(off[:, 1], 0.0, atol=1e-6).sum() < 5


@pytest.mark.parametrize("model,eps", [("eq16", 2.5), ("eq15", 15.0)])
def test_radii_bounded_by_epsilon(model: str, eps: float) -> None:
    for seed in range(10):
        c = cumuli.gaussian_cumulus(seed=seed, radius_model=model, radius_scale=1.0)
        r = c.radii[:, 0]
        assert (r > 0).all() and (r <= eps + 1e-5).all()
        assert (c.radii == c.radii[:, :1]).all()  # spheres
    scaled = cumuli.gaussian_cumulus(seed=0, radius_scale=2.9)
    assert (scaled.radii <= 2.5 * 2.9 + 1e-4).all()


def _eq16_reference(off: np.ndarray, combine: str) -> np.ndarray:
    u2 = (off / (2 * SIGMA)) ** 2
    s = u2.sum(axis=1) if combine == "sum" else u2.prod(axis=1)
    return 2.5 * (1 - 0.1 * np.sqrt(s))


@pytest.mark.parametrize("combine", ["sum", "product"])
def test_eq16_radius_matches_numpy_reference(combine: str) -> None:
    c = cumuli.gaussian_cumulus(
        n=100, seed=4, hollow=False, remove_contained=False, radius_scale=1.0, eq16_combine=combine
    )
    ref = _eq16_reference(c.centres.astype(np.float64), combine)
    np.testing.assert_allclose(c.radii[:, 0], ref, rtol=1e-5)


def test_eq15_radius_matches_numpy_reference() -> None:
    c = cumuli.gaussian_cumulus(
        n=100, seed=4, hollow=False, remove_contained=False, radius_model="eq15"
    )
    off = c.centres.astype(np.float64)
    np.testing.assert_allclose(
        c.radii[:, 0], 15.0 / (np.abs(off[:, 0]) + np.abs(off[:, 2]) + 1), rtol=1e-5
    )


def test_hollow_filter_removes_exactly_the_box_and_about_a_fifth() -> None:
    shares = []
    for seed in range(50):
        raw = cumuli.gaussian_cumulus(seed=seed, hollow=False, remove_contained=False)
        kept = cumuli.gaussian_cumulus(seed=seed, hollow=True, remove_contained=False)
        inside = (np.abs(raw.centres.astype(np.float64)) < HOLLOW).all(axis=1)
        np.testing.assert_array_equal(kept.centres, raw.centres[~inside])
        assert kept.stats["removed_by_hollow"] == inside.sum()
        shares.append(inside.mean())
    mean = float(np.mean(shares))
    # Saturating clamps: P(|x|<.75σ)·P(y<σ/3)·P(|z|<.75σ) ≈ .547·.630·.547 ≈ 0.19 (paper: ~20 %).
    assert 0.14 < mean < 0.25, mean


@pytest.mark.parametrize("seed", range(10))
def test_no_sphere_inside_another_after_containment(seed: int) -> None:
    c = cumuli.gaussian_cumulus(seed=seed, radius_model="eq15", n=80)
    p = c.centres.astype(np.float64)
    r = c.radii[:, 0].astype(np.float64)
    d = np.linalg.norm(p[:, None] - p[None], axis=2)
    contained = (r[:, None] - r[None, :]) >= d
    np.fill_diagonal(contained, False)
    assert not contained.any()


def test_containment_filter_on_known_spheres() -> None:
    centres = np.array([[0, 0, 0], [0.5, 0, 0], [5, 0, 0], [5, 0, 0], [0, 0, 0.2]], np.float32)
    radii = np.array([1.0, 0.4, 1.0, 1.0, 3.0], np.float32)
    keep = _core.remove_contained_spheres(centres, radii)
    # 0 and 1 lie inside 4; the coincident pair 2/3 keeps the first.
    assert keep.tolist() == [2, 4]


def test_same_seed_same_arrays_and_prefix_stable() -> None:
    a = cumuli.gaussian_cumulus(seed=11)
    b = cumuli.gaussian_cumulus(seed=11)
    assert np.array_equal(a.centres, b.centres) and np.array_equal(a.radii, b.radii)
    c = cumuli.gaussian_cumulus(seed=12)
    assert not np.array_equal(a.centres, c.centres) or a.n != c.n
    small = cumuli.gaussian_cumulus(n=10, seed=11, hollow=False, remove_contained=False)
    big = cumuli.gaussian_cumulus(n=20, seed=11, hollow=False, remove_contained=False)
    assert np.array_equal(small.centres, big.centres[:10])


def test_metaball_preset() -> None:
    m = cumuli.metaball_cumulus(centre=(1, 2, 3), n=6, seed=2)
    assert m.model == "metaball" and m.n == 6
    r = m.radii[:, 0]
    assert (r >= 0.9).all() and (r <= 1.6).all()
    assert (m.centres[:, 1] >= 2 - 1e-5).all()
    assert m.params["generator"] == "metaball_cumulus"


@pytest.mark.parametrize(
    "kwargs,exc,word",
    [
        ({"n": 0}, ValueError, "n"),
        ({"n": -3}, ValueError, "n"),
        ({"n": 10**9}, ValueError, "n"),
        ({"n": 3.5}, TypeError, "n"),
        ({"sigma": (-1, 1, 1)}, ValueError, "sigma"),
        ({"sigma": (0, 1, 1)}, ValueError, "sigma"),
        ({"sigma": (np.nan, 1, 1)}, ValueError, "sigma"),
        ({"centre": (0, np.inf, 0)}, ValueError, "centre"),
        ({"clamps": ((2, -2), (0, 2), (-2, 2))}, ValueError, "clamps"),
        ({"clamps": ((0, 1),)}, TypeError, "clamps"),
        ({"radius_model": "eq17"}, ValueError, "radius_model"),
        ({"radius_scale": -1}, ValueError, "radius_scale"),
        ({"epsilon": 0}, ValueError, "epsilon"),
        ({"radius_model": "uniform", "radius_range": (-1, 1)}, ValueError, "radius_range"),
        ({"seed": -1}, ValueError, "seed"),
        ({"clamp_mode": "wrap"}, ValueError, "clamp_mode"),
    ],
)
def test_bad_arguments_raise_clear_errors(kwargs: dict, exc: type, word: str) -> None:
    with pytest.raises(exc, match=word):
        cumuli.gaussian_cumulus(**kwargs)


def test_all_removed_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="removed all"):
        cumuli.gaussian_cumulus(n=1, sigma=(1, 1, 1), clamps=((0, 0), (0, 0), (0, 0)))


def test_core_validates_on_its_own() -> None:
    with pytest.raises(ValueError, match="sigma"):
        _core.gaussian_cumulus(
            core_struct(
                _core.GaussianCumulusParams, centre=[0, 0, 0], n=5, mu=[0, 0, 0],
                sigma=[1, -1, 1], clamp_lo=[-2, 0, -2], clamp_hi=[2, 2, 2],
                clamp_mode="saturate", radius_model="eq16", eq16_combine="sum", epsilon=2.5,
                radius_scale=1.0, radius_lo=1.0, radius_hi=1.0, hollow=True,
                hollow_box=[0.75, 0.33, 0.75], remove_contained=True, seed=0,
            )
        )  # fmt: skip


def test_epsilon_pair_picks_by_model() -> None:
    a = cumuli.gaussian_cumulus(seed=1, radius_model="eq15", epsilon=(10.0, 2.0))
    b = cumuli.gaussian_cumulus(seed=1, radius_model="eq15", epsilon=10.0)
    assert np.array_equal(a.radii, b.radii) and a.params["args"]["epsilon"] == 10.0
    c = cumuli.gaussian_cumulus(seed=1, epsilon=(10.0, 2.0))
    assert c.params["args"]["epsilon"] == 2.0 and (c.radii <= 2.0 * 2.9 + 1e-4).all()
