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
