"""The sun-and-sky split of the reference views (``tests/references/sun_and_sky.py``): its two
scenes hold one light each, and its errors are each part's over the blocks' whole light."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "references"))
import mitsuba_views as mv  # noqa: E402
import sun_and_sky as sas  # noqa: E402


def test_the_parts_hold_one_light_each() -> None:
    scene, _ = mv.VIEWS["toplit"]()
    parts = sas.parts(scene)
    assert set(parts) == {"sun", "sky"}
    assert parts["sun"].sun == scene.sun
    assert max(parts["sun"].sky.zenith) <= sas.OFF and parts["sun"].sky.sun_disc_intensity == 0
    assert parts["sky"].sky == scene.sky
    assert parts["sky"].sun.intensity == sas.OFF
    assert parts["sky"].sun.direction == scene.sun.direction


def test_split_errors_are_over_the_whole_light() -> None:
    h, w = mv.HEIGHT, mv.WIDTH
    ref_sun = np.zeros((h, w, 4), np.float32)
    ref_sun[..., :3], ref_sun[..., 3] = 1.0, 1.0
    ref_sky = ref_sun.copy()
    ref_sky[..., :3] = 3.0
    img_sun, img_sky = ref_sun.copy(), ref_sky.copy()
    img_sun[..., :3] *= 0.8  # the sun's part 20 % too dark: 5 % of the whole light
    out = sas.split_errors({"sun": (img_sun, ref_sun), "sky": (img_sky, ref_sky)})
    assert np.isclose(out["sun"]["share"], 0.25) and np.isclose(out["sky"]["share"], 0.75)
    assert np.isclose(out["sun"]["mean"], -0.2) and np.isclose(out["sky"]["mean"], 0.0)
    assert np.isclose(out["sun"]["median"], 0.05) and np.isclose(out["sun"]["p90"], 0.05)
    assert out["sky"]["median"] == 0.0
    bare = {k: (a, b * np.float32([1, 1, 1, 0])) for k, (a, b) in
            {"sun": (img_sun, ref_sun), "sky": (img_sky, ref_sky)}.items()}  # fmt: skip
    with pytest.raises(ValueError, match="no block"):
        sas.split_errors(bare)


def test_the_whole_phase_keeps_its_peak() -> None:
    """The single-scattering reference's phase is the whole phase: it integrates to one and is
    the δ-M table times ``1 − f`` outside the forward cone."""
    scene, _ = mv.VIEWS["toplit"]()
    whole, f = mv.phase_table(scene, keep_peak=True)
    scaled, f2 = mv.phase_table(scene)
    assert f == f2 and 0.3 < f < 0.6  # the Mie phase's diffraction peak
    c = np.linspace(-1.0, 1.0, whole.size)
    integral = 2 * np.pi * float(np.sum((whole[1:] + whole[:-1]) / 2 * np.diff(c)))
    assert integral == pytest.approx(1.0, abs=0.02)
    outside = c < mv.PEAK_COS - 2 * (c[1] - c[0])
    np.testing.assert_allclose(whole[outside], scaled[outside] * (1 - f), rtol=1e-9)
    assert whole[-1] > 100 * scaled[-1] * (1 - f) + 1.0  # the peak itself is kept


def test_single_split_by_rows() -> None:
    h, w = mv.HEIGHT, mv.WIDTH
    ref = np.zeros((h, w, 4), np.float32)
    ref[..., :3], ref[..., 3] = 2.0, 1.0
    ref1 = ref.copy()
    ref1[..., :3] = 0.5  # a quarter of the light is single scattering
    img1 = ref1.copy()
    img1[..., :3] *= 0.8  # cumuli's single scattering 20 % short
    img = ref.copy()
    img[..., :3] = 0.4 + 1.5 * 1.2  # and the rest 20 % over
    img[: h // 2, :, :3] = 0.4 + 1.5  # ... but only in the bottom half
    out = sas.single_split((img, ref), (img1, ref1))
    assert set(out) == {"all", "top", "middle", "bottom"}
    for row in out.values():
        assert row["share"] == pytest.approx(0.25) and row["single"] == pytest.approx(0.8)
    assert out["top"]["rest"] == pytest.approx(1.0)
    assert out["bottom"]["rest"] == pytest.approx(1.2)
    assert 1.0 < out["all"]["rest"] < 1.2
    empty = ref * np.float32([1, 1, 1, 0])
    with pytest.raises(ValueError, match="covered rows"):
        sas.single_split((img, empty), (img1, ref1))
