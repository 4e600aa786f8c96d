"""The physical light's camera-dependent part (cumuli.light.view): the diffuse sun light seen
through its flux, ``φ·(1 + ḡ·clamp(r·d, ±FLUX_LIMIT))`` with ``r = 3E/φ`` from the diffusion's
face fluxes; and single scattering reached by the δ-M sun."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.light import physical as phys
from cumuli.light import view
from cumuli.rendering.params import physical_params

ALBEDO, G = 0.9, 0.5
SIGMA = 4.0


def _block(shape=(8, 8, 8), pad=2) -> tuple[np.ndarray, tuple, tuple]:
    """A uniform cube of extinction SIGMA inside empty cells, on unit cells."""
    ext = np.zeros(shape, np.float32)
    ext[pad:-pad, pad:-pad, pad:-pad] = SIGMA
    lo, hi = (0.0, 0.0, 0.0), tuple(float(n) for n in shape[::-1])
    return ext, lo, hi


def test_the_anisotropy_of_a_linear_fluence_is_its_flux_over_it() -> None:
    """Inside the medium, φ falling along +x at rate b carries E = D·b x̂, D = 1/(3σ(1 − ϖḡ)):
    r = 3E/φ exactly (central differences of a linear field, equal D on both sides)."""
    ext, lo, hi = _block()
    x = np.arange(8, dtype=np.float32)[None, None, :] + 0.5
    phi = np.broadcast_to(10.0 - 0.5 * x, ext.shape)[..., None].astype(np.float32)
    r = _core.diffusion_anisotropy(ext, lo, hi, np.ascontiguousarray(phi), ALBEDO, G)
    assert r.shape == (8, 8, 8, 3) and r.dtype == np.float32
    d = 1.0 / (3.0 * SIGMA * (1.0 - ALBEDO * G))
    inner = (slice(3, 5),) * 3  # cells whose both x faces are between medium cells
    want = 3.0 * d * 0.5 / phi[inner][..., 0]
    np.testing.assert_allclose(r[inner][..., 0], want, rtol=1e-5)
    np.testing.assert_allclose(r[inner][..., 1:], 0.0, atol=1e-6)


def test_a_surface_cell_leaks_outwards_by_marshaks_condition() -> None:
    """A uniform φ has no flux inside; at the medium's faces Marshak's leak 2Dφ/(h + 4D) runs
    outwards, so r points out of the cube on every side (and the centre's is 0)."""
    ext, lo, hi = _block()
    phi = np.where(ext > 0, 1.0, 0.0).astype(np.float32)[..., None]
    r = _core.diffusion_anisotropy(ext, lo, hi, phi, ALBEDO, G)
    d = 1.0 / (3.0 * SIGMA * (1.0 - ALBEDO * G))
    leak = 3.0 * 0.5 * 2.0 * d / (1.0 + 4.0 * d)  # one face leaks, the other carries nothing
    assert r[4, 4, 5, 0] == pytest.approx(leak, rel=1e-5)  # the +x face (array axis 2 is x)
    assert r[4, 4, 2, 0] == pytest.approx(-leak, rel=1e-5)
    assert r[5, 4, 4, 2] == pytest.approx(leak, rel=1e-5)  # +z
    assert r[4, 2, 4, 1] == pytest.approx(-leak, rel=1e-5)  # −y
    np.testing.assert_allclose(r[3:5, 3:5, 3:5], 0.0, atol=1e-6)
    assert np.linalg.norm(r, axis=-1).max() <= 3.0 + 1e-6


def test_empty_cells_next_to_the_medium_hold_their_neighbours_mean_and_the_rest_zero() -> None:
    ext, lo, hi = _block()
    phi = np.where(ext > 0, 1.0, 0.0).astype(np.float32)[..., None]
    r = _core.diffusion_anisotropy(ext, lo, hi, phi, ALBEDO, G)
    np.testing.assert_array_equal(r[4, 4, 6], r[4, 4, 5])  # one medium neighbour, −x
    np.testing.assert_array_equal(r[0], 0.0)  # two cells from the medium
    np.testing.assert_array_equal(r[:, :, 0], 0.0)


def test_the_forward_scattered_flux_streams_along_the_light() -> None:
    """With the sun's source, E = −D∇φ + w·3D·Q1 (the P1 flux with a first-moment source): a
    uniform φ under a sun straight overhead has, on the cube's inner cells, r = 3·w·3D·Q1/φ
    pointing down (the way the light travels), Q1 = ϖσ·T·ḡ; across the light nothing; at the
    faces to empty cells only Marshak's leak, as without it (no flux source crosses them)."""
    ext, lo, hi = _block()
    phi = np.where(ext > 0, 2.0, 0.0).astype(np.float32)[..., None]
    sun_t = np.full(ext.shape, 0.6, np.float32)
    w = 0.7
    r0 = _core.diffusion_anisotropy(ext, lo, hi, phi, ALBEDO, G)
    r = _core.diffusion_anisotropy(
        ext, lo, hi, phi, ALBEDO, G, sun_t=sun_t, to_sun=(0.0, 1.0, 0.0), forward=w
    )
    d = 1.0 / (3.0 * SIGMA * (1.0 - ALBEDO * G))
    q1 = ALBEDO * SIGMA * 0.6 * G
    inner = (slice(3, 5), slice(3, 5), slice(3, 5))
    np.testing.assert_allclose(r[inner][..., 1], -3.0 * w * 3.0 * d * q1 / 2.0, rtol=1e-5)
    np.testing.assert_allclose(r[inner][..., [0, 2]], 0.0, atol=1e-6)
    # A top or bottom medium cell has one face to the medium: half the streaming flux, plus
    # the leak it had before.
    top, bottom = (4, 5, 4), (4, 2, 4)
    half = -3.0 * 0.5 * w * 3.0 * d * q1 / 2.0
    assert r[top][1] == pytest.approx(r0[top][1] + half, rel=1e-5)
    assert r[bottom][1] == pytest.approx(r0[bottom][1] + half, rel=1e-5)
    # No sun transmittance or no weight: the flux of −D∇φ alone.
    np.testing.assert_array_equal(
        _core.diffusion_anisotropy(ext, lo, hi, phi, ALBEDO, G, sun_t=sun_t, forward=0.0), r0
    )
    np.testing.assert_array_equal(
        _core.diffusion_anisotropy(ext, lo, hi, phi, ALBEDO, G, forward=w), r0
    )


def test_the_light_step_streams_the_flux_of_its_own_sun_source(monkeypatch) -> None:
    """The physical light step hands the anisotropy the same sun transmittance, sun and forward
    weight as its diffusion's source (so the flux it reads is the flux that source carries), and
    with no flux source (``forward`` 0, as a particle or billboard proxy's light step asks) it
    streams nothing."""
    calls: dict[str, dict] = {}
    real_light, real_aniso = _core.diffusion_light, _core.diffusion_anisotropy

    def spy(name, real):
        def wrapped(*args, **kw):
            calls[name] = {"args": args, **kw}
            return real(*args, **kw)

        return wrapped

    monkeypatch.setattr(_core, "diffusion_light", spy("light", real_light))
    monkeypatch.setattr(_core, "diffusion_anisotropy", spy("aniso", real_aniso))
    scene = _scene()
    phys.physical_light(scene.clouds[0], scene)
    light, aniso = calls["light"], calls["aniso"]
    assert aniso["sun_t"] is light["args"][3]  # (extinction, lo, hi, sun_t, to_sun, ...)
    assert tuple(aniso["to_sun"]) == tuple(light["args"][4])
    assert aniso["forward"] == light["forward"] == pytest.approx(phys.SUN_FORWARD)
    calls.clear()
    phys.physical_light(scene.clouds[0], scene, forward=0.0)
    assert calls["aniso"]["forward"] == 0.0


@pytest.mark.parametrize(
    "bad, match",
    [
        ({"phi": np.ones((8, 8, 8), np.float32)}, "phi must have shape"),
        ({"phi": np.ones((8, 8, 7, 1), np.float32)}, "phi must have shape"),
        ({"albedo": 1.5}, "albedo"),
        ({"mean_cosine": 1.0}, "mean_cosine"),
        ({"sun_t": np.ones((8, 8, 7), np.float32)}, "sun_t must have"),
        ({"forward": -0.1}, "forward must be in"),
        ({"forward": math.nan}, "forward must be in"),
        ({"to_sun": (0.0, 0.0, 0.0)}, "to_sun must be"),
        ({"to_sun": (math.nan, 1.0, 0.0)}, "to_sun must be"),
    ],
)
def test_bad_anisotropy_arguments_are_refused(bad: dict, match: str) -> None:
    ext, lo, hi = _block()
    args = {
        "phi": np.ones((8, 8, 8, 1), np.float32),
        "albedo": ALBEDO,
        "mean_cosine": G,
        "sun_t": np.ones((8, 8, 8), np.float32),
        "forward": 0.5,
    } | bad
    with pytest.raises(ValueError, match=match):
        _core.diffusion_anisotropy(ext, lo, hi, args.pop("phi"), args.pop("albedo"),
                                   args.pop("mean_cosine"), **args)  # fmt: skip


def test_view_weights_follow_the_clamped_flux_towards_the_camera() -> None:
    """``1 + ḡ·clamp(r·d, ±limit)``: a camera far along +x sees r_x, clamped."""
    r = np.zeros((2, 2, 2, 3), np.float32)
    r[..., 0] = [[[0.2, 2.0], [-0.2, -2.0]], [[0.0, 0.4], [1.0, -1.0]]]
    box = ((0.0, 0.0, 0.0), (2.0, 2.0, 2.0))
    w = view.view_weights(r, box, (1e6, 1.0, 1.0), 0.8, 0.5)
    want = 1.0 + 0.8 * np.clip(r[..., 0], -0.5, 0.5)
    np.testing.assert_allclose(w, want, atol=1e-5)
    # Seen from −x the same flux dims what it brightened.
    w2 = view.view_weights(r, box, (-1e6, 1.0, 1.0), 0.8, 0.5)
    np.testing.assert_allclose(w2, 1.0 - 0.8 * np.clip(r[..., 0], -0.5, 0.5), atol=1e-5)


def _scene() -> cu.Scene:
    cloud = cu.gaussian_cumulus(centre=(0.0, 0.0, 0.0), seed=3)
    return cu.Scene(clouds=[cloud], sun=cu.Sun(direction=(0.3, 0.8, -0.5)))


def _camera(scene: cu.Scene, side: float) -> cu.Camera:
    lo, hi = scene.clouds[0].layer_box()
    centre = (np.asarray(lo) + np.asarray(hi)) / 2
    far = 3.0 * float(np.max(np.subtract(hi, lo)))
    pos = centre + side * far * np.array([-0.3, 0.0, 0.5]) / math.hypot(0.3, 0.5)
    return cu.Camera(tuple(pos), tuple(centre), fov=40.0)


def test_the_view_is_the_light_step_seen_from_the_camera(counted) -> None:
    """A render applies the view to the light step's result: the sun channel times the view
    weights, the sky channels and the sun lattice as they were; a second camera reuses the light
    step (nothing recomputed) and a camera that has not moved gets the same view object back."""
    scene = _scene()
    lit = cu.prepare_light(scene)
    light = lit.lights[0]
    assert light.anisotropy is not None and light.seen_from is None
    cam = _camera(scene, 1.0)
    seen = view.seen_from(lit, cam).lights[0]
    assert seen.seen_from is light and seen.anisotropy is None
    w = view.view_weights(light.anisotropy, light.box, cam.position, scene.settings.mean_cosine,
                          phys.FLUX_LIMIT)  # fmt: skip
    np.testing.assert_allclose(seen.grid[..., 0], light.grid[..., 0] * w, rtol=1e-6)
    np.testing.assert_array_equal(seen.grid[..., 1:], light.grid[..., 1:])
    assert seen.sun_depth is light.sun_depth and seen.same_as(light) and light.same_as(seen)
    assert view.seen_from(lit, cam).lights[0] is seen
    assert view.view_light(seen, cam.position, 0.8) is seen  # a view is not seen twice
    before = dict(counted)
    cu.render(scene, cam, 32, 24, backend="cpu")
    cu.render(scene, _camera(scene, -1.0), 32, 24, backend="cpu")
    assert counted == before


@pytest.mark.parametrize("backend", ["cpu", "gl"])
def test_the_flux_term_reaches_the_image(monkeypatch, backend: str) -> None:
    """The diffuse light leaves a cloud through every surface: seen from downstream (the sun
    behind the cloud, side +1) and from the sun's side alike the cloud is brighter with the flux
    term than with the isotropic fluence (FLUX_LIMIT 0, the view pass a no-op): by 2.0 % and
    2.4 % at the default resolution 40. Most of the forward-scattered light is carried in the
    source (``SUN_CARRIED``) rather than streamed in the flux, so which side gains more is the
    lattice's detail (at resolution 48 it was 2.1 % against 2.0 %). GL draws what the CPU twin
    draws."""
    scene = _scene()
    out = {}
    for limit in (0.0, phys.FLUX_LIMIT):
        monkeypatch.setattr(phys, "FLUX_LIMIT", limit)
        for side in (1.0, -1.0):
            img = cu.render(scene, _camera(scene, side), 48, 36, backend=backend)
            cloud = img[..., 3] > 0.5
            out[limit, side] = float(img[cloud][:, :3].mean())
            if backend == "gl":
                cpu = cu.render(scene, _camera(scene, side), 48, 36, backend="cpu")
                np.testing.assert_allclose(img, cpu, atol=2e-3)
    gain = {side: out[phys.FLUX_LIMIT, side] / out[0.0, side] for side in (1.0, -1.0)}
    assert gain[1.0] > 1.01, out
    assert gain[-1.0] > 1.01, out


def test_without_multiple_scattering_there_is_no_view() -> None:
    scene = _scene().replace(settings=cu.RenderSettings(multiple_scattering=False))
    lit = cu.prepare_light(scene)
    assert lit.lights[0].anisotropy is None
    assert view.seen_from(lit, _camera(scene, 1.0)) is lit


def test_single_scattering_reaches_a_point_with_the_delta_m_sun() -> None:
    """Order 0 of the octaves is ``phase·e^{−(1 − f·ϖ)τ}`` (f the phase's forward-peak share),
    in the numpy reference and the core alike; an HG lobe's f is small, the Mie peak's 0.447."""
    s = cu.RenderSettings()
    f = phys.forward_peak_share(s)
    assert f == pytest.approx(0.447, abs=0.01)
    scale = phys.first_order_depth_scale(s)
    assert scale == pytest.approx(1.0 - f * s.albedo)
    tau = np.array([0.0, 0.5, 2.0, 6.0])
    c = 0.3
    want = phys.phase(s, c, 1.0) * np.exp(-scale * tau)
    np.testing.assert_allclose(phys.octave_sum(s, tau, c, 1), want, rtol=1e-6)
    p = physical_params(s, 1)
    assert p.oct_first == pytest.approx(scale)
    np.testing.assert_allclose(p.octave_sum(c, tau.astype(np.float32)), want, rtol=1e-4)
    hg = cu.RenderSettings(phase="hg")
    assert phys.first_order_depth_scale(hg) > 0.99


def test_oct_first_is_checked() -> None:
    p = physical_params(cu.RenderSettings(), 2)
    p.oct_first = 0.0
    with pytest.raises(ValueError, match="oct_first"):
        p.octave_sum(0.0, np.zeros(2, np.float32))


def test_a_view_given_back_to_the_light_step_is_the_light_it_was_made_from() -> None:
    """``prepare_light(scene, lights=...)`` with a camera's view takes the light underneath, so
    the next camera's view is made from it, not from the last camera's."""
    scene = _scene()
    lit = cu.prepare_light(scene)
    seen = view.seen_from(lit, _camera(scene, 1.0))
    again = cu.prepare_light(scene, lights=list(seen.lights))
    assert again.lights[0] is lit.lights[0]
