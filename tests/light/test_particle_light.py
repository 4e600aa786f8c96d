"""Harris 2002 light pass: C++ reference against a numpy slow
reference, the analytic column / offset / continuum results, monotonicity, invariances, the
energy check, GLSL compute and 2002 read-back parity, threads, convergence in N_L, skylight."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.light.particles import (
    ParticleLight,
    SpriteSettings,
    light_is_stale,
    particle_light,
    particle_light_many,
    phase_values,
    skylight_lights,
)
from cumuli.model.particles import ParticleCloud, particle_cumulus

F = np.float32
FOUR_PI = F(12.566370614359172)


# --- numpy slow reference (float32, the C++ operation order) ----------------------------------
def _normalize(v: np.ndarray) -> np.ndarray:
    d = (v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]
    return (v * (F(1) / np.sqrt(d))).astype(F)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array(
        [a[1] * b[2] - b[1] * a[2], a[2] * b[0] - b[2] * a[0], a[0] * b[1] - b[0] * a[1]], dtype=F
    )


def _dot(a: np.ndarray, b: np.ndarray) -> F:
    return F((a[0] * b[0] + a[1] * b[1]) + a[2] * b[2])


def _kernel(kind: str, peak: float, d: F) -> F:
    if not d < 1:
        return F(0)
    d2 = F(d * d)
    if kind == "hermite":
        return F(F(peak) * F(F(F(1) - F(3) * d2) + F(F(2) * d2) * d))
    tail = F(0.011108996538242306)
    return F(F(peak) * F(F(np.exp(F(-4.5) * d2) - tail) / F(F(1) - tail)))


def reference_light(pc: ParticleCloud, sun: np.ndarray, s: SpriteSettings) -> np.ndarray:
    """The spec §4 algorithm written out in numpy float32, one light, readback pixel/bilinear."""
    c_, r_, tau, alb = pc.core_args()
    n, nl = pc.n, s.light_resolution
    lo = (c_ - r_[:, None]).min(0)
    hi = (c_ + r_[:, None]).max(0)
    centre = ((lo + hi) * F(0.5)).astype(F)
    rb = F(0)
    for k in range(n):
        v = (c_[k] - centre).astype(F)
        rb = max(rb, F(np.sqrt(_dot(v, v)) + r_[k]))
    f = -_normalize(np.asarray(sun, dtype=F))
    up = np.array([1, 0, 0] if abs(f[1]) > F(1) - F(1e-6) else [0, 1, 0], dtype=F)
    right = _normalize(_cross(f, up))
    upv = _cross(right, f)
    p_fwd = {"rayleigh": F(0.75) * F(2), "isotropic": F(1)}[s.phase]
    two_r, nlf = F(2) * rb, F(nl)
    x, y, t, rpx, fwd, alpha = (np.zeros(n, F) for _ in range(6))
    for k in range(n):
        v = (c_[k] - centre).astype(F)
        t[k] = _dot(v, f)
        x[k] = F(F(_dot(v, right) + rb) / two_r) * nlf
        y[k] = F(F(_dot(v, upv) + rb) / two_r) * nlf
        rpx[k] = F(r_[k] * nlf) / two_r
        fwd[k] = F(F(F(F(alb[k] * tau[k]) * p_fwd) * F(s.solid_angle)) / FOUR_PI) * s.forward
        alpha[k] = F(1) - F(np.exp(-tau[k]))
    buf = np.ones((nl, nl), F)
    out = np.zeros(n, F)
    for k in sorted(range(n), key=lambda k: (t[k], k)):
        if s.readback == "pixel":
            ix, iy = (int(np.clip(np.floor(q), 0, nl - 1)) for q in (x[k], y[k]))
            intensity = buf[iy, ix]
        else:
            u, w = F(x[k] - F(0.5)), F(y[k] - F(0.5))
            fu, fw = np.floor(u), np.floor(w)
            wx, wy = F(u - fu), F(w - fw)
            x0, x1 = int(np.clip(fu, 0, nl - 1)), int(np.clip(fu + 1, 0, nl - 1))
            y0, y1 = int(np.clip(fw, 0, nl - 1)), int(np.clip(fw + 1, 0, nl - 1))

            def lerp(a: F, b: F, q: F) -> F:
                return F(a + F(q * F(b - a)))

            intensity = lerp(
                lerp(buf[y0, x0], buf[y0, x1], wx), lerp(buf[y1, x0], buf[y1, x1], wx), wy
            )
        out[k] = intensity
        g = F(fwd[k] * intensity)
        for iy in range(nl):
            for ix in range(nl):
                dx, dy = F(F(ix) + F(0.5)) - x[k], F(F(iy) + F(0.5)) - y[k]
                d = F(np.sqrt(F(dx * dx + dy * dy)) / rpx[k])
                if d < 1:
                    wk = _kernel(s.kernel, s.peak, d)
                    buf[iy, ix] = F(F(wk * g) + F(F(F(1) - F(wk * alpha[k])) * buf[iy, ix]))
    return out


def tiny_cloud(seed: int, n: int = 30) -> ParticleCloud:
    rng = np.random.default_rng(seed)
    return ParticleCloud(
        rng.normal(size=(n, 3)) * 2,
        rng.uniform(0.4, 1.5, n),
        rng.uniform(0.5, 8, n),
        rng.uniform(0.3, 1, n),
    )


@pytest.mark.parametrize("readback", ["pixel", "bilinear"])
@pytest.mark.parametrize("kernel", ["gaussian", "hermite"])
@pytest.mark.parametrize("sun", [(0.3, 0.8, 0.2), (0.0, 1.0, 0.0), (-0.5, -0.2, 0.7)])
def test_cpp_matches_numpy_reference(readback: str, kernel: str, sun: tuple) -> None:
    s = SpriteSettings(light_resolution=8, readback=readback, kernel=kernel, peak=0.9)
    pc = tiny_cloud(3)
    got = particle_light(pc, cu.Sun(sun), s).light[:, 0]
    want = reference_light(pc, np.array(cu.Sun(sun).direction), s)
    assert np.abs(got - want).max() <= 1e-6


def test_unshadowed_particle_reads_exactly_one() -> None:
    """§10.1.1: a particle whose read-back point no earlier footprint covers gets i = 1."""
    pc = tiny_cloud(5, 40)
    s = SpriteSettings(light_resolution=16)
    light = particle_light(pc, cu.Sun(), s).light[:, 0]
    geom, index, _patch, _fr, _r = _core.particle_light_splats(
        *pc.core_args(), np.array([cu.Sun().direction], np.float32), s.light_dict()
    )
    g = geom[0]
    covered = np.zeros(pc.n, bool)
    for k in range(pc.n):
        px = np.floor(g[k, :2]) + 0.5
        d = np.hypot(*(px - g[:k, :2]).T) / g[:k, 2]
        covered[index[0, k]] = bool((d < 1).any())
    assert (~covered).sum() >= 3 and covered.sum() >= 3
    assert (light[~covered] == 1.0).all()
    assert (light[covered] < 1.0).all()


def column(n: int, tau: float, albedo: float = 0.9, spacing: float = 0.5) -> ParticleCloud:
    """n equal particles on the light ray x = y = 0 (light along −z, nearest the light first)."""
    z = -spacing * np.arange(n, dtype=np.float64)
    return ParticleCloud(np.stack([np.zeros(n), np.zeros(n), z], 1), 1.0, tau, albedo)


SUN_Z = cu.Sun((0.0, 0.0, 1.0))
# N_L = 9 puts a centred column on the centre of pixel 4: w = K(0) = peak exactly.
COLUMN = SpriteSettings(light_resolution=9)


@pytest.mark.parametrize("tau", [1.0, 8.0])
def test_column_recurrence(tau: float) -> None:
    """§10.1.2: i_k = m^{k−1}, m = e^{−τ} + aτ p_fwd γ/4π (eqs. (3)/(4))."""
    n = 40
    light = particle_light(column(n, tau), SUN_Z, COLUMN).light[:, 0].astype(np.float64)
    m = math.exp(-tau) + 0.9 * tau * 1.5 / (4 * math.pi)
    k = np.arange(n)
    assert np.all(np.abs(light / m**k - 1) <= 1e-6 * (k + 1))


def test_column_single_scattering() -> None:
    """§10.1.2 with forward=False: i_k = e^{−(k−1)τ} ([H] Fig. 10's dark clouds)."""
    s = SpriteSettings(light_resolution=9, forward=False)
    for tau, tol in ((1.0, 1e-6), (8.0, 2e-4)):  # α = 1 − e^{−8} holds e^{−8} to ~2e−4
        light = particle_light(column(10, tau), SUN_Z, s).light[:, 0].astype(np.float64)
        k = np.arange(10)
        assert np.all(np.abs(light / np.exp(-k * tau) - 1) <= tol * (k + 1))


@pytest.mark.parametrize("kernel", ["gaussian", "hermite"])
def test_offset_pair_recovers_kernel_profile(kernel: str) -> None:
    """§10.1.3: i₂ = 1 − K(ρ/r_px)(α − aτ p_fwd γ/4π) for a second particle ρ pixels aside."""
    s = SpriteSettings(light_resolution=32, kernel=kernel)
    alpha = 1 - math.exp(-8.0)
    fwd = 0.9 * 8.0 * 1.5 / (4 * math.pi)
    anchors = [(-6.0, -6.0, -9.0), (6.0, 6.0, -9.0)]  # fix the light box whatever the offset
    for offset in np.linspace(0.0, 1.6, 9):
        pc = ParticleCloud([(0.0, 0.0, 0.0), (offset, 0.0, -1.0), *anchors], [1.2, 1.2, 0.5, 0.5])
        light = particle_light(pc, SUN_Z, s).light[:, 0]
        geom, index, *_ = _core.particle_light_splats(
            *pc.core_args(), np.array([SUN_Z.direction], np.float32), s.light_dict()
        )
        first, second = (geom[0][list(index[0]).index(i)] for i in (0, 1))
        pixel = np.floor(second[:2]) + 0.5
        d = float(np.hypot(*(pixel - first[:2])) / first[2])
        kd = float(_core.splat_kernel(kernel, 1.0, np.array([d], np.float32))[0])
        assert light[1] == pytest.approx(1 - kd * (alpha - fwd), abs=1e-6)


def test_continuum_limit_first_order() -> None:
    """§10.1.4: τ = σD/N stacked, I_N → exp(−σD(1 − a p_fwd γ/4π)) with an O(1/N) error."""
    sigma_d, a = 2.0, 0.9
    limit = math.exp(-sigma_d * (1 - a * 1.5 / (4 * math.pi)))
    errors = {}
    for n in (10, 100, 1000, 10000):
        light = particle_light(column(n, sigma_d / n, a, 0.01), SUN_Z, COLUMN).light[:, 0]
        errors[n] = abs(float(light[-1]) - limit)
    assert errors[10] > errors[100] > errors[1000] > errors[10000]
    scaled = [errors[n] * n for n in (10, 100, 1000)]
    assert max(scaled) / min(scaled) < 1.5  # first order in 1/N
    assert errors[10000] < 1e-4


def test_monotone_in_albedo_gamma_and_tau() -> None:
    """§10.1.5: i non-decreasing in albedo and γ; non-increasing in τ when a = 0."""
    pc = particle_cumulus(n_particles=150, seed=2)
    c, r = pc.centres, pc.radii
    base = particle_light(pc, cu.Sun()).light
    brighter = particle_light(ParticleCloud(c, r, 8.0, 1.0), cu.Sun()).light
    assert (brighter >= base).all() and (brighter > base).any()
    wider = particle_light(pc, cu.Sun(), SpriteSettings(solid_angle=1.05)).light
    assert (wider >= base).all() and (wider > base).any()
    thin = particle_light(ParticleCloud(c, r, 2.0, 0.0), cu.Sun()).light
    thick = particle_light(ParticleCloud(c, r, 4.0, 0.0), cu.Sun()).light
    assert (thick <= thin).all() and (thick < thin).any()


def test_adding_a_particle_never_raises_light_without_forward_scattering() -> None:
    """§10.1.5: with forward=False (m = 1 − wα ≤ 1 everywhere) an extra particle only darkens."""
    pc = particle_cumulus(n_particles=150, seed=4)
    s = SpriteSettings(forward=False)
    before = particle_light(pc, cu.Sun(), s).light
    lo, hi = pc.bounds()
    rng = np.random.default_rng(1)
    for _ in range(10):  # inside the box, small: the light box stays the same
        p = lo + 3 + rng.random(3) * (hi - lo - 6)
        more = ParticleCloud(np.vstack([pc.centres, p]), np.append(pc.radii, 0.5), 8.0, 0.9)
        after = particle_light(more, cu.Sun(), s).light[:-1]
        assert (after <= before).all()


def test_forward_scattering_splat_can_raise_a_shadowed_neighbour() -> None:
    """Finding (spec §10.1.5 "adding a particle never raises any i" needs a caveat): with forward
    scattering a splat adds w·g (g from its own, lit, centre pixel) to every footprint pixel, so it
    lifts a neighbouring pixel darker than g/α; a particle later reading that pixel gets more
    light. Along one read-back pixel (the column) adding particles never raises i."""
    s = SpriteSettings(light_resolution=9)
    base = [(0, 0, 4), (0, 0, 3), (0, 0, -4), (3, 0, -4.5), (-3, 0, -4.5)]
    before = particle_light(ParticleCloud(base, 1.0), SUN_Z, s).light[:, 0]
    extra = ParticleCloud([*base, (1.4, 0, 0)], [1.0] * 5 + [2.0])
    after = particle_light(extra, SUN_Z, s).light[:-1, 0]
    assert after[2] > before[2] + 0.01  # the probe behind two particles gets brighter
    col = particle_light(column(12, 8.0), SUN_Z, COLUMN).light[:, 0]
    assert (np.diff(col) <= 0).all()


def test_order_and_translation_invariance() -> None:
    """§10.1.6: permuting the particles permutes the light (bit for bit); translating cloud and
    light changes nothing (dyadic coordinates keep the float32 differences exact)."""
    rng = np.random.default_rng(9)
    c = np.round(rng.normal(size=(60, 3)) * 3 * 64) / 64
    pc = ParticleCloud(c, np.round(rng.uniform(0.5, 1.5, 60) * 64) / 64, 6.0, 0.8)
    lights = [cu.Sun(), cu.Sun((-0.2, 0.5, 0.9))]
    base = particle_light(pc, lights).light
    perm = rng.permutation(60)
    shuffled = ParticleCloud(pc.centres[perm], pc.radii[perm], 6.0, 0.8)
    assert np.array_equal(particle_light(shuffled, lights).light, base[perm])
    moved = particle_light(pc.translated((64.0, -32.0, 128.0)), lights).light
    assert np.array_equal(moved, base)


def test_energy_check() -> None:
    """§10.1.7: a τ p_fwd γ/4π > α raises naming solid_angle unless allow_gain; clamp caps."""
    pc = particle_cumulus(n_particles=100, seed=1)
    hg = SpriteSettings(phase="hg", hg_g=0.6)  # p_fwd = 10: 0.9·8·10/4π = 5.7 > α
    with pytest.raises(ValueError, match="solid_angle"):
        particle_light(pc, cu.Sun(), hg)
    gain = particle_light(pc, cu.Sun(), SpriteSettings(phase="hg", allow_gain=True)).light
    assert gain.max() > 1.0
    clamped = SpriteSettings(phase="hg", allow_gain=True, clamp=True)
    assert particle_light(pc, cu.Sun(), clamped).light.max() <= 1.0
    small = SpriteSettings(phase="hg", solid_angle=0.1)  # 0.57 ≤ α: fine
    assert particle_light(pc, cu.Sun(), small).light.max() <= 1.0


def test_quantize_rounds_to_eighths_of_255() -> None:
    pc = particle_cumulus(n_particles=100, seed=1)
    light = particle_light(pc, cu.Sun(), SpriteSettings(quantize=8)).light
    assert np.allclose(light * 255, np.round(light * 255), atol=1e-4)
    plain = particle_light(pc, cu.Sun()).light
    assert 0 < np.abs(light - plain).max() < 0.05


def test_thread_count_independence_and_many_clouds() -> None:
    """§10.1.9: bit-identical for any thread count; clouds × lights share the threads."""
    clouds = [particle_cumulus((0, 0, 0), 120, seed=s) for s in (1, 2, 3)]
    lights = [cu.Sun(), cu.Sun((0.5, 0.5, -0.5)), cu.Sun((-0.1, 0.2, 0.9))]
    one = particle_light_many(clouds, lights, threads=1, return_buffers=True)
    for threads in (2, 0):
        other = particle_light_many(clouds, lights, threads=threads, return_buffers=True)
        for a, b in zip(one, other, strict=True):
            assert np.array_equal(a.light, b.light) and np.array_equal(a.buffers, b.buffers)
    for cloud, res in zip(clouds, one, strict=True):
        single = particle_light(cloud, lights[1])
        assert np.array_equal(single.light[:, 0], res.light[:, 1])


def test_convergence_in_light_resolution() -> None:
    """§10.1.10: with bilinear read-back the mean |Δi| between N_L and 2N_L shrinks as N_L
    doubles."""
    pc = particle_cumulus(n_particles=200, seed=0)
    lights = {
        nl: particle_light(pc, cu.Sun(), SpriteSettings(readback="bilinear", light_resolution=nl))
        for nl in (32, 64, 128, 256, 512)
    }
    deltas = [np.abs(lights[2 * nl].light - lights[nl].light).mean() for nl in (32, 64, 128, 256)]
    print("mean |Δi| 32→64→128→256→512:", deltas)
    assert all(b < a for a, b in zip(deltas, deltas[1:], strict=False))


def test_buffers_are_the_shadow_map() -> None:
    """§10.3.9: the final buffer is in [0, 1], 1 outside every footprint and m^N under a column."""
    light = particle_light(column(5, 8.0), SUN_Z, COLUMN, return_buffers=True)
    buf = light.buffers[0]
    assert buf.shape == (9, 9) and 0 <= buf.min() and buf.max() <= 1
    m = math.exp(-8.0) + 0.9 * 8 * 1.5 / (4 * math.pi)
    assert buf[4, 4] == pytest.approx(m**5, rel=1e-5)
    assert buf[0, 0] == 1.0


def test_stale_light_detection() -> None:
    pc = particle_cumulus(n_particles=80, seed=1)
    sun = cu.Sun()
    light = particle_light(pc, sun)
    assert light_is_stale(light, pc, sun) is None
    assert light_is_stale(None, pc, sun) == "missing"
    assert light_is_stale(light, pc.translated((3, 0, 0)), sun) is None
    assert light_is_stale(light, pc.scaled(1.5), sun) == "particles"
    assert light_is_stale(light, pc, cu.Sun((0.31, 0.8, 0.2))) == "lights"
    assert light_is_stale(light, pc, [sun, sun]) == "lights"
    loose = SpriteSettings(relight_tolerance=2.0)
    assert light_is_stale(light, pc, cu.Sun((0.31, 0.8, 0.2)), loose) is None
    assert light_is_stale(light, pc, sun, SpriteSettings(light_resolution=64)) == "settings"
    assert isinstance(light, ParticleLight) and not light.light.flags.writeable


def test_skylight_lights() -> None:
    sky, sun = cu.Sky(), cu.Sun()
    lights = skylight_lights(sky, sun, n=8, strength=2.0, elevation_min=10)
    assert len(lights) == 8
    ys = np.array([s.direction[1] for s in lights])
    assert (ys >= math.sin(math.radians(10)) - 1e-9).all() and len(set(np.round(ys, 6))) == 8
    omega = 2 * math.pi * (1 - math.sin(math.radians(10)))
    assert all(s.intensity == pytest.approx(2.0 * omega / 8) for s in lights)
    no_disc = cu.Sky(sun_disc_intensity=0.0)
    for s in lights:
        want = no_disc.colour(np.array([s.direction], np.float32), sun)[0]
        assert np.allclose(s.colour, want, atol=1e-6)
    light = particle_light(particle_cumulus(n_particles=60, seed=1), [sun, *lights])
    assert light.light.shape == (60, 9)
    for bad in ({"n": 0}, {"strength": -1.0}, {"elevation_min": 90.0}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            skylight_lights(sky, sun, **bad)
    with pytest.raises(TypeError, match="sky"):
        skylight_lights("sky", sun)  # type: ignore[arg-type]


def test_phase_values_cpu() -> None:
    c = np.linspace(-1, 1, 101, dtype=np.float32)
    assert np.allclose(
        phase_values("rayleigh", c), 0.75 * (1 + c.astype(np.float64) ** 2), rtol=1e-6
    )
    assert (phase_values("isotropic", c) == 1).all()
    g = 0.6
    want = (1 - g * g) / (1 + g * g - 2 * g * c.astype(np.float64)) ** 1.5
    assert np.allclose(phase_values("hg", c, g), want, rtol=1e-5)
    # ∫p dω = 4π (2π ∫ p dc over [−1, 1]).
    fine = np.linspace(-1, 1, 200001)
    for phase in ("rayleigh", "isotropic", "hg"):
        vals = phase_values(phase, fine, 0.3).astype(np.float64)
        integral = 2 * math.pi * np.sum((vals[1:] + vals[:-1]) / 2 * np.diff(fine))
        assert integral == pytest.approx(4 * math.pi, rel=1e-4)
    with pytest.raises(ValueError, match="cos_theta"):
        phase_values("rayleigh", [1.5])
    with pytest.raises(ValueError, match="phase"):
        phase_values("mie", [0.0])


# --- GL twins -----------------------------------------------------------------------------------
GL_CASES = [
    SpriteSettings(),
    SpriteSettings(readback="bilinear", kernel="hermite", peak=0.4, light_resolution=48),
    SpriteSettings.preset("skyworks"),
    SpriteSettings(forward=False, quantize=8),
    SpriteSettings(phase="hg", solid_angle=0.05, clamp=True),
]


@pytest.mark.gl
@pytest.mark.parametrize("settings", GL_CASES, ids=lambda s: f"{s.readback}-{s.kernel}")
def test_glsl_compute_matches_cpp(gl_context, settings: SpriteSettings) -> None:
    """§10.1.8: the compute twin agrees with the C++ to ≤ 1e−6 (light and buffers)."""
    pc = particle_cumulus(n_particles=300, seed=5)
    lights = [cu.Sun(), cu.Sun((0.0, 1.0, 0.0)), cu.Sun((-0.7, 0.1, 0.3))]
    cpu = particle_light(pc, lights, settings, return_buffers=True)
    gl = particle_light(pc, lights, settings, method="gl", return_buffers=True, context=gl_context)
    assert np.abs(gl.light - cpu.light).max() <= 1e-6
    assert np.abs(gl.buffers - cpu.buffers).max() <= 1e-6


@pytest.mark.gl
@pytest.mark.parametrize("settings", GL_CASES[:3], ids=lambda s: f"{s.readback}-{s.kernel}")
def test_readback_path_matches_cpp(gl_context, settings: SpriteSettings) -> None:
    """§10.1.8: [H]'s own algorithm (blended quads, one read per particle) gives the C++'s."""
    pc = particle_cumulus(n_particles=120, seed=6)
    lights = [cu.Sun(), cu.Sun((0.2, -0.9, 0.1))]
    cpu = particle_light(pc, lights, settings, return_buffers=True)
    rb = particle_light(
        pc, lights, settings, method="readback", return_buffers=True, context=gl_context
    )
    assert np.abs(rb.light - cpu.light).max() <= 1e-6
    assert np.abs(rb.buffers - cpu.buffers).max() <= 1e-6


@pytest.mark.gl
def test_glsl_compute_beyond_llvmpipe_loop_limit(gl_context) -> None:
    """llvmpipe ends a shader after 65535 loop iterations per invocation: one dispatch over 15000
    particles used to stop at particle 13107 (outputs left 0). The host now splits dispatches."""
    rng = np.random.default_rng(0)
    pc = ParticleCloud(rng.uniform(-5, 5, (15000, 3)), 0.05, 0.5, 0.5)
    s = SpriteSettings(light_resolution=16)
    cpu = particle_light(pc, SUN_Z, s).light
    gl = particle_light(pc, SUN_Z, s, method="gl", context=gl_context).light
    assert np.abs(gl - cpu).max() <= 1e-6


@pytest.mark.gl
@pytest.mark.parametrize("readback", ["pixel", "solid_angle"])
def test_glsl_compute_huge_footprints_and_patches(gl_context, readback: str) -> None:
    """N_L > 1024 (work groups of 1024) with footprints and read-back patches of ~10⁵–10⁶ pixels."""
    rng = np.random.default_rng(1)
    pc = ParticleCloud(rng.normal(size=(6, 3)), [3, 2, 2.5, 1, 3.2, 2], 2.0, 0.9)
    s = SpriteSettings(light_resolution=1500, readback=readback)
    cpu = particle_light(pc, cu.Sun(), s, return_buffers=True)
    gl = particle_light(pc, cu.Sun(), s, method="gl", return_buffers=True, context=gl_context)
    assert np.abs(gl.light - cpu.light).max() <= 1e-6
    assert np.abs(gl.buffers - cpu.buffers).max() <= 1e-6


@pytest.mark.gl
def test_readback_with_8bit_buffer_stays_close(gl_context) -> None:
    """quantize=8 reads back an RGBA8 framebuffer: GL's own 8-bit blending (rounding rule not
    fixed by GL) stays within a few 1/255 steps of the C++ emulation."""
    pc = particle_cumulus(n_particles=100, seed=6)
    s = SpriteSettings(quantize=8)
    cpu = particle_light(pc, cu.Sun(), s).light
    rb = particle_light(pc, cu.Sun(), s, method="readback", context=gl_context).light
    assert np.abs(rb - cpu).max() <= 4 / 255
    assert np.allclose(rb * 255, np.round(rb * 255), atol=1e-3)


@pytest.mark.gl
def test_phase_glsl_matches_cpp(gl_context) -> None:
    c = np.linspace(-1, 1, 257, dtype=np.float32)
    for phase, g in (("rayleigh", 0.0), ("isotropic", 0.0), ("hg", 0.6), ("hg", -0.3)):
        cpu = phase_values(phase, c, g)
        gl = phase_values(phase, c, g, backend="gl", context=gl_context)
        assert np.allclose(gl, cpu, rtol=2e-6, atol=0)


@pytest.mark.gl
def test_readback_refuses_unclampable_gain(gl_context) -> None:
    pc = particle_cumulus(n_particles=20, seed=1)
    s = SpriteSettings(phase="hg", allow_gain=True, clamp=True)
    with pytest.raises(ValueError, match="clamp"):
        particle_light(pc, cu.Sun(), s, method="readback", context=gl_context)


# --- settings and bad input ----------------------------------------------------------------------
def test_settings_presets_and_round_trip() -> None:
    sky = SpriteSettings.preset("skyworks")
    assert (sky.kernel, sky.peak, sky.solid_angle, sky.readback, sky.clamp, sky.sort) == (
        "hermite",
        0.4,
        0.09,
        "solid_angle",
        True,
        "depth",
    )
    assert sky.ambient == (0.3, 0.3, 0.3)
    assert SpriteSettings.preset("paper") == SpriteSettings()
    assert SpriteSettings.from_dict(sky.to_dict()) == sky
    assert SpriteSettings.preset("skyworks", peak=0.5).peak == 0.5
    with pytest.raises(ValueError, match="preset"):
        SpriteSettings.preset("nvidia")
    with pytest.raises(ValueError, match="unknown"):
        SpriteSettings.from_dict({"gamma": 1})


@pytest.mark.parametrize(
    "field, value, error",
    [
        ("solid_angle", 0.0, ValueError),
        ("solid_angle", 13.0, ValueError),
        ("solid_angle", float("nan"), ValueError),
        ("phase", "mie", ValueError),
        ("hg_g", 1.0, ValueError),
        ("kernel", "box", ValueError),
        ("peak", 1.5, ValueError),
        ("peak", 0.0, ValueError),
        ("light_resolution", 7, ValueError),
        ("light_resolution", 4097, ValueError),
        ("light_resolution", 32.0, TypeError),
        ("readback", "mean", ValueError),
        ("readback_solid_angle", -1.0, ValueError),
        ("forward", 1, TypeError),
        ("quantize", 4, ValueError),
        ("ambient", (1, 2), ValueError),
        ("ambient", (-1, 0, 0), ValueError),
        ("sort", "z", ValueError),
        ("near", 0.0, ValueError),
        ("relight_tolerance", -1.0, ValueError),
    ],
)
def test_settings_validation(field: str, value: object, error: type) -> None:
    with pytest.raises(error, match=field):
        SpriteSettings(**{field: value})


def test_particle_light_bad_input() -> None:
    pc = particle_cumulus(n_particles=20, seed=1)
    with pytest.raises(TypeError, match="lights"):
        particle_light(pc, (0, 1, 0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="lights"):
        particle_light(pc, [])
    with pytest.raises(ValueError, match="method"):
        particle_light(pc, cu.Sun(), method="cuda")
    with pytest.raises(TypeError, match="settings"):
        particle_light(pc, cu.Sun(), settings={"peak": 1})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="threads"):
        particle_light(pc, cu.Sun(), threads=-1)
    with pytest.raises(TypeError, match="clouds"):
        particle_light_many([pc, "x"], cu.Sun())  # type: ignore[list-item]
