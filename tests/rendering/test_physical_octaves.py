"""The physical mode's Poisson-weighted octaves and thickness-aware lattice gains
(``cumuli.light.physical``: ``octave_sum``, ``lattice_gains``): the numpy reference against the
C++ marchers' ``PhysicalParams.octave_sum`` and the shaders' ``octave_sum``, their limits, and
the validation of their constants."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.light import physical as phys
from cumuli.light.physical import lattice_gains, octave_sum, phase_values, physical_light
from cumuli.rendering.params import physical_params

TAU = np.array([0.0, 0.05, 0.3, 1.0, 2.5, 6.0, 15.0], np.float32)
COSINES = (-0.9, 0.0, 0.6, 0.99)
SETTINGS = {
    "mie": cu.RenderSettings(),
    "hg": cu.RenderSettings(phase="hg"),
    "dual_hg": cu.RenderSettings(phase="dual_hg"),
}


@pytest.fixture(params=[0.0, 0.8, 2.0], ids=["plain", "poisson0.8", "poisson2"])
def poisson(request, monkeypatch) -> float:
    monkeypatch.setattr(phys, "OCTAVE_POISSON", request.param)
    return request.param


def test_poisson_octaves_are_their_formula(poisson: float) -> None:
    s, tau = SETTINGS["hg"], TAU.astype(np.float64)
    for c in COSINES:
        got = octave_sum(s, tau, c, 3)
        want = np.zeros(len(TAU))
        for n in range(3):
            p = phys.order_phase(s, np.array([c]), n, 3)[0]  # the phase itself for n = 0
            weight = (poisson * tau) ** n / math.factorial(n) if poisson else 1.0
            k = phys.first_order_depth_scale(s) if n == 0 else phys.OCTAVE_C**n  # δ-M order 0
            want += phys.OCTAVE_A**n * p * weight * np.exp(-k * tau)
        np.testing.assert_allclose(got, want, rtol=1e-12)


@pytest.mark.parametrize("phase", list(SETTINGS))
@pytest.mark.parametrize("octaves", [1, 2, 4])
def test_cpp_octave_sum_is_the_numpy_reference(poisson: float, phase: str, octaves: int) -> None:
    s = SETTINGS[phase]
    params = physical_params(s, octaves)
    assert params.oct_poisson == pytest.approx(poisson)
    for c in COSINES:
        np.testing.assert_allclose(
            params.octave_sum(c, TAU), octave_sum(s, TAU, c, octaves), rtol=2e-5, atol=1e-9
        )


@pytest.mark.gl
@pytest.mark.parametrize("phase", list(SETTINGS))
def test_glsl_octave_sum_is_the_numpy_reference(gl_context, poisson: float, phase: str) -> None:
    from cumuli.rendering.physical_gl import octave_sum_gl

    s = SETTINGS[phase]
    for c in COSINES:
        gl = octave_sum_gl(s, TAU, c, 3, context=gl_context)
        np.testing.assert_allclose(gl, octave_sum(s, TAU, c, 3), rtol=2e-5, atol=1e-9)


def test_poisson_weights_put_high_orders_in_the_depths() -> None:
    """In full sun only single scattering is drawn; inside, order 1 peaks at τ = 1/c."""
    s = SETTINGS["hg"]
    assert phys.OCTAVE_POISSON > 0 and phys.OCTAVES >= 2
    zero = octave_sum(s, 0.0, 0.3, phys.OCTAVES)
    assert zero == pytest.approx(phase_values(s, np.array([0.3]))[0])
    t = np.linspace(0.0, 20.0, 4001)
    order1 = octave_sum(s, t, 0.3, 2) - octave_sum(s, t, 0.3, 1)
    assert t[np.argmax(order1)] == pytest.approx(1.0 / phys.OCTAVE_C, abs=0.01)


@pytest.mark.parametrize("value", [-0.1, 16.5, float("nan")])
def test_oct_poisson_is_validated(value: float) -> None:
    p = _core.PhysicalParams()
    p.oct_poisson = value
    with pytest.raises(ValueError, match="oct_poisson"):
        p.validate()
    with pytest.raises(ValueError, match="oct_poisson"):
        p.octave_sum(0.0, TAU)
    p.oct_poisson = 16.0
    p.validate()


def test_lattice_gains_rise_with_cell_thickness() -> None:
    ext = np.array([0.0, 0.1, 1.0, 10.0, 1000.0], np.float32).reshape(1, 1, 5)
    lo, hi = (0.0, 0.0, 0.0), (2.5, 0.5, 0.5)  # cells of 0.5 on every edge
    g = lattice_gains(ext, lo, hi, 3.0, depth=1.0)
    want = 1.0 + 2.0 * (1.0 - np.exp(-ext.astype(np.float64) * 0.5))
    np.testing.assert_allclose(g, want, rtol=1e-6)
    assert g[0, 0, 0] == 1.0 and g[0, 0, -1] == pytest.approx(3.0)
    assert (np.diff(g.ravel()) > 0).all()
    # a deeper τg lowers the gain of every cell with medium; τg = 0 is the gain everywhere
    assert (lattice_gains(ext, lo, hi, 3.0, depth=4.0)[..., 1:-1] < g[..., 1:-1]).all()
    np.testing.assert_array_equal(lattice_gains(ext, lo, hi, 3.0, depth=0.0), np.full_like(g, 3))


@pytest.mark.parametrize(
    "args, match",
    [
        ((np.ones((2, 2)), 2.0, 1.0), "extinction"),
        ((np.ones((2, 2, 2)), 0.0, 1.0), "gain"),
        ((np.ones((2, 2, 2)), float("inf"), 1.0), "gain"),
        ((np.ones((2, 2, 2)), 2.0, -1.0), "gain_depth"),
        ((np.ones((2, 2, 2)), 2.0, float("nan")), "gain_depth"),
    ],
)
def test_lattice_gains_bad_input(args: tuple, match: str) -> None:
    ext, gain, depth = args
    with pytest.raises(ValueError, match=match):
        lattice_gains(ext, (0, 0, 0), (1, 1, 1), gain, depth)


def _scene() -> cu.Scene:
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), n=8, seed=4)
    return cu.Scene(clouds=[cloud], settings=cu.RenderSettings(physical_resolution=24))


def test_physical_light_applies_the_gains_by_cell_thickness() -> None:
    scene = _scene()
    cloud = scene.clouds[0]
    flat = physical_light(cloud, scene, threads=1, gain_depth=0.0)
    shaped = physical_light(cloud, scene, threads=1)
    assert shaped.grid.shape == flat.grid.shape
    # τg = 0 is the constant gain; the default leaves thin cells at a lower gain, never higher
    ratio = shaped.grid[..., 0] / np.where(flat.grid[..., 0] > 0, flat.grid[..., 0], 1.0)
    lit = flat.grid[..., 0] > 1e-6
    assert ratio[lit].max() <= 1.0 + 1e-5
    assert ratio[lit].min() >= 1.0 / phys.SUN_GAIN - 1e-5
    assert ratio[lit].min() < 0.9  # some cells are thin
    with pytest.raises(ValueError, match="gain_depth"):
        physical_light(cloud, scene, threads=1, gain_depth=-1.0)
