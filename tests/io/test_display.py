"""Display transforms: exposure and tone mapping in `to_srgb8` / `write_image` and the CLI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.io.images import TONEMAPS, linear_to_srgb, tone_map


def test_tone_curves() -> None:
    x = np.array([0.0, 0.18, 1.0, 4.0, 100.0])
    np.testing.assert_allclose(tone_map(x, "none"), np.clip(x, 0, 1))
    np.testing.assert_allclose(tone_map(x, "reinhard"), x / (1 + x))
    aces = tone_map(x, "aces")
    # Narkowicz's fit: 0 → 0, 0.18 → ≈ 0.27 (mid grey lifted), monotone, rolls off below 1.
    assert aces[0] == 0 and aces[1] == pytest.approx(
        0.18 * 0.4818 / (0.18 * 1.0274 + 0.14), rel=1e-6
    )
    assert np.all(np.diff(aces) > 0) and aces[-1] <= 1 and aces[-2] > 0.95
    assert TONEMAPS == ("none", "aces", "reinhard")


def test_to_srgb8_applies_exposure_then_the_curve() -> None:
    img = np.random.default_rng(0).random((5, 7, 4)).astype(np.float32) * 3
    np.testing.assert_array_equal(
        cu.to_srgb8(img, exposure=1.0, tonemap="none"), cu.to_srgb8(img, 1.0, "none")
    )
    out = cu.to_srgb8(img, 0.5, "aces")
    want = np.floor(linear_to_srgb(tone_map(img[..., :3] * 0.5, "aces")) * 255 + 0.5)
    np.testing.assert_array_equal(out[..., :3], want)
    np.testing.assert_array_equal(
        out[..., 3], cu.to_srgb8(img, exposure=1.0, tonemap="none")[..., 3]
    )  # alpha untouched
    assert (
        cu.to_srgb8(img, 2.0, tonemap="none")[..., :3]
        >= cu.to_srgb8(img, exposure=1.0, tonemap="none")[..., :3]
    ).all()
    # Highlights: clipped without a curve, distinguishable with one.
    hot = np.array([[[4.0] * 3, [8.0] * 3]], np.float32)
    assert (
        cu.to_srgb8(hot, exposure=1.0, tonemap="none")[0, 0, 0]
        == cu.to_srgb8(hot, exposure=1.0, tonemap="none")[0, 1, 0]
        == 255
    )
    assert (
        cu.to_srgb8(hot, tonemap="aces", exposure=1.0)[0, 0, 0]
        < cu.to_srgb8(hot, tonemap="aces", exposure=1.0)[0, 1, 0]
    )


@pytest.mark.parametrize(
    ("kw", "error"),
    [({"exposure": -1.0}, ValueError), ({"exposure": float("inf")}, ValueError),
     ({"exposure": "2"}, TypeError), ({"tonemap": "filmic"}, ValueError)],
)  # fmt: skip
def test_bad_display_arguments(tmp_path: Path, kw: dict, error: type) -> None:
    img = np.ones((2, 2, 4), np.float32)
    name = next(iter(kw))
    with pytest.raises(error, match=name):
        cu.to_srgb8(img, **kw)
    with pytest.raises(error, match=name):
        cu.write_image(tmp_path / "x.png", img, **kw)
    assert list(tmp_path.iterdir()) == []


def test_write_image_uses_them_for_png_only(tmp_path: Path) -> None:
    img = np.random.default_rng(1).random((4, 6, 4)).astype(np.float32) * 5
    img[..., 3] = 1
    cu.write_image(tmp_path / "a.png", img, exposure=0.7, tonemap="aces")
    np.testing.assert_array_equal(
        cu.to_srgb8(cu.read_image(tmp_path / "a.png"), exposure=1.0, tonemap="none"),
        cu.to_srgb8(img, 0.7, "aces"),
    )
    cu.write_image(tmp_path / "a.exr", img, exposure=0.7, tonemap="aces")
    np.testing.assert_array_equal(cu.read_image(tmp_path / "a.exr"), img)  # linear, as given


def test_cli_render_takes_exposure_and_tonemap(tmp_path: Path) -> None:
    from cumuli.cli import main

    scene = cu.Scene([cu.gaussian_cumulus(n=6, seed=2)], noise=cu.Noise(seed=1, size=32),
                     sun=cu.Sun(intensity=4.0),
                     settings=cu.RenderSettings(lighting="paper"))  # fmt: skip
    path = scene.save(tmp_path / "s.json")
    args = ["render", str(path), "--size", "24x18", "--backend", "cpu"]
    assert main([*args, "-o", str(tmp_path / "lin.exr")]) == 0
    assert (
        main([*args, "-o", str(tmp_path / "t.png"), "--exposure", "0.5", "--tonemap", "aces"]) == 0
    )
    lin = cu.read_image(tmp_path / "lin.exr")
    np.testing.assert_array_equal(
        cu.to_srgb8(cu.read_image(tmp_path / "t.png"), exposure=1.0, tonemap="none"),
        cu.to_srgb8(lin, 0.5, "aces"),
    )
    with pytest.raises(SystemExit) as exc:  # argparse refuses it
        main([*args, "-o", str(tmp_path / "b.png"), "--exposure", "-2"])
    assert exc.value.code == 2 and not (tmp_path / "b.png").exists()
