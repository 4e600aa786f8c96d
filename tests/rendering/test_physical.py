"""The physical lighting mode (RENDER_CONTRACT "Physical lighting"): settings, the medium
(`density_volume`), the light step, the C++ marcher against a slow numpy twin, GL against C++,
the volume renderer against the marcher, and bad input."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.gl.context import shader_dir
from cumuli.light import physical
from cumuli.light.onto_media import frame_nodes
from cumuli.light.physical import (
    OCTAVES,
    octave_sum,
    physical_light,
    view_depth_scale,
    view_diffuse_share,
)
from cumuli.light.view import seen_from
from cumuli.rendering import params
from cumuli.rendering.marcher_cpu import MIN_TRANSMITTANCE
from cumuli.rendering.params import COARSEN_EVERY, MAX_COARSEN
from cumuli.sky import sky_args
from cumuli.testing import assert_image_close, only

F = np.float32
SUN = cu.Sun(direction=(0.8, 0.45, -0.3), colour=(1.0, 0.9, 0.8), intensity=5.0)
PHYS = cu.RenderSettings(
    lighting="physical",
    physical_resolution=16,
    exact_noise=True,
    haze=0.0,
    resolve=False,
    air_extinction=0.0,
)


def small_cloud() -> cu.Cloud:
    return cu.gaussian_cumulus(centre=(0, 0, 0), n=8, seed=4)


def small_scene(settings: cu.RenderSettings = PHYS, **kw) -> cu.Scene:
    return cu.Scene(
        [small_cloud()], sun=SUN, noise=cu.Noise(seed=5, size=32), settings=settings, **kw
    )


def camera_for(scene: cu.Scene) -> cu.Camera:
    lo, hi = scene.bounds()
    c = (lo + hi) / 2
    return cu.Camera(position=(float(c[0]) + 3, float(c[1]) + 2, -40.0), target=tuple(c), fov=40)


# --- settings and the medium --------------------------------------------------------------
@pytest.mark.parametrize(
    ("field", "value", "error"),
    [
        ("lighting", "pbr", ValueError),
        ("albedo", 1.5, ValueError),
        ("albedo", float("nan"), ValueError),
        ("extinction_scale", -1.0, ValueError),
        ("phase", "rayleigh", ValueError),
        ("hg_g2", 1.0, ValueError),
        ("hg_blend", -0.1, ValueError),
        ("physical_resolution", 2, ValueError),
        ("multiple_scattering", 1, TypeError),
        ("jitter_seed", 5000, ValueError),
        ("jitter", 1, TypeError),
        ("shadow_resolution", 0, ValueError),
    ],
)
def test_bad_physical_settings_name_the_field(field: str, value: object, error: type) -> None:
    with pytest.raises(error, match=f"settings.{field}"):
        cu.RenderSettings(**{field: value})


def test_settings_mean_cosine_and_round_trip() -> None:
    s = cu.RenderSettings(lighting="physical", phase="dual_hg", hg_g=0.8, hg_g2=-0.4, hg_blend=0.25)
    assert s.physical and s.mean_cosine == pytest.approx(0.75 * 0.8 - 0.25 * 0.4)
    assert cu.RenderSettings(**s.to_dict()) == s
    assert cu.RenderSettings().physical  # the physical mode is the default
    assert cu.RenderSettings().phase == "mie"  # with the approximate Mie phase
    assert not cu.RenderSettings(lighting="paper").physical


def test_density_volume_is_the_extinction_field_at_texel_centres() -> None:
    cloud, noise = small_cloud(), cu.Noise(seed=5, size=32)
    s = cu.RenderSettings(extinction_scale=7.0, lighting="paper")
    field = cu.density_volume(cloud, noise, s, (12, 9, 10))
    assert field.values.shape == (10, 9, 12) and field.values.dtype == np.float32
    lo, hi = (np.asarray(b, np.float64) for b in field.box)
    np.testing.assert_allclose(lo, cloud.layer_box()[0])
    np.testing.assert_allclose(hi, cloud.layer_box()[1])
    # Texel (i, j, k) at lo + (i + ½)(hi − lo)/res: extinction_scale × the density field there.
    rng = np.random.default_rng(0)
    for _ in range(20):
        i, j, k = rng.integers(12), rng.integers(9), rng.integers(10)
        p = F(lo) + (np.array([i, j, k], F) + F(0.5)) * F((hi - lo) / np.array([12, 9, 10]))
        rho, _ = cloud.density(p[None].astype(F), noise, **s.fbm_params())
        assert field.values[k, j, i] == pytest.approx(7.0 * rho[0], rel=1e-5, abs=1e-6)
    assert (field.values > 0).mean() > 0.1
    # One int sizes the longest edge, the others in proportion.
    shape = cu.density_volume(cloud, noise, s, 20).values.shape
    ext = hi - lo
    assert shape[2 - int(np.argmax(ext))] == 20


def test_density_volume_of_a_volume_cloud_and_bad_input() -> None:
    dens = np.random.default_rng(1).random((6, 5, 4)).astype(F)
    vc = cu.VolumeCloud(density=dens, box=((0, 0, 0), (4, 5, 6)), sigma_t=3.0)
    np.testing.assert_allclose(cu.density_volume(vc, resolution=None).values, 3 * dens, rtol=1e-6)
    # Resampled at the lattice's own centres it is unchanged.
    np.testing.assert_allclose(
        cu.density_volume(vc, resolution=(4, 5, 6)).values, 3 * dens, rtol=1e-5
    )
    with pytest.raises(ValueError, match="noise"):
        cu.density_volume(small_cloud(), None)
    with pytest.raises(TypeError, match="cloud"):
        cu.density_volume("cloud", cu.Noise(seed=1, size=32))
    with pytest.raises(ValueError, match="resolution"):
        cu.density_volume(small_cloud(), cu.Noise(seed=1, size=32), resolution=0)
    with pytest.raises(TypeError, match="settings"):
        cu.density_volume(small_cloud(), cu.Noise(seed=1, size=32), settings={})


def test_sky_radiance_is_the_gradient_without_the_disc() -> None:
    sky = cu.Sky()
    d = np.random.default_rng(2).normal(size=(50, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[0] = SUN.direction  # in the disc
    r = sky.radiance(d, SUN)
    assert r.shape == (50, 3) and r.dtype == np.float32
    nodisc = cu.Sky(sun_disc_intensity=0.0)
    np.testing.assert_array_equal(r, nodisc.colour(d.astype(F), SUN))
    assert (sky.colour(d[:1].astype(F), SUN) > r[:1]).all()
    with pytest.raises(ValueError, match="directions"):
        sky.radiance(np.zeros((3, 2)))


# --- the light step -----------------------------------------------------------------------
def test_light_step_dispatches_on_lighting_and_memoises() -> None:
    scene = small_scene()
    lit = cu.prepare_light(scene)
    light = lit.lights[0]
    assert isinstance(light, cu.PhysicalLight) and light.octaves == OCTAVES
    assert light.grid.shape[-1] == 4 and not light.grid.flags.writeable
    assert cu.prepare_light(scene).lights[0] is light  # memoised by content
    paper = cu.prepare_light(scene.replace(settings=cu.RenderSettings(lighting="paper")))
    assert isinstance(paper.lights[0], cu.LightGrid)
    # Switches: no sky light → no sky channels; no multiple scattering → single scattering only.
    nosky = physical_light(scene.clouds[0], scene.replace(settings=PHYS.replace(sky_light=False)))
    assert (nosky.grid[..., 1:] == 0).all() and (nosky.grid[..., 0] > 0).any()
    ss = physical_light(
        scene.clouds[0], scene.replace(settings=PHYS.replace(multiple_scattering=False))
    )
    assert ss.octaves == 1 and (ss.grid[..., 0] == 0).all() and (ss.grid[..., 1:] > 0).any()


def test_sun_depth_matches_a_brute_force_march() -> None:
    scene = small_scene()
    light = cu.prepare_light(scene).lights[0]
    cloud, s = scene.clouds[0], scene.settings
    lo, hi = (np.asarray(b) for b in light.box)
    rng = np.random.default_rng(3)
    pts = (lo + (hi - lo) * rng.uniform(0.2, 0.8, size=(40, 3))).astype(F)
    sun = np.asarray(scene.sun.direction)
    # τ from p to the lattice's sun-side face (which lies beyond the cloud): march to the box.
    got = light.sample_depth(pts)
    ds = 0.01
    want = []
    for p in pts:
        tmax = min(
            (b - q) / v for q, v, b in zip(p, sun, np.where(sun > 0, hi, lo), strict=True) if v != 0
        )
        ts = np.arange(ds / 2, tmax, ds)
        rho, _ = cloud.density((p + ts[:, None] * sun).astype(F), scene.noise, **s.fbm_params())
        want.append(s.extinction_scale * rho.sum() * ds)
    want = np.array(want)
    # The march stops past SUN_DEPTH_CUT (no light is left): deeper points hold a depth above it.
    cut = physical.SUN_DEPTH_CUT
    shallow, deep = want < 0.8 * cut, want > 1.2 * cut
    assert shallow.sum() >= 15, want
    # (A deep point between the last node before the cut and the first after it reads a blend
    # of the two: up to ~10 % under the cut with one node per cell along the light, its light
    # e^−τ nil all the same.)
    assert np.all(got[deep] > 0.9 * cut) and np.all(got[deep] <= 1.05 * want[deep])
    assert np.median(got[deep]) > cut
    # Trilinear between lattice nodes: close where the depth varies smoothly (the shallow points
    # include the cloud's fringe, where a node's depth differs most from a point's).
    got, want = got[shallow], want[shallow]
    assert np.median(np.abs(got - want)) < 1.5
    assert abs(np.mean(got - want)) < 1.0
    assert np.corrcoef(got, want)[0, 1] > 0.97


def test_diffusion_matches_the_slab_solution() -> None:
    """A thick homogeneous slab lit from straight above: the collided fluence along its middle
    against the 1-D diffusion solution with Marshak's boundary, φ = A e^{−κz} + C e^{−σz}."""
    sigma, albedo, g = 5.0, 0.99, 0.6
    h = 0.25
    ext = np.zeros((40, 40, 40), F)
    ext[2:38, 4:32, 2:38] = sigma  # medium y in [−4, 3] of the box below
    lo, hi = (-5.0, -5.0, -5.0), (5.0, 5.0, 5.0)
    top = 3.0
    ys = lo[1] + (np.arange(40) + 0.5) * h
    sun_t = np.where(ext > 0, np.exp(-sigma * np.maximum(top - ys, 0))[None, :, None], 1.0).astype(
        F
    )
    phi = _core.diffusion_light(ext, lo, hi, sun_t, (0.0, 1.0, 0.0), None, albedo, g, 1e-6)
    col = phi[20, 4:32, 20, 0][::-1][:10]  # from the top medium cell down
    sa, ss = (1 - albedo) * sigma, albedo * sigma
    d = 1 / (3 * (sa + ss * (1 - g)))
    kap = math.sqrt(sa / d)
    c = -ss / (d * sigma**2 - sa)
    a = -c * (1 + 2 * d * sigma) / (1 + 2 * d * kap)
    z = (np.arange(10) + 0.5) * h
    analytic = a * np.exp(-kap * z) + c * np.exp(-sigma * z)
    # Cells of 1.25 mean free paths: within 10 % (the discretisation; 1 % at h = 0.02 in 1-D).
    np.testing.assert_allclose(col, analytic, rtol=0.1)
    # Empty cells next to the medium carry the boundary value, below the surface cell's.
    assert 0 < phi[20, 32, 20, 0] < phi[20, 31, 20, 0]


def test_the_forward_flux_source_carries_the_sun_deeper() -> None:
    """The forward-scattered sun's flux source moves the collided sun light along the light:
    in a slab lit from above the fluence's depth centroid sinks and the top cells dim while the
    deep ones brighten; lit from below it is the mirror image; weight 0 is the isotropic
    source, and the sky's channels do not see it."""
    sigma, albedo, g = 4.0, 0.99, 0.8
    ext = np.zeros((12, 40, 12), F)
    ext[1:11, 4:36, 1:11] = sigma
    lo, hi = (-1.5, -5.0, -1.5), (1.5, 5.0, 1.5)
    ys = lo[1] + (np.arange(40) + 0.5) * 0.25
    depth = np.clip(ys.max() - 1.0 - ys, 0.0, None)[None, :, None]  # from the slab's top
    sun_t = np.broadcast_to(np.exp(-sigma * depth), ext.shape).astype(F)
    sky = np.ones((*ext.shape, 3), F)

    def solve(to_sun, t, forward):
        return _core.diffusion_light(ext, lo, hi, t, to_sun, sky, albedo, g, 1e-6,
                                     forward=forward)  # fmt: skip

    iso = solve((0.0, 1.0, 0.0), sun_t, 0.0)
    plain = _core.diffusion_light(ext, lo, hi, sun_t, (0.0, 1.0, 0.0), sky, albedo, g, 1e-6)
    np.testing.assert_array_equal(iso, plain)
    fwd = solve((0.0, 1.0, 0.0), sun_t, 1.0)
    np.testing.assert_allclose(fwd[..., 1:], iso[..., 1:], rtol=1e-5, atol=1e-7)
    col_i, col_f = iso[6, 4:36, 6, 0], fwd[6, 4:36, 6, 0]
    z = np.arange(32)[::-1]  # depth below the top (row 35 is the top medium cell)

    def centroid(c):
        return float((c * z).sum() / c.sum())

    assert centroid(col_f) > centroid(col_i) + 0.3
    assert col_f[-1] < col_i[-1] and col_f[-8] > col_i[-8]
    # The sun from below, through the mirrored slab: the mirror image.
    up = solve((0.0, -1.0, 0.0), np.ascontiguousarray(sun_t[:, ::-1]), 1.0)
    np.testing.assert_allclose(up[:, ::-1, :, 0], fwd[..., 0], rtol=2e-3, atol=1e-6)
    for bad in (-0.5, 5.0, float("nan")):
        with pytest.raises(ValueError, match="forward"):
            solve((0.0, 1.0, 0.0), sun_t, bad)


def test_diffusion_sky_channels_each_solve_their_own_source() -> None:
    """The sky's colour channels share one solve's operator, each after the first started from
    the previous solution: every channel still converges to its own source's fluence — a
    channel whose source is a multiple of another's is that multiple of its fluence, and a
    channel repeating an earlier source (after a different one) gives the same fluence."""
    rng = np.random.default_rng(3)
    ext = np.zeros((16, 16, 16), F)
    ext[3:13, 2:12, 4:14] = rng.uniform(2.0, 6.0, (10, 10, 10)).astype(F)
    lo, hi = (-2.0, -2.0, -2.0), (2.0, 2.0, 2.0)
    sun_t = np.ones(ext.shape, F)
    ys = np.linspace(0.2, 1.0, 16, dtype=F)[None, :, None] * np.ones(ext.shape, F)
    xs = np.linspace(1.0, 0.3, 16, dtype=F)[None, None, :] * np.ones(ext.shape, F)
    sky_a = np.stack([ys, 2.5 * ys, 0.5 * ys], -1).astype(F)
    phi = _core.diffusion_light(ext, lo, hi, sun_t, (0.0, 1.0, 0.0), sky_a, 0.99, 0.6, 1e-6)
    inside = ext > 0.1
    r = phi[..., 1][inside]
    np.testing.assert_allclose(phi[..., 2][inside], 2.5 * r, rtol=1e-4)
    np.testing.assert_allclose(phi[..., 3][inside], 0.5 * r, rtol=1e-4)
    sky_b = np.stack([ys, xs, ys], -1).astype(F)
    phi_b = _core.diffusion_light(ext, lo, hi, sun_t, (0.0, 1.0, 0.0), sky_b, 0.99, 0.6, 1e-6)
    np.testing.assert_allclose(phi_b[..., 3][inside], phi_b[..., 1][inside], rtol=1e-4)
    np.testing.assert_allclose(phi_b[..., 1], phi[..., 1], rtol=1e-4, atol=1e-7)
    assert not np.allclose(phi_b[..., 2][inside], phi_b[..., 1][inside], rtol=0.05)


def test_sky_visibility_march_drops_only_what_is_past_six_optical_depths() -> None:
    """The sky's visibility march stops once τ > 6: a lattice with no medium to speak of is the
    open sky everywhere; at the centre of a dense cube (4 optical depths a voxel) every ray
    stops after the sample that takes it past 6, so the irradiance there is between e⁻¹⁰ and
    e⁻⁶ of the open sky (a march to τ > 12 would leave under e⁻¹²), and below its corner's."""
    coeffs = _core.sky_sh(sky_args(cu.Sky()), 3, 3)
    lo, hi = (-2.0, -2.0, -2.0), (2.0, 2.0, 2.0)
    ext = np.zeros((16, 16, 16), F)
    ext[3:13, 3:13, 3:13] = 1e-9
    open_sky = _core.sky_irradiance(ext, lo, hi, coeffs, 3, 3, 1.0, method="march")
    np.testing.assert_allclose(
        open_sky, np.broadcast_to(open_sky[0, 0, 0], open_sky.shape), rtol=1e-5
    )
    ext[3:13, 3:13, 3:13] = 16.0  # voxels of 0.25: 4 optical depths each
    e = _core.sky_irradiance(ext, lo, hi, coeffs, 3, 3, 1.0, method="march")
    for ch in range(3):
        corner, centre, sky = e[3, 3, 3, ch], e[8, 8, 8, ch], open_sky[0, 0, 0, ch]
        assert math.exp(-10) * sky <= centre <= math.exp(-6) * sky < corner < sky


# --- the C++ marcher against its numpy twin ----------------------------------------------
def _jitter(row: int, col: int, seed: int) -> F:
    s = F(5.588238) * F(seed)
    f = F(0.06711056) * (F(col) + s) + F(0.00583715) * (F(row) + s)
    g = F(52.9829189) * (f - np.floor(f))
    return F(g - np.floor(g))


def _trilinear(values: np.ndarray, lo, hi, p: np.ndarray) -> np.ndarray:
    res = np.array(values.shape[2::-1], F)
    u = (p - F(lo)) / (F(hi) - F(lo)) * res - F(0.5)
    f = np.floor(u)
    w = u - f
    i0 = np.clip(f, 0, res - 1).astype(int)
    i1 = np.clip(f + 1, 0, res - 1).astype(int)
    out = 0
    for cz in (0, 1):
        for cy in (0, 1):
            for cx in (0, 1):
                idx = (
                    np.where(cz, i1[2], i0[2]),
                    np.where(cy, i1[1], i0[1]),
                    np.where(cx, i1[0], i0[0]),
                )
                wt = (
                    (w[0] if cx else 1 - w[0])
                    * (w[1] if cy else 1 - w[1])
                    * (w[2] if cz else 1 - w[2])
                )
                out = out + wt * values[idx]
    return out


def _hg(g: float, c: float) -> float:
    d = 1 + g * g - 2 * g * c
    return (1 - g * g) / (4 * math.pi * d**1.5)


def coarsening(T_view: float) -> float:
    """The step's multiple at view transmittance ``T_view``: twice for each decade below
    ``COARSEN_BELOW``, at most ``MAX_COARSEN`` times (RENDER_CONTRACT "Physical lighting")."""
    m, limit = 1.0, params.COARSEN_BELOW
    while m < MAX_COARSEN and T_view < limit:
        m, limit = 2 * m, limit * 0.1
    return m


def numpy_physical(lit: cu.LitScene, cam: cu.Camera, w: int, h: int) -> np.ndarray:
    """RENDER_CONTRACT "Physical lighting", one pixel at a time (one spheroid cloud, no ground)."""
    scene = lit.scene
    s, cloud, light = scene.settings, scene.clouds[0], lit.lights[0]
    f, r, u = cam.basis()
    th = math.tan(math.radians(cam.fov) / 2)
    o = np.asarray(cam.position, F)
    sun = np.asarray(scene.sun.direction, F)
    e_sun = np.asarray(scene.sun.radiance, F)
    blo, bhi = (np.asarray(b, np.float64) for b in cloud.layer_box())
    step = s.step_for(float(np.linalg.norm(o - cloud.centre)))
    view, diffuse = view_depth_scale(s), view_diffuse_share(s)
    sky = scene.sky
    out = np.zeros((h, w, 4), np.float64)
    for i in range(h):
        for j in range(w):
            x = (2 * (j + 0.5) / w - 1) * th * w / h
            y = (1 - 2 * (i + 0.5) / h) * th
            d = f + x * r + y * u
            d = d / np.linalg.norm(d)
            inv = 1 / np.where(d == 0, 1e-30, d)
            ta, tb = (blo - o) * inv, (bhi - o) * inv
            t0, t1 = max(np.minimum(ta, tb).max(), 0), np.maximum(ta, tb).min()
            colour, T, T_view = np.zeros(3), 1.0, 1.0
            if t1 >= t0:
                cands = []
                for k in range(cloud.n):
                    q_o = cloud.rotations[k].T @ (o - cloud.centres[k]) / cloud.radii[k]
                    q_d = cloud.rotations[k].T @ d / cloud.radii[k]
                    a, b, c = q_d @ q_d, q_o @ q_d, q_o @ q_o - 1
                    disc = b * b - a * c
                    if disc < 0:
                        continue
                    lo_, hi_ = (
                        max((-b - math.sqrt(disc)) / a, t0),
                        min((-b + math.sqrt(disc)) / a, t1),
                    )
                    if hi_ > lo_:
                        cands.append((lo_, hi_))
                cands.sort()
                c_ = float(d @ sun)
                xi = float(_jitter(i, j, s.jitter_seed))
                tu = -np.inf
                done = False
                dt, inside = step, 0  # the step now, and the samples inside the cloud so far
                for lo_, hi_ in cands:
                    if hi_ <= tu or done:
                        continue
                    t = max(tu, lo_)
                    while t < hi_:
                        p = o + (t + xi * step) * d
                        rho_, gamma_ = cloud.density(
                            p[None].astype(F), scene.noise, **s.fbm_params()
                        )
                        rho = rho_[0]
                        if rho > 0:
                            at = math.exp(-s.extinction_scale * rho * dt)
                            # the δ-M view: the radiance sees σ·(1 − f·ϖ), diffuse light 1 − f
                            av = math.exp(-s.extinction_scale * rho * view * dt)
                            tau = light.sample_depth(p[None])[0]
                            g = _trilinear(light.grid, *light.box, p.astype(F))
                            oct_ = float(octave_sum(s, tau, c_, light.octaves))
                            sun_part = oct_ + diffuse * g[0] / (4 * math.pi)
                            src = s.albedo * (e_sun * sun_part + diffuse * g[1:] / (4 * math.pi))
                            colour += T_view * (1 - av) / view * src
                            T *= at
                            T_view *= av
                            if T_view < MIN_TRANSMITTANCE:
                                done = True
                                break
                        t += dt
                        # every COARSEN_EVERY samples inside (γ > 0), the step for T_view
                        inside += int(gamma_[0] > 0)
                        if gamma_[0] > 0 and inside % COARSEN_EVERY == 0:
                            dt = step * coarsening(T_view)
                    tu = t
            out[i, j, :3] = colour + T_view * sky.colour(d[None].astype(F), scene.sun)[0]
            out[i, j, 3] = 1 - T
    return out.astype(F)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_what_lies_behind_shows_through_the_delta_m_view(backend: str) -> None:
    """The camera's rays take the phase's forward peak as unscattered: the background shows
    through a cloud by ``T^v`` (``v = 1 − f·ϖ``), not by its coverage's ``T = 1 − α``."""
    s = PHYS.replace(sky_light=False)
    other_sky = cu.Sky(zenith=(0.9, 0.5, 0.1), horizon=(0.3, 0.9, 0.2), ground=(0.1, 0.1, 0.6))
    a, b = small_scene(s), small_scene(s, sky=other_sky)
    cam = camera_for(a)
    img_a, img_b = (cu.render(x, cam, 64, 48, backend=backend) for x in (a, b))
    bg_a, bg_b = (cu.render(x.replace(clouds=[]), cam, 64, 48, backend=backend) for x in (a, b))
    v = view_depth_scale(s)
    assert v == pytest.approx(1.0 - physical.forward_peak_share(s) * s.albedo)
    assert 0.4 < v < 0.7 and view_diffuse_share(s) == pytest.approx(
        1 - physical.forward_peak_share(s)
    )
    T = 1.0 - img_a[..., 3]
    np.testing.assert_allclose(img_b[..., 3], img_a[..., 3])  # the sky is not in the cloud's light
    partial = (T > 0.05) & (T < 0.95)
    assert partial.sum() > 20
    seen = (img_a - img_b)[..., :3][partial]
    behind = (bg_a - bg_b)[..., :3][partial]
    np.testing.assert_allclose(seen, (T[partial] ** v)[:, None] * behind, atol=2e-3)
    assert np.abs(seen - T[partial][:, None] * behind).max() > 0.02  # not the coverage's T


def test_cpu_marcher_matches_its_numpy_twin() -> None:
    scene = small_scene()
    lit = cu.prepare_light(scene)
    cam = camera_for(scene)
    cpu = cu.render_cpu(lit, cam, 16, 12)
    ref = numpy_physical(seen_from(lit, cam), cam, 16, 12)  # the drawers read the camera's view
    diff = np.abs(cpu - ref)
    assert diff.mean() < 2e-4, diff.mean()
    assert (diff.max(-1) > 0.05).mean() <= 0.02  # eq. (2)'s gate at a few samples
    assert cpu[..., 3].max() > 0.9  # the cloud is in the picture


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_rays_growing_opaque_take_coarser_steps(
    backend: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Once a ray's view transmittance is below ``COARSEN_BELOW`` its step doubles (again for each
    decade, looked at every ``COARSEN_EVERY`` samples inside the cloud): fewer samples, nearly
    the same picture, and the same steps in both marchers (the numpy twin above takes them too)."""
    assert COARSEN_EVERY == 16 and MAX_COARSEN == 8 and 0 < params.COARSEN_BELOW <= 1
    assert [coarsening(t) for t in (1.0, 0.4, 0.04, 0.004, 1e-5)] == [1, 2, 4, 8, 8]
    scene = small_scene()
    cam = camera_for(scene)
    lit = cu.prepare_light(scene)
    default = params.COARSEN_BELOW
    images, cpu, steps = {}, {}, {}
    for below in (default, 0.0):
        monkeypatch.setattr(params, "COARSEN_BELOW", below)
        images[below] = cu.render(scene, cam, 16, 12, backend=backend)
        cpu[below], stats = cu.render_cpu(lit, cam, 16, 12, return_stats=True)
        steps[below] = stats.steps
    assert steps[default] < 0.9 * steps[0.0]  # ≥ 10 % fewer samples
    change = images[default] - images[0.0]
    assert np.abs(change).max() > 1e-3 and np.abs(change).mean() < 3e-4  # real, and small
    # The GL marcher changes as the C++ marcher does.
    cpu_change = cpu[default] - cpu[0.0]
    assert np.abs(change - cpu_change).max() < 0.25 * np.abs(cpu_change).max()


def test_the_shader_keeps_the_core_constants() -> None:
    """The GLSL marcher's copies of the core's constants are the core's: ``kCoarsenEvery`` and
    ``kMaxCoarsen`` (the coarser steps), ``kMaxOctaves`` and ``kOrderPhaseSize`` (the octaves'
    arrays and the phase table's layout)."""
    text = (shader_dir() / "common" / "physical.glsl").read_text()
    names = "COARSEN_EVERY|MAX_COARSEN|MAX_OCTAVES|ORDER_PHASE_SIZE"
    defines = dict(re.findall(rf"^#define ({names}) (\S+)", text, re.M))
    assert int(defines["COARSEN_EVERY"]) == COARSEN_EVERY
    assert float(defines["MAX_COARSEN"]) == MAX_COARSEN
    assert int(defines["MAX_OCTAVES"]) == _core.MAX_OCTAVES
    assert int(defines["ORDER_PHASE_SIZE"]) == _core.ORDER_PHASE_SIZE
    # The uniform array the octaves' phases are uploaded into is as long as the table.
    assert params.ORDER_PHASE_VEC4S == (_core.MAX_OCTAVES - 1) * _core.ORDER_PHASE_SIZE // 4


def test_octaves_beyond_the_shader_arrays_are_refused() -> None:
    """``kMaxOctaves`` bounds the octaves: one more is refused, before any shader sees it."""
    p = _core.PhysicalParams()
    p.octaves = _core.MAX_OCTAVES
    p.validate()
    p.octaves = _core.MAX_OCTAVES + 1
    with pytest.raises(ValueError, match="octaves"):
        p.validate()


def test_coarsen_below_is_checked() -> None:
    p = _core.PhysicalParams()
    for bad in (-0.1, 1.5, float("nan")):
        p.coarsen_below = bad
        with pytest.raises(ValueError, match="coarsen_below"):
            p.validate()


def test_physical_images_are_deterministic_and_jittered() -> None:
    scene = small_scene()
    cam = camera_for(scene)
    lit = cu.prepare_light(scene)
    a = cu.render_cpu(lit, cam, 32, 24, threads=1)
    np.testing.assert_array_equal(a, cu.render_cpu(lit, cam, 32, 24, threads=2))
    lit2 = cu.prepare_light(scene.replace(settings=PHYS.replace(jitter_seed=7)))
    b = cu.render_cpu(lit2, cam, 32, 24)
    assert np.abs(a - b).max() > 1e-3  # another seed moves the samples
    assert abs(a[..., :3].mean() - b[..., :3].mean()) < 0.02 * a[..., :3].mean()
    assert (a >= 0).all() and np.isfinite(a).all()


def test_physical_alpha_is_the_paper_modes_opacity() -> None:
    """σt = extinction_scale·ρ with the default 12 = absorption/step_ref: the same geometry."""
    scene = small_scene(settings=PHYS.replace(march="union"))
    cam = camera_for(scene)
    phys = cu.render_cpu(scene, cam, 48, 36)
    paper = cu.render_cpu(
        scene.replace(settings=cu.RenderSettings(march="union", lighting="paper")), cam, 48, 36
    )
    assert np.abs(phys[..., 3] - paper[..., 3]).mean() < 0.01


def test_the_sun_lights_the_side_facing_it() -> None:
    black = cu.Sky(zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0))
    halves = []
    for x in (0.8, -0.8):
        scene = small_scene(settings=PHYS.replace(sky_light=False), sky=black)
        scene = scene.replace(sun=cu.Sun(direction=(x, 0.45, 0.0), intensity=5.0))
        lo, hi = scene.bounds()
        c = (lo + hi) / 2
        cam = cu.Camera(position=(float(c[0]), float(c[1]), -45.0), target=tuple(c), fov=35)
        img = cu.render_cpu(scene, cam, 48, 36)
        lum = np.where(img[..., 3] > 0.5, img[..., :3].mean(-1), np.nan)
        halves.append((np.nanmean(lum[:, :24]), np.nanmean(lum[:, 24:])))
    # +x is on the left of a camera looking along +z: that half is lit by the first sun.
    (left_a, right_a), (left_b, right_b) = halves
    assert left_a > 2 * left_b and right_b > right_a


def test_a_sun_overhead_lights_like_one_just_off_it() -> None:
    """The sun lattice's frame takes its first axis from +y, or from +x where the light runs
    within about 26° of vertical (|w·y| ≥ 0.9): a sun either side of the switch, and one
    straight overhead, light the cloud alike (no degenerate frame darkens a top-lit cloud)."""
    means = []
    switch = math.degrees(math.asin(0.9))
    for elevation in (switch - 0.05, switch + 0.05, 89.95, 90.0):
        e = math.radians(elevation)
        sun = cu.Sun(direction=(math.cos(e), math.sin(e), 0.0), intensity=5.0)
        scene = small_scene().replace(sun=sun)
        img = cu.render_cpu(scene, camera_for(scene), 48, 36)
        means.append(float(img[..., :3].mean()))
    assert means[0] == pytest.approx(means[1], rel=0.01)
    assert means[2] == pytest.approx(means[3], rel=0.01)
    assert means[3] > 0.0


# --- GL against C++, the volume renderer against the marcher ------------------------------
@pytest.mark.gl
def test_gl_physical_matches_cpu(gl_context) -> None:
    two = small_scene().replace(clouds=[small_cloud(), small_cloud().translated((9, 3, 6))])
    for scene in (small_scene(), two):
        cam = camera_for(scene)
        lit = cu.prepare_light(scene)
        with cu.Renderer(context=gl_context) as r:
            gl = r.render(lit, cam, 48, 36)
        cpu = cu.render_cpu(lit, cam, 48, 36)
        diff = np.abs(gl - cpu)
        assert diff.mean(axis=(0, 1)).max() <= 1e-3
        assert (diff.max(-1) > 5e-2).mean() <= 0.01


def test_gl_and_cpu_add_the_other_clouds_shadow_alike(gl_context) -> None:
    """A cloud shaded by another keeps the other's depth as a per-column map: the GL atlas adds
    it as it is filled, the CPU drawer as it reads; both draw the same shaded cloud."""
    first = small_cloud()
    lo, hi = first.layer_box()
    sun = np.asarray(SUN.direction)
    upstream = first.translated(tuple(float(v) for v in sun * 1.2 * float(np.max(hi - lo))))
    scene = small_scene().replace(clouds=[first, upstream])
    lit = cu.prepare_light(scene)
    assert lit.lights[0].upstream is not None and lit.lights[0].upstream.max() > 5
    alone = cu.prepare_light(small_scene())
    cam = camera_for(small_scene())
    with cu.Renderer(context=gl_context) as r:
        gl = r.render(lit, cam, 48, 36)
        gl_alone = r.render(alone, cam, 48, 36)
    cpu = cu.render_cpu(lit, cam, 48, 36)
    diff = np.abs(gl - cpu)
    assert diff.mean(axis=(0, 1)).max() <= 1e-3
    assert (diff.max(-1) > 5e-2).mean() <= 0.01
    # The shadow shows: the first cloud is darker under the other than alone.
    assert gl[..., :3].mean() < 0.97 * gl_alone[..., :3].mean()


@pytest.mark.gl
def test_volume_renderer_draws_the_same_medium(gl_context) -> None:
    scene = small_scene()
    cam = camera_for(scene)
    field = cu.density_volume(scene.clouds[0], scene.noise, scene.settings, 96)
    # The field's values are σt already; read trilinearly and not eroded, it is the same medium.
    vc = cu.VolumeCloud(density=field.values, box=field.box, sigma_t=1.0, step=0.1, detail=0.0,
                        reconstruction="linear")  # fmt: skip
    vscene = scene.replace(clouds=[vc])
    lit = cu.prepare_light(vscene)
    cpu = cu.render_cpu(lit, cam, 48, 36)
    with cu.Renderer(context=gl_context) as r:
        gl = r.render(lit, cam, 48, 36)
    assert_image_close(gl, cpu, **only(channel_mean_abs=1e-3))
    marcher = cu.render_cpu(scene, cam, 48, 36)
    cov = marcher[..., 3] > 0.5
    assert cov.mean() > 0.05
    assert np.abs(cpu[..., 3] - marcher[..., 3]).mean() < 0.02
    ratio = cpu[cov, :3].mean() / marcher[cov, :3].mean()
    assert abs(ratio - 1) < 0.1, ratio
    # render_volume takes the settings too.
    img = cu.render_volume(
        field.values,
        None,
        field.box,
        cam,
        48,
        36,
        scene.sun,
        scene.sky,
        backend="cpu",
        sigma_t=1.0,
        step=0.1,
        settings=scene.settings,
        detail=0.0,
        reconstruction="linear",
    )
    np.testing.assert_allclose(img, cpu, atol=1e-5)


def test_light_step_does_not_depend_on_the_thread_count() -> None:
    scene = small_scene()
    a = physical_light(scene.clouds[0], scene, threads=1)
    b = physical_light(scene.clouds[0], scene, threads=2)
    np.testing.assert_array_equal(a.sun_depth, b.sun_depth)
    np.testing.assert_array_equal(a.grid, b.grid)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_an_empty_physical_scene_is_its_background(backend: str) -> None:
    empty = cu.Scene([], sun=SUN, settings=PHYS)
    cam = cu.Camera(position=(0, 2, -10), target=(0, 0, 0), fov=50)
    img = cu.render(empty, cam, 16, 12, backend=backend)
    ref = cu.render(
        empty.replace(settings=cu.RenderSettings(lighting="paper")), cam, 16, 12, backend="cpu"
    )
    np.testing.assert_allclose(img, ref, atol=1e-6)
    assert (img[..., 3] == 0).all()


def test_render_volume_bad_input() -> None:
    dens = np.ones((4, 4, 4), F)
    cam = cu.Camera(position=(0, 0, -10), target=(0, 0, 0), fov=40)
    box = ((-1, -1, -1), (1, 1, 1))
    with pytest.raises(ValueError, match="light is required"):
        cu.render_volume(dens, None, box, cam, 8, 6, settings=cu.RenderSettings(lighting="paper"))
    with pytest.raises(TypeError, match="settings"):
        cu.render_volume(dens, None, box, cam, 8, 6, settings="physical")
    img = cu.render_volume(dens, None, box, cam, 8, 6, settings=PHYS, sigma_t=1.0)
    # σt = sigma_t·density = 1 through the 2-unit cube: alpha = 1 − e^{−2} at the centre.
    assert img.shape == (6, 8, 4) and img[3, 4, 3] == pytest.approx(1 - math.exp(-2), rel=0.01)


def test_clouds_shade_each_other() -> None:
    """A second cloud between the sun and the first darkens the first's sun lattice."""
    first = small_cloud()
    lo, hi = first.layer_box()
    sun = np.asarray(SUN.direction)
    upstream = first.translated(tuple(float(v) for v in sun * 1.2 * float(np.max(hi - lo))))
    alone = small_scene()
    both = alone.replace(clouds=[first, upstream])
    a = cu.prepare_light(alone).lights[0]
    b = cu.prepare_light(both).lights[0]
    assert a.sun_depth.shape == b.sun_depth.shape and a.upstream is None
    # The shaded cloud keeps its own lattice and a map of the other's depth per column.
    np.testing.assert_array_equal(b.sun_depth, a.sun_depth)
    assert b.upstream.shape == a.sun_depth.shape[1:]
    extra = b.total_depth() - a.total_depth()
    assert (extra >= -1e-4).all() and extra.max() > 5  # some columns pass through the other cloud
    # The same all along each column (up to float32 rounding of the sums).
    np.testing.assert_allclose(extra.min(axis=0), extra.max(axis=0), atol=1e-3, rtol=1e-5)
    # Every reader adds the map: sampled depth, and the transmittance the drawers see.
    nodes = frame_nodes(b.frame, b.sun_depth.shape)
    np.testing.assert_allclose(
        b.sample_depth(nodes), b.total_depth().reshape(-1), rtol=1e-4, atol=1e-4
    )


def test_only_clouds_upstream_of_a_lattice_shade_it() -> None:
    """Clouds beside or downstream of a cloud's sun lattice are culled (linear in clouds), a cloud
    upstream is kept, and culling changes no light: the light with every other cloud marched
    equals the light with only the upstream one."""
    from cumuli.light.physical import upstream_of

    first = small_cloud()
    lo, hi = first.layer_box()
    size = float(np.max(hi - lo))
    sun = np.asarray(SUN.direction)
    upstream = first.translated(tuple(float(v) for v in sun * 1.2 * size))
    downstream = first.translated(tuple(float(v) for v in -sun * 1.2 * size))
    beside = first.translated((0.0, 0.0, 3.0 * size))
    scene = small_scene().replace(clouds=[first, upstream, downstream, beside])
    frame = physical_light(first, small_scene()).frame
    assert upstream_of(frame, [upstream, downstream, beside]) == [upstream]
    culled = physical_light(first, scene)
    only_upstream = physical_light(first, small_scene().replace(clouds=[first, upstream]))
    np.testing.assert_array_equal(culled.sun_depth, only_upstream.sun_depth)
    np.testing.assert_array_equal(culled.upstream, only_upstream.upstream)
    np.testing.assert_array_equal(culled.grid, only_upstream.grid)
    alone = physical_light(first, small_scene())
    assert (culled.total_depth() - alone.total_depth()).max() > 5
    # The light step's memo keys a light by the clouds upstream of it: moving the cloud beside
    # reuses the first cloud's light, moving the upstream one relights it.
    cu.light.prepare.clear_memo()
    before = cu.prepare_light(scene).lights[0]
    moved_beside = scene.replace(clouds=[first, upstream, downstream, beside.translated((1, 0, 0))])
    assert cu.prepare_light(moved_beside).lights[0] is before
    moved_up = scene.replace(clouds=[first, upstream.translated((0.5, 0, 0)), downstream, beside])
    assert cu.prepare_light(moved_up).lights[0] is not before


def test_other_clouds_shadow_is_read_from_their_own_sun_lattices() -> None:
    """The optical depth of the clouds upstream is each one's own sun lattice (the same axes)
    read at the column's face point: close to a march from every column's face through them,
    and zero across the light outside their lattice."""
    from cumuli.light import physical as ph

    first = small_cloud()
    lo, hi = first.layer_box()
    sun = np.asarray(SUN.direction)
    upstream = first.translated(tuple(float(v) for v in sun * 1.2 * float(np.max(hi - lo))))
    scene = small_scene().replace(clouds=[first, upstream])
    frame = physical_light(first, small_scene()).frame
    step = scene.settings.light_step
    shared = ph._upstream_depth([upstream], scene, frame, 0)
    u, v, w, flo, fhi, (nu, nv, _) = frame
    fu = flo[0] + (np.arange(nu) + 0.5) * (fhi[0] - flo[0]) / nu
    fv = flo[1] + (np.arange(nv) + 0.5) * (fhi[1] - flo[1]) / nv
    gv, gu = np.meshgrid(fv, fu, indexing="ij")
    pts = (gu[..., None] * np.asarray(u) + gv[..., None] * np.asarray(v)
           + flo[2] * np.asarray(w)).reshape(-1, 3).astype(np.float32)  # fmt: skip
    # A march from every face point, until τ passes the lattices' cut (no light is left).
    full = ph.optical_depth([upstream], scene, pts, SUN.direction, step, 0).reshape(nv, nu)
    full = np.minimum(full, ph.SUN_DEPTH_CUT)
    shared = np.minimum(shared, ph.SUN_DEPTH_CUT)
    assert shared.shape == full.shape and full.max() > 5
    assert np.abs(shared - full).mean() < 0.03 * full.max()
    assert shared.sum() == pytest.approx(full.sum(), rel=0.03)
    # Each cloud's own lattice is marched once and shared: the light of the first reuses it.
    frame_up, depth_up = ph.own_sun_depth(upstream, scene)
    assert ph.own_sun_depth(upstream, scene)[1] is depth_up
    assert not depth_up.flags.writeable
    # Away from the upstream cloud across the light, nothing: a cloud beside it is not shaded.
    aside = first.translated((10.0 * float(np.max(hi - lo)), 0.0, 0.0))
    assert not ph._upstream_depth([aside], scene.replace(clouds=[first, aside]), frame, 0).any()
