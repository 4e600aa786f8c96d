"""Harris 2002: linearity in the lights (skylight additivity), the shadow
map by-product and ground shadows (§10.3.9), and the fidelity of the approximations against the
Gaussian-blob volume they stand for (§10.4, reported by `cumuli.rendering.fidelity`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.rendering.fidelity import blob_transmittance, image_fidelity, light_fidelity

W, H = 64, 48
SUN = cu.Sun(direction=(0.4, 0.8, -0.3), colour=(1.0, 0.9, 0.8), intensity=2.0)
CAMERA = cu.Camera((5.0, 6.0, -60.0), (0.0, 2.0, 0.0), fov=40)


def puff(n: int = 300, seed: int = 5, tau: float = 8.0) -> cu.ParticleCloud:
    return cu.particle_cumulus((0, 2, 0), n, seed=seed, radius=(2.0, 3.5), tau=tau)


def with_lights(sun_i: float, light_i: tuple[float, ...], sky: cu.Sky, ambient: float) -> cu.Scene:
    dirs = ((-0.6, 0.5, 0.2), (0.1, 0.9, 0.6), (0.7, 0.3, 0.5))
    cols = ((1.0, 0.5, 0.3), (0.9, 0.4, 0.8), (0.4, 0.6, 1.0))
    lights = tuple(cu.Sun(d, c, i) for d, c, i in zip(dirs, cols, light_i, strict=False))
    return cu.Scene(
        [puff()], sun=cu.Sun(SUN.direction, SUN.colour, sun_i), sky=sky, lights=lights,
        sprite_settings=cu.SpriteSettings(ambient=(ambient,) * 3),
    settings=cu.RenderSettings(lighting="paper"))  # fmt: skip


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_the_eye_pass_is_linear_in_the_lights(backend: str) -> None:
    """§10.2.6: for fixed alphas (the light pass depends on directions only), render(L_a + L_b)
    = render(L_a) + render(L_b) − render(none): sky and ambient counted once."""
    sky = cu.Sky()

    def img(sun_i: float, light_i: tuple[float, ...]) -> np.ndarray:
        scene = with_lights(sun_i, light_i, sky, 0.1)
        return cu.render(scene, CAMERA, W, H, backend=backend).astype(np.float64)

    both = img(2.0, (0.7,))
    a, b, none = img(2.0, (0.0,)), img(0.0, (0.7,)), img(0.0, (0.0,))
    np.testing.assert_allclose(both, a + b - none, atol=2e-5)
    assert np.abs(both - a).max() > 0.05  # the second light does show
    # Skylight: the sun plus three sky lights is the sum of each alone.
    full = img(2.0, (0.3, 0.4, 0.5))
    parts = [img(2.0, (0, 0, 0)), img(0, (0.3, 0, 0)), img(0, (0, 0.4, 0)), img(0, (0, 0, 0.5))]
    np.testing.assert_allclose(full, sum(parts) - 3 * img(0, (0, 0, 0)), atol=4e-5)


def test_skylight_lights_add_up_like_the_sky() -> None:
    # The automatic skylight: n lights from the sky's colours, one column each in the light pass.
    sky = cu.Sky.sunset()
    lights = cu.skylight_lights(sky, SUN, n=4)
    scene = cu.Scene(
        [puff()], sun=SUN, sky=sky, lights=lights, settings=cu.RenderSettings(lighting="paper")
    )
    lit = cu.prepare_light(scene)
    assert lit.lights[0].light.shape == (300, 5)
    lit_sky = cu.render(scene, CAMERA, W, H, backend="cpu")
    sun_only = cu.render(scene.replace(lights=()), CAMERA, W, H, backend="cpu")
    cloud = sun_only[..., 3] > 0.3
    assert (lit_sky[cloud][:, :3] >= sun_only[cloud][:, :3] - 1e-6).all()
    assert (lit_sky - sun_only)[cloud][:, :3].mean() > 1e-3


def reference_buffer_pixel(pc: cu.ParticleCloud, light: np.ndarray, ix: int, iy: int,
                           settings: cu.SpriteSettings) -> float:  # fmt: skip
    """One light-buffer pixel by the recurrence B ← w·g_k + (1 − w·α_k)·B in processing order
    (float64), g_k = forward_k·I_k with I_k the pass's own read-back."""
    geom, index, *_ = _core.particle_light_splats(
        *pc.core_args(), np.asarray([SUN.direction], np.float32), settings.light_dict()
    )
    b = 1.0
    for (x, y, r_px, fwd, alpha), k in zip(geom[0], index[0], strict=True):
        d = math.hypot(ix + 0.5 - x, iy + 0.5 - y) / r_px
        if d < 1:
            w = float(_core.splat_kernel(settings.kernel, settings.peak, np.float32([d]))[0])
            b = w * fwd * float(light[k]) + (1 - w * alpha) * b
    return b


@pytest.mark.parametrize("forward", [False, True])
def test_final_light_buffer_is_the_shadow_map(forward: bool) -> None:
    """§10.3.9: the final buffer is Π(1 − wα) over the footprints covering a pixel without
    forward scattering, plus the forward terms with it (spot checks); ground shadows in [0, 1]."""
    pc = puff(120)
    s = cu.SpriteSettings(forward=forward)
    light = cu.particle_light(pc, SUN, s, return_buffers=True)
    buf = light.buffers[0]
    rng = np.random.default_rng(1)
    for ix, iy in rng.integers(4, 28, (12, 2)):
        ref = reference_buffer_pixel(pc, light.light[:, 0], int(ix), int(iy), s)
        assert buf[iy, ix] == pytest.approx(ref, rel=1e-4, abs=1e-6)
    dark = 0.6 if not forward else 0.95  # forward scattering lets most of the light through
    assert (buf < dark).any() and 0 <= buf.min() and buf.max() <= 1
    # Ground shadows: the buffer where ground points project along the sun.
    xs, zs = np.meshgrid(np.linspace(-60, 60, 41), np.linspace(-60, 60, 41))
    ground = np.stack([xs.ravel(), np.full(xs.size, -30.0), zs.ravel()], axis=1)
    shade = cu.ground_shadow(pc, SUN, ground, s, light=light)
    assert shade.shape == (41 * 41,) and 0 <= shade.min() and shade.max() <= 1
    assert shade.min() < dark and (shade == 1.0).sum() > 100
    # The shadow lies down-sun of the cloud: under the centre displaced along −s.
    c = pc.sphere[0]
    t = (c[1] + 30.0) / SUN.direction[1]
    foot = c - t * np.asarray(SUN.direction)
    nearest = np.argmin(np.linalg.norm(ground[:, [0, 2]] - foot[[0, 2]], axis=1))
    assert shade[nearest] < 1.0 - (1.0 - dark) / 2
    # Points between the sun and the cloud are lit.
    above = np.asarray([c + 60 * np.asarray(SUN.direction)])
    assert cu.ground_shadow(pc, SUN, above, s, light=light)[0] == 1.0
    with pytest.raises(ValueError, match="points"):
        cu.ground_shadow(pc, SUN, np.zeros((3, 2)))


def test_blob_transmittance_reference() -> None:
    # One blob seen from far behind it along the light: exp(−τ) through the centre, and the
    # Gaussian profile off axis; from in front of it: 1.
    pc = cu.ParticleCloud([(0, 0, 0), (0, 0, -50), (3.0, 0, -50), (20, 0, 50)], 6.0, tau=2.0)
    t = blob_transmittance(pc, (0, 0, 1))
    s = 2.0  # r/3
    # Blob 0 whole on the axis, blob 2 half (level with the point) 3 units off the axis.
    expect = math.exp(-2.0) * math.exp(-1.0 * math.exp(-9 / (2 * s * s)))
    assert t[1] == pytest.approx(expect, rel=1e-9)
    assert t[3] == pytest.approx(1.0)
    assert blob_transmittance(pc, (0, 0, 1), include_self=True)[3] == pytest.approx(math.exp(-1))


def test_fidelity_against_the_blob_volume() -> None:
    """§10.4: the particle cloud against the same density as a volume (single scattering,
    isotropic, black sky) and the 2018 cloud it fills. Coverage agrees; radiance does not — the
    splat scatters a·τ/4π where a blob of optical depth τ can scatter at most a(1 − e^{−τ})/4π,
    so the ratio shrinks towards 1 as τ → 0; the figures go to the notebook and the docs."""
    shape = cu.gaussian_cumulus(centre=(0, 0, 0), seed=1)
    ratios = []
    for tau in (8.0, 0.5):
        pc = cu.particle_fill(shape, 500, seed=2, tau=tau)
        r = image_fidelity(pc, SUN, CAMERA, 48, 36, shape=shape, resolution=24)
        e = r["errors"]["splat_vs_volume"]
        assert e["pixels"] > 50 and e["alpha_mean_abs"] < 0.1
        assert math.isfinite(e["median_relative"]) and "splat_vs_marched" in r["errors"]
        ratios.append(e["ratio_of_means"])
    assert ratios[0] > 3 and abs(ratios[1] - 1) < abs(ratios[0] - 1)


def test_forward_scattering_error_against_gamma_and_tau() -> None:
    """§10.4: i_k against the blobs' exact transmittance: the splat light pass is too bright
    already without forward scattering (linear alpha profile, coarse buffer), more so as τ grows;
    forward scattering adds light growing with γ, part of which the continuum limit explains."""
    pc = puff(250)
    f = light_fidelity(pc, SUN, taus=(1.0, 4.0), gammas=(0.09, 1.0))
    cases = {(c["tau"], c["gamma"]): c for c in f["cases"]}
    assert cases[(1.0, 0.0)]["error"] < cases[(4.0, 0.0)]["error"]
    for tau in (1.0, 4.0):
        gains = [cases[(tau, g)]["gain"] for g in (0.0, 0.09, 1.0)]
        assert gains[0] < gains[1] < gains[2]
        assert cases[(tau, 1.0)]["continuum_error"] < cases[(tau, 1.0)]["error"]
