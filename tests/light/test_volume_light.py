"""Iwasaki 2011 §3.1: per-volume optical depths (sun, SH sky), the SH exponential, the blend."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli.light.volume import (
    point_optical_depth,
    sh_basis,
    sh_optical_depth,
    sphere_quadrature,
    sun_optical_depth,
)
from cumuli.sky import as_sky, sky_args

LO, HI = (0.0, 0.0, 0.0), (2.0, 1.0, 3.0)


def _voxel_centres(shape: tuple[int, int, int]) -> np.ndarray:
    d, h, w = shape
    lo, hi = np.array(LO), np.array(HI)
    z, y, x = np.meshgrid(np.arange(d), np.arange(h), np.arange(w), indexing="ij")
    return lo + (np.stack([x, y, z], -1) + 0.5) * (hi - lo) / np.array([w, h, d])


def _random_volumes(n: int, shape: tuple[int, int, int], seed: int) -> np.ndarray:
    return np.random.default_rng(seed).random((n, *shape)).astype(np.float32)


@pytest.mark.parametrize("direction", [(0, 1, 0), (0, -1, 0), (1, 0, 0), (0.3, 0.8, -0.4)])
def test_optical_depth_of_uniform_slab_is_density_times_length(direction: tuple) -> None:
    shape = (6, 5, 4)
    rho = 0.7
    vol = np.full(shape, rho, np.float32)
    f = sun_optical_depth(vol, LO, HI, direction, step=0.5)
    d = np.array(direction, np.float64) / np.linalg.norm(direction)
    p = _voxel_centres(shape)
    # Distance from each voxel centre to the box exit along d.
    with np.errstate(divide="ignore"):
        t = np.where(d > 0, (np.array(HI) - p) / d, np.where(d < 0, (np.array(LO) - p) / d, np.inf))
    length = t.min(axis=-1)
    np.testing.assert_allclose(f, rho * length, rtol=1e-5, atol=1e-6)


def test_sphere_quadrature_and_sh_basis_are_orthonormal() -> None:
    dirs, w = sphere_quadrature(4)
    assert dirs.shape == (32, 3)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0, atol=1e-6)
    assert w.sum() == pytest.approx(4 * math.pi, rel=1e-6)
    y = sh_basis(4, dirs).astype(np.float64)
    gram = (y * w[:, None]).T @ y
    np.testing.assert_allclose(gram, np.eye(16), atol=2e-6)


def test_sh_projection_of_a_constant_is_exact() -> None:
    # A uniform sky L(ω) = c projects onto (c·√4π, 0, ...).
    c = (0.3, 0.5, 0.9)
    coeffs = cu._core.sky_sh(sky_args(as_sky(c)), 3, 4)
    expect = np.zeros((3, 9))
    expect[:, 0] = np.array(c) * math.sqrt(4 * math.pi)
    np.testing.assert_allclose(coeffs, expect, atol=1e-6)
    # And the optical depth of an empty volume is zero in every direction.
    zero = sh_optical_depth(np.zeros((3, 3, 3), np.float32), LO, HI, 3, 4)
    assert not zero.any()


def test_sh_optical_depth_reconstructs_directional_depth() -> None:
    """At the centre of a uniform cube the depth is ρ·(distance to the face): band-limited but
    its SH reconstruction matches the mean over directions exactly (coefficient 0)."""
    shape = (5, 5, 5)
    vol = np.full(shape, 0.5, np.float32)
    lo, hi = (0, 0, 0), (1, 1, 1)
    f = sh_optical_depth(vol, lo, hi, 2, 8, step=0.25)[2, 2, 2]
    dirs, w = sphere_quadrature(8)
    depth = 0.5 * (0.5 / np.abs(dirs).max(axis=1))  # centre to the cube's faces
    mean = (w * depth).sum() / (4 * math.pi)
    assert f[0] / math.sqrt(4 * math.pi) == pytest.approx(mean, rel=1e-4)
    np.testing.assert_allclose(f[1:4], 0.0, atol=1e-5)  # symmetric: no linear band


def test_optical_depth_of_a_blend_is_the_blend_of_optical_depths() -> None:
    shape = (6, 7, 8)
    vols = _random_volumes(2, shape, 3)
    w = np.float32(0.3)
    blended = w * vols[0] + (1 - w) * vols[1]
    sun = (0.3, 0.8, 0.2)
    f = sun_optical_depth(vols, LO, HI, sun)
    direct = sun_optical_depth(blended, LO, HI, sun)
    np.testing.assert_allclose(cu.blend_volumes(f[0], f[1], w), direct, rtol=1e-5, atol=1e-6)
    s = sh_optical_depth(vols, LO, HI, 3, 4)
    s_direct = sh_optical_depth(blended, LO, HI, 3, 4)
    np.testing.assert_allclose(cu.blend_volumes(s[0], s[1], w), s_direct, rtol=1e-4, atol=1e-5)


@pytest.fixture(scope="module")
def lighting() -> cu.VolumeLighting:
    vols = _random_volumes(3, (6, 6, 6), 1) * np.float32(2.0)
    db = cu.VolumeDatabase(vols, LO, HI)
    return cu.VolumeLighting(db, cu.Sun(direction=(0.2, 1, 0.1)), sigma_t=1.5, sh_samples=4)


def test_light_of_blended_frame_matches_direct_computation(lighting: cu.VolumeLighting) -> None:
    db = lighting.database
    frame = cu.AnimationFrame(0, 0, 2, 0.4, True)
    light = lighting.light(frame)
    w = np.float32(0.4)
    blended = w * db.volumes[0] + (1 - w) * db.volumes[2]
    f_sun = sun_optical_depth(blended, *db.box, lighting.sun.direction, lighting.step)
    f_sky = sh_optical_depth(
        blended, *db.box, lighting.sh_order, lighting.sh_samples, lighting.step
    )
    f_pts = point_optical_depth(blended, *db.box, lighting.points, lighting.step)
    direct = lighting.light_from_depths(f_sun, f_sky, f_pts, blended)
    np.testing.assert_allclose(light, direct, rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(light[..., 0], np.exp(-1.5 * f_sun), rtol=1e-5)
    single = lighting.light_from_depths(f_sun, f_sky)
    assert (light[..., 1:] > single[..., 1:]).all()  # multiple scattering adds light


def test_multiple_scattering_of_uniform_volume_matches_formula() -> None:
    """Uniform ρ and a sun straight down the y axis: every term of eq. (8) is analytic."""
    shape, rho, sigma_t, albedo = (4, 4, 4), 0.5, 0.8, 0.9
    db = cu.VolumeDatabase(np.full((1, *shape), rho, np.float32), (0, 0, 0), (1, 1, 1))
    sun = cu.Sun(direction=(0, 1, 0), colour=(1.0, 0.5, 0.25), intensity=2.0)
    lit = cu.VolumeLighting(
        db, sun, sky=(0, 0, 0), sigma_t=sigma_t, sh_order=2, sh_samples=2, ms_points=7, ms_orders=1,
        albedo=albedo, seed=3,
    )  # fmt: skip
    light = lit.light(0)
    q = lit.points.astype(np.float64)
    assert q.shape == (7, 3) and (q >= 0).all() and (q <= 1).all()
    x = (np.stack(np.meshgrid(*(np.arange(4),) * 3, indexing="ij"), -1)[..., ::-1] + 0.5) / 4
    d = np.linalg.norm(x[..., None, :] - q, axis=-1)  # (4, 4, 4, K)
    np.testing.assert_allclose(lit.point_depth[0], rho * d, rtol=1e-4, atol=1e-6)
    # E₁ at the points: trilinear of sun·τ_sun (+ no sky) — τ_sun depends only on y.
    tau = np.exp(-sigma_t * rho * (1 - x[..., 1]))
    e1_vox = np.array(sun.radiance) * tau[..., None]
    y_q = np.clip(q[:, 1] * 4 - 0.5, 0, 3)
    lo_i = np.floor(y_q).astype(int)
    hi_i = np.minimum(lo_i + 1, 3)
    f = y_q - lo_i
    tau_y = np.exp(-sigma_t * rho * (1 - (np.arange(4) + 0.5) / 4))
    tau_q = tau_y[lo_i] + f * (tau_y[hi_i] - tau_y[lo_i])
    e1_q = np.array(sun.radiance) * tau_q[:, None]
    src = (1 / 7) * sigma_t * rho * albedo * e1_q / (4 * math.pi)  # (K, 3)
    d_min2 = (0.5 * (1 / 7) ** (1 / 3)) ** 2
    geo = np.exp(-sigma_t * rho * d) / np.maximum(d**2, d_min2)
    e2 = geo @ src
    np.testing.assert_allclose(light[..., 1:], e2, rtol=2e-4, atol=1e-7)
    np.testing.assert_allclose(light[..., 0], tau, rtol=1e-5)
    assert e1_vox.shape == (4, 4, 4, 3)


def test_empty_volume_sees_the_whole_sky() -> None:
    db = cu.VolumeDatabase(np.zeros((2, 3, 3, 3), np.float32), LO, HI)
    sky = cu.Sky(zenith=(0.2, 0.4, 0.9), horizon=(0.6, 0.7, 0.8), sun_disc_intensity=50.0)
    lit = cu.VolumeLighting(db, cu.Sun(), sky=sky, sh_samples=6, ms_points=8)
    light = lit.light(1)
    np.testing.assert_array_equal(light[..., 0], 1.0)
    # E_sky = ∫ L_sky dω over the same quadrature, the sun disc left out (it is the τ_sun term).
    dirs, w = sphere_quadrature(6)
    no_disc = cu.Sky(zenith=sky.zenith, horizon=sky.horizon, sun_disc_intensity=0.0)
    expect = (w[:, None] * no_disc.colour(dirs, cu.Sun())).sum(axis=0)
    np.testing.assert_allclose(light[..., 1:], np.broadcast_to(expect, (3, 3, 3, 3)), rtol=1e-5)
    uniform = cu.VolumeLighting(db, cu.Sun(), sky=(0.5, 0.5, 0.5), sh_samples=6, ms_points=0)
    np.testing.assert_allclose(uniform.light(0)[..., 1:], 4 * math.pi * 0.5, rtol=1e-5)


@pytest.mark.parametrize("method", ["squaring", "fit"])
def test_shexp_against_direct_transmittance(lighting: cu.VolumeLighting, method: str) -> None:
    """The SH exponential approximates exp of the band-limited optical depth: compare its SH
    vector with the quadrature projection of exp(−σ_t f(ω))."""
    order = 3
    f = lighting.sky_depth[1].reshape(-1, 16)[:, : order**2].astype(np.float64)  # bands 0..2
    dirs, w = sphere_quadrature(lighting.sh_samples)
    y = sh_basis(order, dirs).astype(np.float64)
    sigma_t = 0.3  # moderate optical depths, where the linear form of eq. 7 is meant to work
    ref = (np.exp(-sigma_t * f @ y.T) * w) @ y
    g = (-sigma_t * f).astype(np.float32)
    core = cu._core
    if method == "fit":
        a, b, norm = core.fit_shexp(f.astype(np.float32), order, sigma_t, 16, 4)
    else:
        a, b, norm = np.ones(1, np.float32), np.ones(1, np.float32), 0.0
    got = core.shexp_apply(g, a, b, norm, order, method == "squaring")
    rel = np.linalg.norm(got - ref, axis=1) / np.linalg.norm(ref, axis=1)
    assert np.median(rel) < (0.01 if method == "squaring" else 0.05)
    # With no directional variation the form is exact, exp(g₀/√4π)·1, given a(0) = 1.
    g0 = np.zeros((1, order**2), np.float32)
    g0[0, 0] = -2.0
    ones = np.ones(4, np.float32)
    out = core.shexp_apply(g0, ones, ones, 1.0, order, method == "squaring")
    expect = np.zeros(order**2)
    expect[0] = math.exp(-2.0 / math.sqrt(4 * math.pi)) * math.sqrt(4 * math.pi)
    np.testing.assert_allclose(out[0], expect, rtol=1e-5, atol=1e-6)


def test_squaring_beats_the_fit_on_a_cloud() -> None:
    """Against brute-force marching over the quadrature directions (not band-limited), the
    scaling-and-squaring SH exponential gives the uniform-sky visibility ∫τ dω far more
    accurately than the paper's fitted a, b on a thick cumulus."""
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), n=12, seed=1)
    db = cu.evolving_cloud_volumes(cloud, cu.Noise(seed=7, size=32), 1, 12, density_scale=2.0)
    dirs, w = sphere_quadrature(6)
    depth = np.stack([sun_optical_depth(db.volumes[0], *db.box, d) for d in dirs], -1)
    true = (np.exp(-depth) * w).sum(-1)
    errors = {}
    for method in ("squaring", "fit"):
        lit = cu.VolumeLighting(
            db, cu.Sun(), sky=(1, 1, 1), sh_samples=6, shexp=method, ms_points=0
        )
        vis = lit.light(0)[..., 1]  # E_sky of a uniform unit sky = ∫τ dω
        errors[method] = float(np.median(np.abs(vis - true) / true))
    assert errors["squaring"] < 0.5 * errors["fit"]
    assert errors["squaring"] < 0.2


def test_light_bad_input(lighting: cu.VolumeLighting) -> None:
    db = lighting.database
    with pytest.raises(ValueError, match="sh_order"):
        cu.VolumeLighting(db, cu.Sun(), sh_order=5)
    with pytest.raises(ValueError, match="shexp"):
        cu.VolumeLighting(db, cu.Sun(), shexp="taylor")
    with pytest.raises(ValueError, match="sh_samples"):
        cu.VolumeLighting(db, cu.Sun(), sh_order=4, sh_samples=3)
    with pytest.raises(ValueError, match="sigma_t"):
        cu.VolumeLighting(db, cu.Sun(), sigma_t=-1)
    with pytest.raises(TypeError, match="sun"):
        cu.VolumeLighting(db, (0, 1, 0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="sky"):
        cu.VolumeLighting(db, cu.Sun(), sky=(1, 2))
    with pytest.raises(ValueError, match="frame"):
        lighting.light(7)
    with pytest.raises(ValueError, match="ms_points"):
        cu.VolumeLighting(db, cu.Sun(), ms_points=-1)
    with pytest.raises(ValueError, match="albedo"):
        cu.VolumeLighting(db, cu.Sun(), albedo=1.5)
    with pytest.raises(ValueError, match="density"):
        f_sun, f_sky, f_pts = lighting.optical_depth(0)
        lighting.light_from_depths(f_sun, f_sky, f_pts)
    with pytest.raises(ValueError, match="to_sun"):
        sun_optical_depth(np.zeros((2, 2, 2)), LO, HI, (0, 0, 0))
    with pytest.raises(ValueError, match="box_max"):
        sun_optical_depth(np.zeros((2, 2, 2)), HI, LO, (0, 1, 0))


def test_precompute_is_thread_count_independent() -> None:
    vols = _random_volumes(2, (5, 6, 7), 9)
    db = cu.VolumeDatabase(vols, LO, HI)
    kw = {"sh_order": 3, "sh_samples": 3, "ms_points": 9, "seed": 4}
    one = cu.VolumeLighting(db, cu.Sun(), threads=1, **kw)
    two = cu.VolumeLighting(db, cu.Sun(), threads=2, **kw)
    for name in ("sun_depth", "sky_depth", "point_depth", "points"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))
    frame = cu.AnimationFrame(0, 0, 1, 0.25, True)
    np.testing.assert_array_equal(one.light(frame, threads=1), two.light(frame, threads=2))


def test_sky_given_as_sky_pair_or_colour() -> None:
    z, h = (0.1, 0.2, 0.3), (0.4, 0.5, 0.6)
    sky = cu.Sky(zenith=z, horizon=h)
    assert as_sky(sky) is sky
    assert as_sky(None) == cu.Sky()
    pair = as_sky((z, h))
    assert (pair.zenith, pair.horizon) == (z, h)
    uniform = as_sky(z)
    assert uniform.zenith == uniform.horizon == uniform.ground == z
    with pytest.raises(ValueError, match="non-negative"):
        as_sky((-1, 0, 0))
    with pytest.raises(ValueError, match="sky"):
        as_sky((1, 2))
