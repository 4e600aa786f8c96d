"""The angular distribution of the physical mode's drawn orders (``cumuli.light.phase``:
``order_phase_table``; ``PhysicalParams.order_phase``): order ``n`` turns the light by the δ-M
phase convolved with itself ``n`` times — its energy kept, its mean cosine ``g'ⁿ⁺¹`` — and the
C++ marchers read the same table."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.light import physical as phys
from cumuli.light.phase import (
    PEAK_COS,
    forward_peak_share,
    order_phase_table,
    order_phase_values,
    phase_values,
)
from cumuli.rendering.params import physical_params

# A fine midpoint rule over θ: ∫ f dω = 2π ∫ f(cos θ) sin θ dθ.
THETA = (np.arange(200_000) + 0.5) * math.pi / 200_000
MU = np.cos(THETA)
DOMEGA = 2.0 * math.pi * np.sin(THETA) * math.pi / THETA.size


def hg(g: float, c: np.ndarray) -> np.ndarray:
    return (1.0 - g * g) / (4.0 * math.pi * (1.0 + g * g - 2.0 * g * c) ** 1.5)


def truncated_mean_cosine(settings: cu.RenderSettings) -> float:
    """g' of the phase outside the forward cone, renormalised (the δ-M phase)."""
    p = np.where(MU >= PEAK_COS, 0.0, phase_values(settings, MU)) * DOMEGA
    return float((p * MU).sum() / p.sum())


@pytest.mark.parametrize("phase", ["mie", "hg", "dual_hg"])
def test_each_order_keeps_the_light_outside_the_peak(phase: str) -> None:
    s = cu.RenderSettings(phase=phase)
    table = order_phase_table(s, 4)
    assert table.shape == (3, _core.ORDER_PHASE_SIZE) and table.dtype == np.float32
    kept = 1.0 - forward_peak_share(s)
    g = truncated_mean_cosine(s)
    for n in (1, 2, 3):
        row = order_phase_values(table, n, MU)
        assert (row * DOMEGA).sum() == pytest.approx(kept, rel=2e-3)
        # Convolution multiplies Legendre coefficients: the mean cosine is g'ⁿ⁺¹.
        mean_cos = (row * MU * DOMEGA).sum() / (row * DOMEGA).sum()
        assert mean_cos == pytest.approx(g ** (n + 1), abs=3e-3)


def test_hg_orders_are_hg_with_g_to_the_power() -> None:
    """HG convolved with itself is HG(g²): Wrenninge's octaves with b = g, for HG lobes."""
    s = cu.RenderSettings(phase="hg", hg_g=0.6)
    table = order_phase_table(s, 3)
    kept = 1.0 - forward_peak_share(s)
    c = np.cos(np.radians([0.0, 10.0, 30.0, 60.0, 90.0, 135.0, 180.0]))
    for n in (1, 2):
        want = kept * hg(0.6 ** (n + 1), c)
        np.testing.assert_allclose(order_phase_values(table, n, c), want, rtol=0.025)


def test_twice_scattered_mie_light_is_spread_wider_than_the_phase() -> None:
    """Back-lit, the twice-scattered light near the sun falls off far more slowly than the
    phase's narrow lobe: from 10° to 25° the phase drops 2.4×, order 1 less than 1.7×."""
    s = cu.RenderSettings()
    table = order_phase_table(s, 2)
    c10, c25 = np.cos(np.radians([10.0, 25.0]))
    p10, p25 = phase_values(s, np.array([c10, c25]))
    o10, o25 = order_phase_values(table, 1, np.array([c10, c25]))
    assert p10 / p25 > 2.2
    assert o10 / o25 < 1.7
    # …and sends more to the side: at 90° many times the phase.
    assert order_phase_values(table, 1, 0.0) > 4.0 * phase_values(s, np.array([0.0]))[0]


@pytest.fixture
def convolved(monkeypatch) -> None:
    monkeypatch.setattr(phys, "OCTAVE_PHASE", "convolved")


def test_the_marchers_read_the_table(convolved) -> None:
    s = cu.RenderSettings()
    p = physical_params(s, 3)
    np.testing.assert_array_equal(p.order_phase, order_phase_table(s, 3).ravel())
    tau = np.array([0.0, 0.5, 2.0, 8.0], np.float32)
    for c in np.linspace(-1.0, 1.0, 17):
        np.testing.assert_allclose(
            p.octave_sum(float(c), tau), phys.octave_sum(s, tau, c, 3), rtol=2e-6, atol=1e-12
        )


@pytest.mark.gl
@pytest.mark.parametrize("phase", ["mie", "hg"])
def test_the_shaders_read_the_table(gl_context, convolved, phase: str) -> None:
    from cumuli.rendering.physical_gl import octave_sum_gl

    s = cu.RenderSettings(phase=phase)
    tau = np.array([0.0, 0.3, 1.0, 2.5, 6.0], np.float32)
    for c in (-1.0, -0.9, -0.2, 0.3, 0.6, 0.9, 0.99, 0.9999, 1.0):
        gl = octave_sum_gl(s, tau, c, 3, context=gl_context)
        np.testing.assert_allclose(gl, phys.octave_sum(s, tau, c, 3), rtol=2e-5, atol=1e-9)


def test_scaled_octaves_are_the_default(monkeypatch) -> None:
    """``OCTAVE_PHASE = "scaled"`` (the fitted default): no table, orders turn by
    phase(bⁿ·g)."""
    assert phys.OCTAVE_PHASE == "scaled"
    monkeypatch.setattr(phys, "OCTAVE_B", 0.7)
    s = cu.RenderSettings()
    p = physical_params(s, 2)
    assert len(p.order_phase) == 0
    c = 0.8
    weights = [w for w, _ in phys.octave_terms(s, c, 2)]
    assert weights[1] == pytest.approx(phys.OCTAVE_A * p.phase(c, 0.7), rel=1e-6)


@pytest.mark.parametrize(
    ("values", "match"),
    [
        (np.ones(10, np.float32), "order_phase must hold"),
        (np.full(_core.ORDER_PHASE_SIZE, -1.0, np.float32), "finite and >= 0"),
        (np.full(_core.ORDER_PHASE_SIZE, np.nan, np.float32), "finite and >= 0"),
    ],
)
def test_bad_tables_are_refused(convolved, values: np.ndarray, match: str) -> None:
    p = physical_params(cu.RenderSettings(), 2)
    p.order_phase = values
    with pytest.raises(ValueError, match=match):
        p.validate()
    with pytest.raises(ValueError, match=match):
        p.octave_sum(0.0, np.zeros(2, np.float32))


def test_a_table_must_be_flat() -> None:
    p = _core.PhysicalParams()
    with pytest.raises(ValueError, match="one-dimensional"):
        p.order_phase = np.ones((2, 64), np.float32)
