"""Volume light precompute by sweeping against brute-force marching.

``method="sweep"`` integrates each sun-parallel line of a sheared grid once (sun and every SH
quadrature direction) and sweeps outwards from each multiple-scattering point; ``"march"`` marches
every voxel's ray. A constant density must come out exact (the sweeps blend the mean density
along the rays, not the depth); on a cloud the sweeps must stay within the bounds stated in
docs/iwasaki-animation.md, and the sky visibility against brute-force marching must keep its
accuracy.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli.light.volume import (
    DEPTH_METHODS,
    point_optical_depth,
    sh_optical_depth,
    sphere_quadrature,
    sun_optical_depth,
)

LO, HI = (0.0, 0.0, 0.0), (2.0, 1.0, 3.0)
DIRECTIONS = [(0, 1, 0), (0.3, 0.8, -0.4), (-0.9, 0.2, 0.3), (0.2, -0.3, -0.93), (1, 1, 1)]

# Stated differences between the swept and the marched depths of a cumulus volume
# (docs/iwasaki-animation.md):
# mean |Δf| over the mean depth.
SUN_BOUND = 0.06
SKY_BOUND = 0.05
POINT_BOUND = 0.08


@pytest.fixture(scope="module")
def cumulus() -> cu.VolumeDatabase:
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), seed=1)
    return cu.evolving_cloud_volumes(
        cloud, cu.Noise(seed=7), 1, 20, density_scale=2.0, frequency=0.3, seed=3
    )


def test_methods_are_listed() -> None:
    assert DEPTH_METHODS == ("sweep", "march")


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_constant_density_is_exact(direction: tuple) -> None:
    vol = np.full((7, 5, 6), 0.8, np.float32)
    swept = sun_optical_depth(vol, LO, HI, direction, method="sweep")
    marched = sun_optical_depth(vol, LO, HI, direction, method="march")
    np.testing.assert_allclose(swept, marched, rtol=2e-5, atol=1e-6)
    pts = np.array([[0.3, 0.2, 2.9], [1.0, 0.5, 1.5], [1.9, 0.9, 0.1]], np.float32)
    np.testing.assert_allclose(
        point_optical_depth(vol, LO, HI, pts, method="sweep"),
        point_optical_depth(vol, LO, HI, pts, method="march"),
        rtol=2e-5,
        atol=1e-6,
    )
    np.testing.assert_allclose(
        sh_optical_depth(vol, LO, HI, 3, 4, method="sweep"),
        sh_optical_depth(vol, LO, HI, 3, 4, method="march"),
        rtol=1e-4,
        atol=1e-5,
    )


def _relative_mean_difference(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).mean() / np.abs(b).mean())


def test_cumulus_depths_within_the_stated_bounds(cumulus: cu.VolumeDatabase) -> None:
    vol, box = cumulus.volumes, cumulus.box
    for d in DIRECTIONS:
        swept = sun_optical_depth(vol, *box, d, method="sweep")
        marched = sun_optical_depth(vol, *box, d, method="march")
        assert _relative_mean_difference(swept, marched) < SUN_BOUND, d
        assert float(swept.mean()) == pytest.approx(float(marched.mean()), rel=0.02)
    sky = sh_optical_depth(vol, *box, 4, 6, method="sweep")
    sky_march = sh_optical_depth(vol, *box, 4, 6, method="march")
    assert _relative_mean_difference(sky, sky_march) < SKY_BOUND
    pts = cu._core.volume_sample_points(*box, 12, 5)
    near = point_optical_depth(vol, *box, pts, method="sweep")
    near_march = point_optical_depth(vol, *box, pts, method="march")
    assert _relative_mean_difference(near, near_march) < POINT_BOUND
    # A depth along a ray never decreases towards the sun: the sweep keeps f ≥ 0.
    assert (near >= 0).all() and (sky[..., 0] >= 0).all()


def test_sweep_differs_from_march_on_a_single_voxel_but_conserves_its_mass() -> None:
    """The blend across lines spreads a point-like density over about a voxel, keeping its sum."""
    vol = np.zeros((8, 8, 8), np.float32)
    vol[2, 3, 4] = 1.0
    d = (0.3, 0.9, 0.1)
    swept = sun_optical_depth(vol, (0, 0, 0), (1, 1, 1), d, method="sweep")
    marched = sun_optical_depth(vol, (0, 0, 0), (1, 1, 1), d, method="march")
    assert np.abs(swept - marched).max() > 1e-3
    assert swept.sum() == pytest.approx(marched.sum(), rel=0.02)


def test_sky_visibility_keeps_its_accuracy_against_brute_force(cumulus: cu.VolumeDatabase) -> None:
    """The statement of docs/iwasaki-animation.md: uniform-sky visibility ∫τ dω against
    brute-force marching along
    every quadrature direction, order 4, scaling and squaring: median error ~10 %, and the
    swept precompute no worse than the marched one by more than a point."""
    dirs, w = sphere_quadrature(6)
    depth = np.stack(
        [sun_optical_depth(cumulus.volumes[0], *cumulus.box, d, method="march") for d in dirs], -1
    )
    true = (np.exp(-depth) * w).sum(-1)
    errors = {}
    for method in DEPTH_METHODS:
        lit = cu.VolumeLighting(
            cumulus, cu.Sun(), sky=(1, 1, 1), sh_samples=6, ms_points=0, method=method
        )
        vis = lit.light(0)[..., 1]
        errors[method] = float(np.median(np.abs(vis - true) / true))
    assert errors["sweep"] < 0.15
    assert errors["sweep"] < errors["march"] + 0.01


def test_volume_lighting_method_and_progress(cumulus: cu.VolumeDatabase, capsys) -> None:
    kw = {"ms_points": 8, "seed": 1}
    march = cu.VolumeLighting(cumulus, cu.Sun(), method="march", progress=False, **kw)
    sweep = cu.VolumeLighting(cumulus, cu.Sun(), progress=False, **kw)
    assert (march.method, sweep.method) == ("march", "sweep")
    vol, box = cumulus.volumes, cumulus.box
    np.testing.assert_array_equal(
        march.sun_depth, sun_optical_depth(vol, *box, cu.Sun().direction, method="march")
    )
    np.testing.assert_array_equal(
        sweep.point_depth, point_optical_depth(vol, *box, sweep.points, method="sweep")
    )
    assert not np.array_equal(march.sky_depth, sweep.sky_depth)
    # The light of both stays close at the default settings: τ_sun and the irradiance (sky plus
    # multiple scattering) within a few per cent on average.
    a, b = march.light(0), sweep.light(0)
    assert float(np.abs(a - b).mean() / np.abs(a).mean()) < 0.06
    capsys.readouterr()
    cu.VolumeLighting(cumulus, cu.Sun(), progress=False, **kw)
    assert capsys.readouterr().err == ""  # no bar when asked not to
    with pytest.raises(ValueError, match="method"):
        cu.VolumeLighting(cumulus, cu.Sun(), method="trace")
    with pytest.raises(TypeError, match="progress"):
        cu.VolumeLighting(cumulus, cu.Sun(), progress="yes")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="method"):
        sun_optical_depth(vol, *box, (0, 1, 0), method="sweeping")


def test_sweep_is_linear_in_density_and_thread_independent() -> None:
    rng = np.random.default_rng(2)
    vols = rng.random((2, 6, 7, 5)).astype(np.float32)
    w = np.float32(0.35)
    blended = w * vols[0] + (1 - w) * vols[1]
    d = (0.4, -0.7, 0.2)
    f = sun_optical_depth(vols, LO, HI, d)
    np.testing.assert_allclose(
        cu.blend_volumes(f[0], f[1], w), sun_optical_depth(blended, LO, HI, d), rtol=1e-5, atol=1e-6
    )
    pts = np.array([[1.0, 0.5, 1.0], [0.1, 0.9, 2.5]], np.float32)
    for fn in (
        lambda t: sh_optical_depth(vols, LO, HI, 3, 3, threads=t),
        lambda t: point_optical_depth(vols, LO, HI, pts, threads=t),
        lambda t: sun_optical_depth(vols, LO, HI, d, threads=t),
    ):
        np.testing.assert_array_equal(fn(1), fn(2))
        np.testing.assert_array_equal(fn(1), fn(3))
    assert math.isfinite(float(f.sum()))
