"""`cu.show` and `cu.Image`: renders and scenes shown inline with their display settings."""

from __future__ import annotations

import base64
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import cumuli as cu
from cumuli.io.png import png_bytes
from cumuli.jupyter import display


def _decode_png(data: bytes) -> np.ndarray:
    """PNG bytes → uint8 pixels, through OpenImageIO (an independent decoder)."""
    import OpenImageIO as oiio

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "x.png"
        path.write_bytes(data)
        config = oiio.ImageSpec()
        config.attribute("oiio:UnassociatedAlpha", 1)  # the bytes as stored
        inp = oiio.ImageInput.open(str(path), config)
        assert inp is not None, oiio.geterror()
        pixels = inp.read_image("uint8")
        inp.close()
    return np.asarray(pixels)


def test_png_bytes_round_trip() -> None:
    rgb = np.random.default_rng(0).integers(0, 256, (7, 5, 3), dtype=np.uint8)
    np.testing.assert_array_equal(_decode_png(png_bytes(rgb)), rgb)
    rgba = np.random.default_rng(1).integers(0, 256, (3, 4, 4), dtype=np.uint8)
    np.testing.assert_array_equal(_decode_png(png_bytes(rgba, level=1)), rgba)
    with pytest.raises(TypeError, match="uint8"):
        png_bytes(rgb.astype(np.float32))
    with pytest.raises(ValueError, match="level"):
        png_bytes(rgb, level=12)
    with pytest.raises(ValueError, match="pixels"):
        png_bytes(np.zeros((2, 2, 2), np.uint8))


def test_image_displays_its_settings() -> None:
    img = np.random.default_rng(2).random((6, 8, 4)).astype(np.float32) * 3
    shown = cu.Image(img, exposure=0.5, tonemap="aces", title="a <cloud>")
    want = cu.to_srgb8(img, 0.5, "aces")[..., :3]
    np.testing.assert_array_equal(_decode_png(shown._repr_png_()), want)
    page = shown._repr_html_()
    assert "8×6, exposure 0.5, tone map aces" in page and "a &lt;cloud&gt;" in page
    data = page.split("base64,")[1].split('"')[0]
    np.testing.assert_array_equal(_decode_png(base64.b64decode(data)), want)
    assert np.asarray(shown) is img  # the linear pixels, untouched
    assert "8×6×4" in repr(shown)
    with pytest.raises(ValueError, match="tonemap"):
        cu.Image(img, tonemap="filmic")
    with pytest.raises(TypeError, match="float"):
        cu.Image(np.zeros((2, 2, 3), np.uint8))


def _capture(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    shown: list[Any] = []
    monkeypatch.setattr(display, "_display", shown.append)
    return shown


def test_show_an_image_and_a_scene(monkeypatch: pytest.MonkeyPatch) -> None:
    shown = _capture(monkeypatch)
    img = np.full((4, 4, 4), 0.25, np.float32)
    assert cu.show(img, exposure=2.0) is None
    assert isinstance(shown[-1], cu.Image)
    np.testing.assert_array_equal(shown[-1].srgb8(), cu.to_srgb8(img, 2.0)[..., :3])
    scene = cu.Scene([cu.gaussian_cumulus(n=6, seed=2)], noise=cu.Noise(seed=1, size=32))
    cu.show(scene, size=(24, 16), backend="cpu", tonemap="reinhard")
    want = cu.render(scene, width=24, height=16, backend="cpu", progress=False)
    np.testing.assert_array_equal(np.asarray(shown[-1]), want)
    assert shown[-1].tonemap == "reinhard" and shown[-1].shape == (16, 24, 4)
    lit = cu.prepare_light(scene)
    cam = cu.Camera((0, 5, -40), (0, 3, 0))
    cu.show(lit, size=(20, 12), camera=cam, backend="cpu")
    want = cu.render(lit, cam, 20, 12, backend="cpu", progress=False)
    np.testing.assert_array_equal(np.asarray(shown[-1]), want)
    cu.show([img, lit], title=["flat", "lit"], size=(20, 12), camera=cam, backend="cpu")
    gallery = shown[-1]
    assert [i.title for i in gallery.images] == ["flat", "lit"]
    np.testing.assert_array_equal(np.asarray(gallery.images[1]), want)
    assert gallery._repr_html_().count("<img") == 2
    # cu.render itself still returns a plain array.
    assert type(want) is np.ndarray


def test_show_refuses_bad_input(monkeypatch: pytest.MonkeyPatch) -> None:
    shown = _capture(monkeypatch)
    with pytest.raises(TypeError, match="show takes"):
        cu.show([[1.0]])
    with pytest.raises(TypeError, match="Scene or LitScene"):
        cu.show(np.zeros((2, 2, 3), np.float32), size=(4, 4))
    with pytest.raises(TypeError, match="size"):
        cu.show(cu.Scene([cu.gaussian_cumulus(n=4, seed=1)]), size=5)
    with pytest.raises(ValueError, match="exposure"):
        cu.show(np.zeros((2, 2, 3), np.float32), exposure=-1.0)
    with pytest.raises(ValueError, match="title"):
        cu.show([np.zeros((2, 2, 3), np.float32)], title=["a", "b"])
    assert shown == []


def test_an_image_keeps_its_settings_unless_told(monkeypatch: pytest.MonkeyPatch) -> None:
    shown = _capture(monkeypatch)
    img = np.random.default_rng(3).random((4, 5, 3)).astype(np.float32) * 2
    kept = cu.Image(img, exposure=0.5, tonemap="aces", title="mine")
    cu.show([img, kept], title=["plain", None])  # type: ignore[list-item]
    plain, mine = shown[-1].images
    # An array gets the package's display defaults, the same as to_srgb8 and write_image.
    shown_default = (cu.io.images.DISPLAY_EXPOSURE, cu.io.images.DISPLAY_TONEMAP, "plain")
    assert (plain.exposure, plain.tonemap, plain.title) == shown_default
    assert (mine.exposure, mine.tonemap, mine.title) == (0.5, "aces", "mine")
    cu.show(kept, tonemap="reinhard")
    assert (shown[-1].exposure, shown[-1].tonemap, shown[-1].title) == (0.5, "reinhard", "mine")


def test_a_scene_is_shown_as_its_lighting_mode_is_meant_to_be_seen(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The paper mode untoned (its figures), the physical default through the filmic curve."""
    shown = _capture(monkeypatch)
    cloud = cu.gaussian_cumulus(n=4, seed=1)
    paper = cu.Scene([cloud], settings=cu.RenderSettings(lighting="paper"))
    cu.show([paper, cu.Scene([cloud])], size=(8, 6), backend="cpu")
    as_paper, as_physical = shown[-1].images
    assert (
        (as_paper.exposure, as_paper.tonemap) == cu.io.images.display_for("paper") == (1.0, "none")
    )
    assert (as_physical.exposure, as_physical.tonemap) == cu.io.images.display_for("physical")
    assert as_physical.tonemap != "none"
    cu.show(paper, size=(8, 6), backend="cpu", exposure=2.0)  # what is given wins
    assert (shown[-1].exposure, shown[-1].tonemap) == (2.0, "none")
