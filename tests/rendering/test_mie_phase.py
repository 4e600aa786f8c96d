"""The approximate Mie phase of the physical mode (Jendersie & d'Eon 2023): its fitted
parameters, normalisation, forward peak, GL/CPU agreement and the silver lining it draws."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.light.physical import phase as settings_phase

DIAMETERS = (5.0, 10.0, 20.0, 50.0)


def fitted(d: float) -> tuple[float, float, float, float]:
    """The talk's fits, written out here independently of the C++."""
    return (
        math.exp(-0.0990567 / (d - 1.67154)),
        math.exp(-2.20679 / (d + 3.91029) - 0.428934),
        math.exp(3.62489 - 8.29288 / (d + 5.52825)),
        math.exp(-0.599085 / (d - 0.641583) - 0.665888),
    )


def reference_phase(d: float, c: np.ndarray) -> np.ndarray:
    g_hg, g_d, alpha, w_d = fitted(d)
    c = np.asarray(c, np.float64)

    def hg(g: float) -> np.ndarray:
        return (1 - g * g) / (4 * math.pi * (1 + g * g - 2 * g * c) ** 1.5)

    draine = hg(g_d) * (1 + alpha * c * c) / (1 + alpha * (1 + 2 * g_d * g_d) / 3)
    return (1 - w_d) * hg(g_hg) + w_d * draine


def cosines() -> np.ndarray:
    """Cosines dense towards c = 1, where the diffraction peak is (1 − c down to 1e-7)."""
    t = np.concatenate([[0.0], np.geomspace(1e-7, 2.0, 40000)])
    return 1.0 - t


@pytest.mark.parametrize("d", DIAMETERS)
def test_parameters_are_the_published_fits(d: float) -> None:
    np.testing.assert_allclose(_core.approx_mie_params(d), fitted(d), rtol=1e-5)
    c = np.linspace(-1, 0.999, 101).astype(np.float32)
    np.testing.assert_allclose(_core.approx_mie_phase(d, c), reference_phase(d, c), rtol=1e-4)


@pytest.mark.parametrize("d", DIAMETERS)
def test_normalised_and_mean_cosine(d: float) -> None:
    c = cosines()
    p = _core.approx_mie_phase(d, c.astype(np.float32)).astype(np.float64)
    integral = 2 * math.pi * np.trapezoid(p[::-1], c[::-1])
    assert integral == pytest.approx(1.0, abs=2e-3)
    mean = 2 * math.pi * np.trapezoid((p * c)[::-1], c[::-1])
    assert mean == pytest.approx(_core.approx_mie_mean_cosine(d), abs=2e-3)


def test_forward_peak_of_cloud_droplets() -> None:
    s = cu.RenderSettings()  # the default: physical, Mie, 20 µm
    assert s.phase == "mie" and s.droplet_diameter == 20.0
    forward = settings_phase(s, 1.0)
    side = settings_phase(s, 0.0)
    hg = settings_phase(s.replace(phase="hg"), 1.0)
    assert forward > 1000 * side  # the diffraction peak
    assert forward > 100 * hg  # far narrower than the old HG(0.6) lobe
    assert 0.85 < s.mean_cosine < 0.9  # clouds' measured asymmetry is about 0.85–0.88
    # The narrow peak is the HG lobe; the Draine lobe keeps a backward glory-like rise.
    assert settings_phase(s, -1.0) > settings_phase(s, -0.5)


@pytest.mark.parametrize("bad", [4.9, 50.5, float("nan")])
def test_droplet_diameter_out_of_the_fits_is_refused(bad: float) -> None:
    with pytest.raises(ValueError, match="droplet_diameter"):
        cu.RenderSettings(droplet_diameter=bad)
    with pytest.raises(ValueError, match="droplet diameter"):
        _core.approx_mie_params(bad)


def backlit_scene(phase: str = "mie") -> tuple[cu.Scene, cu.Camera]:
    """A cumulus with the sun 10° above the cloud's top, behind it as the camera sees it."""
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), n=12, seed=4)
    lo, hi = (np.asarray(b) for b in cloud.layer_box())
    centre = (lo + hi) / 2
    eye = centre + np.array([0.0, 0.0, -45.0])
    top = np.array([centre[0], hi[1], centre[2]])
    up = (top - eye) / np.linalg.norm(top - eye)  # towards the cloud's top edge
    axis = np.cross(up, [1.0, 0.0, 0.0])
    axis /= np.linalg.norm(axis)
    a = math.radians(10.0)  # 10° above the top edge, behind the cloud
    to_sun = -(up * math.cos(a) + np.cross(axis, up) * math.sin(a))
    to_sun = -to_sun if to_sun[2] < 0 else to_sun
    scene = cu.Scene(
        # The table noise (version 1): the rim ratios below were measured with it.
        [cloud], sun=cu.Sun(direction=tuple(to_sun), intensity=6.0),
        noise=cu.Noise(seed=5, version=1),
        settings=cu.RenderSettings(phase=phase, physical_resolution=24),
    )  # fmt: skip
    return scene, cu.Camera(position=tuple(eye), target=tuple(centre), fov=30)


def rim_and_body(img: np.ndarray) -> tuple[float, float]:
    a = img[..., 3]
    lum = img[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
    clouds = lum / np.maximum(a, 1e-6)  # the cloud's own light, without the sky behind
    edge = (a > 0.1) & (a < 0.6)
    body = a > 0.98
    assert edge.sum() > 20 and body.sum() > 100
    return float(clouds[edge].mean()), float(clouds[body].mean())


def test_backlit_cloud_has_a_silver_lining() -> None:
    scene, cam = backlit_scene()
    img = cu.render_cpu(scene, cam, 80, 60)
    rim, body = rim_and_body(img)
    assert rim > 1.5 * body  # thin edges glow against the sun; the body is in its own shade
    # The HG(0.6) phase it replaces draws a weaker rim (rim / body 9.4 against 7.0 when
    # written; 7.3 against 5.9 since the edge pass marches the rim's pixels with two rays; 7.5
    # against 6.3 since part of the collided sun light is carried deeper before it diffuses).
    hg_rim, hg_body = rim_and_body(cu.render_cpu(backlit_scene("hg")[0], cam, 80, 60))
    assert rim / body > 1.15 * (hg_rim / hg_body)


@pytest.mark.gl
def test_gl_and_cpu_agree_with_the_mie_phase(gl_context) -> None:
    scene, cam = backlit_scene()
    lit = cu.prepare_light(scene)
    cpu = cu.render_cpu(lit, cam, 48, 36)
    with cu.Renderer(context=gl_context) as r:
        gl = r.render(lit, cam, 48, 36)
    diff = np.abs(gl - cpu)
    assert diff.mean(axis=(0, 1)).max() <= 1e-3
    assert (diff.max(-1) > 5e-2).mean() <= 0.01


def test_the_haze_draws_an_aureole_around_the_hidden_sun() -> None:
    scene, cam = backlit_scene()
    # The aureole alone (no aerial perspective, which lends it to the air before the cloud;
    # no resolve pass, which filters it).
    scene = scene.replace(settings=scene.settings.replace(air_extinction=0.0, resolve=False))
    clear = scene.replace(settings=scene.settings.replace(haze=0.0))
    img = cu.render_cpu(scene, cam, 80, 60)
    base = cu.render_cpu(clear, cam, 80, 60)
    glow = (img - base)[..., :3].sum(-1)
    dirs = cam.ray_directions(80, 60)
    angle = np.degrees(np.arccos(np.clip(dirs @ np.asarray(scene.sun.direction), -1, 1)))
    sky = img[..., 3] < 0.01
    near, far = sky & (angle < 12), sky & (angle > 25)
    assert near.sum() > 5 and far.sum() > 50
    # Bright near the sun (behind the cloud's edge), falling off with the angle; none on the
    # cloud's opaque body (where even its δ-M view, (1 − α)^v, lets nothing through); the
    # phase's own falloff exactly.
    assert glow[near].mean() > 5 * glow[far].mean() > 0
    body = img[..., 3] >= 1.0 - 1e-6
    assert body.sum() > 50
    assert np.abs(glow[body]).max() < 1e-3
    s = scene.settings
    expected = (
        settings_phase(s, float(np.cos(np.radians(angle[far][0]))))
        * s.haze
        * sum(scene.sun.radiance)
    )
    assert glow[far][0] == pytest.approx(expected, rel=1e-3)
    # The paper mode has no air.
    paper = scene.replace(settings=cu.RenderSettings(lighting="paper"))
    assert cu.rendering.air.aureole(paper, cam, 8, 6) is None


def test_the_resolve_pass_averages_the_jitter_out() -> None:
    from cumuli.rendering.edges import edge_mask
    from cumuli.rendering.resolve import tent_filter

    flat = np.full((5, 7, 4), 0.3, np.float32)
    np.testing.assert_allclose(tent_filter(flat), flat, rtol=1e-6)  # constant stays constant
    spike = np.zeros((5, 5, 1), np.float32)
    spike[2, 2] = 16.0
    expected = np.outer([1, 2, 1], [1, 2, 1]).astype(np.float32)
    np.testing.assert_allclose(tent_filter(spike)[1:4, 1:4, 0], expected)
    scene, cam = backlit_scene()

    def noise(resolve: bool) -> float:
        """The jitter's pattern alone: two jitter seeds' images differ by it only."""
        a, b = (
            cu.render_cpu(
                scene.replace(settings=scene.settings.replace(resolve=resolve, jitter_seed=k)),
                cam,
                64,
                48,
            )  # fmt: skip
            for k in (0, 7)
        )
        # Away from the outline, whose pixels the edge pass marches with two rays and keeps
        # out of the tent (cumuli.rendering.edges).
        inner = ~edge_mask(a[..., 3])
        return float(np.abs(a[..., :3] - b[..., :3])[inner].mean())

    assert noise(True) < 0.75 * noise(False)  # 0.62 when written (over every pixel)
    paper = scene.replace(settings=cu.RenderSettings(lighting="paper"))
    img = cu.render_cpu(paper, cam, 16, 12)
    np.testing.assert_array_equal(cu.rendering.resolve.resolve(img, paper), img)
