"""Image files: EXR float32 and PNG sRGB8 round trips, atomic writes, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

import cumuli as cu
import cumuli.io.images as cio


def _image(h: int = 24, w: int = 32, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = rng.uniform(0.0, 1.0, (h, w, 4)).astype(np.float32)
    img[0, 0] = (0.0, 0.0, 0.0, 0.0)
    img[0, 1] = (1.0, 1.0, 1.0, 1.0)
    return img


def test_exr_round_trip_is_exact_float32(tmp_path: Path) -> None:
    img = _image()
    img[2, 3] = (1e-30, 3.5e4, -2.0, 0.25)  # values HALF could not hold
    path = cu.write_image(tmp_path / "a.exr", img, alpha="keep", exposure=1.0, tonemap="none")
    assert path == tmp_path / "a.exr"
    back = cu.read_image(path)
    assert back.dtype == np.float32 and back.shape == img.shape
    np.testing.assert_array_equal(back, img)
    inp = oiio.ImageInput.open(str(path))
    try:
        assert inp.spec().format == oiio.TypeDesc("float")
        assert inp.spec().channelnames == ("R", "G", "B", "A")
    finally:
        inp.close()


def test_row_zero_is_the_top(tmp_path: Path) -> None:
    img = np.zeros((4, 3, 4), np.float32)
    img[0, :, 0] = 1.0  # red top row
    img[..., 3] = 1.0
    cu.write_image(tmp_path / "t.png", img, exposure=1.0, tonemap="none")
    data = oiio.ImageInput.open(str(tmp_path / "t.png"))
    try:
        raw = data.read_image("uint8")
    finally:
        data.close()
    assert raw[0, 0, 0] == 255 and raw[-1, 0, 0] == 0


def test_png_round_trip_within_one_8_bit_step(tmp_path: Path) -> None:
    img = _image(seed=1)
    cu.write_image(tmp_path / "a.png", img, alpha="keep", exposure=1.0, tonemap="none")
    back = cu.read_image(tmp_path / "a.png")
    assert back.shape == img.shape and back.dtype == np.float32
    # Compared where the quantisation happens: in sRGB-encoded values, within half a step.
    step = 1.0 / 255.0
    err = np.abs(cio.linear_to_srgb(back[..., :3]) - cio.linear_to_srgb(img[..., :3]))
    assert err.max() <= 0.5 * step + 1e-6
    assert np.abs(back[..., 3] - img[..., 3]).max() <= 0.5 * step + 1e-6
    # Reading then writing again changes nothing.
    cu.write_image(tmp_path / "b.png", back, alpha="keep", exposure=1.0, tonemap="none")
    np.testing.assert_array_equal(cu.read_image(tmp_path / "b.png"), back)


def test_png_keeps_unassociated_alpha_so_colours_do_not_darken(tmp_path: Path) -> None:
    img = np.zeros((2, 2, 4), np.float32)
    img[...] = (0.8, 0.4, 0.2, 0.25)
    cu.write_image(tmp_path / "alpha.png", img, alpha="keep", exposure=1.0, tonemap="none")
    back = cu.read_image(tmp_path / "alpha.png")
    np.testing.assert_allclose(back[..., :3], img[..., :3], rtol=0.01)
    np.testing.assert_allclose(back[..., 3], 0.25, atol=0.5 / 255)
    cu.write_image(tmp_path / "alpha.exr", img, alpha="keep", exposure=1.0, tonemap="none")
    np.testing.assert_array_equal(cu.read_image(tmp_path / "alpha.exr"), img)


def test_rgb_input_gets_opaque_alpha(tmp_path: Path) -> None:
    rgb = _image()[..., :3]
    for name in ("rgb.exr", "rgb.png"):
        back = cu.read_image(cu.write_image(tmp_path / name, rgb, exposure=1.0, tonemap="none"))
        assert back.shape == (*rgb.shape[:2], 4)
        np.testing.assert_array_equal(back[..., 3], 1.0)
    np.testing.assert_array_equal(cu.read_image(tmp_path / "rgb.exr")[..., :3], rgb)


def test_float64_and_float16_images_are_accepted(tmp_path: Path) -> None:
    img = _image()
    cu.write_image(
        tmp_path / "d.exr", img.astype(np.float64), alpha="keep", exposure=1.0, tonemap="none"
    )
    np.testing.assert_array_equal(cu.read_image(tmp_path / "d.exr"), img)
    cu.write_image(
        tmp_path / "h.exr", img.astype(np.float16), alpha="keep", exposure=1.0, tonemap="none"
    )
    np.testing.assert_array_equal(cu.read_image(tmp_path / "h.exr"), img.astype(np.float16))


def test_to_srgb8_transfer_function() -> None:
    lin = np.array([[[0.0, 1.0, 0.5, 0.5], [0.0031308, 0.18, 2.0, -1.0]]], dtype=np.float32)
    out = cu.to_srgb8(lin, exposure=1.0, tonemap="none")
    assert out.dtype == np.uint8 and out.shape == lin.shape
    # 0.5 linear → 1.055·0.5^(1/2.4) − 0.055 = 0.7354 → 187.5 → 188; 0.18 → 0.4614 → 118;
    # 0.0031308 (the knee) → 0.04045 → 10; values clip; alpha is linear (0.5 → 128).
    assert out[0, 0].tolist() == [0, 255, 188, 128]
    assert out[0, 1].tolist() == [10, 118, 255, 0]


def test_srgb8_codes_round_trip() -> None:
    codes = np.arange(256, dtype=np.uint8)
    data = np.stack([codes, codes[::-1], codes, codes], axis=-1)[None]
    np.testing.assert_array_equal(
        cu.to_srgb8(cu.from_srgb8(data), exposure=1.0, tonemap="none"), data
    )
    linear = cu.from_srgb8(data)
    assert np.all(np.diff(linear[0, :, 0]) > 0)  # monotonic decode
    np.testing.assert_array_equal(linear[0, :, 3], codes / np.float32(255))


def test_failed_write_leaves_no_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(tmp: Path, *args: object) -> None:
        tmp.write_bytes(b"partial")  # what a crash half-way would leave
        raise OSError("disk full (simulated)")

    monkeypatch.setattr(cio, "_write_with_oiio", broken)
    with pytest.raises(OSError, match="disk full"):
        cu.write_image(tmp_path / "x.png", _image(), exposure=1.0, tonemap="none")
    assert list(tmp_path.iterdir()) == []


def test_failed_write_keeps_the_previous_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    old = _image(seed=3)
    cu.write_image(tmp_path / "keep.exr", old, alpha="keep", exposure=1.0, tonemap="none")

    def broken(tmp: Path, *args: object) -> None:
        raise OSError("simulated")

    monkeypatch.setattr(cio, "_write_with_oiio", broken)
    with pytest.raises(OSError):
        cu.write_image(tmp_path / "keep.exr", _image(seed=4), exposure=1.0, tonemap="none")
    np.testing.assert_array_equal(cu.read_image(tmp_path / "keep.exr"), old)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.exr"]


def test_unwritable_destinations(tmp_path: Path) -> None:
    (tmp_path / "dir.png").mkdir()
    with pytest.raises(OSError):
        cu.write_image(tmp_path / "dir.png", _image(), exposure=1.0, tonemap="none")
    (tmp_path / "file").write_text("not a folder")
    with pytest.raises(OSError):
        cu.write_image(tmp_path / "file" / "x.png", _image(), exposure=1.0, tonemap="none")
    with pytest.raises(OSError, match="does not exist"):
        cu.write_image(tmp_path / "missing" / "x.exr", _image(), exposure=1.0, tonemap="none")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.png", "file"]
    assert list((tmp_path / "dir.png").iterdir()) == []


@pytest.mark.parametrize("name", ["x.jpg", "x.tiff", "x", "x.exr.bak"])
def test_unknown_extension_is_rejected(tmp_path: Path, name: str) -> None:
    with pytest.raises(ValueError, match="extension"):
        cu.write_image(tmp_path / name, _image(), exposure=1.0, tonemap="none")
    with pytest.raises(ValueError, match="extension"):
        cu.read_image(tmp_path / name)
    assert list(tmp_path.iterdir()) == []


def test_extension_is_case_insensitive(tmp_path: Path) -> None:
    img = _image()
    np.testing.assert_array_equal(
        cu.read_image(
            cu.write_image(tmp_path / "UP.EXR", img, alpha="keep", exposure=1.0, tonemap="none")
        ),
        img,
    )


@pytest.mark.parametrize(
    ("img", "error", "match"),
    [
        (np.zeros((4, 4, 4), np.uint8), TypeError, "float"),
        (np.zeros((4, 4), np.float32), ValueError, "shape"),
        (np.zeros((4, 4, 2), np.float32), ValueError, "shape"),
        (np.zeros((0, 4, 4), np.float32), ValueError, "pixels"),
        (np.full((2, 2, 4), np.nan, np.float32), ValueError, "NaN"),
        ([[[0.0, 0.0, 0.0]]], TypeError, "numpy"),
    ],
)
def test_bad_images_are_rejected(tmp_path: Path, img, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        cu.write_image(tmp_path / "bad.exr", img, exposure=1.0, tonemap="none")
    assert list(tmp_path.iterdir()) == []


def test_to_srgb8_bad_input() -> None:
    with pytest.raises(TypeError):
        cu.to_srgb8(np.zeros((2, 2, 4), np.uint8), exposure=1.0, tonemap="none")
    with pytest.raises(ValueError, match="NaN"):
        cu.to_srgb8(np.full((1, 1, 3), np.inf, np.float32), exposure=1.0, tonemap="none")


def test_read_missing_and_corrupt_files(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        cu.read_image(tmp_path / "none.exr")
    (tmp_path / "junk.png").write_bytes(b"\x89PNG not really a png")
    with pytest.raises(OSError):
        cu.read_image(tmp_path / "junk.png")
    (tmp_path / "junk.exr").write_bytes(b"\x00" * 64)
    with pytest.raises(OSError):
        cu.read_image(tmp_path / "junk.exr")


def test_reads_grey_and_rgb_files_written_elsewhere(tmp_path: Path) -> None:
    grey = np.arange(12, dtype=np.uint8).reshape(3, 4) * 20
    spec = oiio.ImageSpec(4, 3, 1, oiio.UINT8)
    out = oiio.ImageOutput.create(str(tmp_path / "g.png"))
    assert out.open(str(tmp_path / "g.png"), spec)
    assert out.write_image(grey[..., None]) and out.close()
    img = cu.read_image(tmp_path / "g.png")
    assert img.shape == (3, 4, 4)
    want = cu.from_srgb8(np.repeat(grey[..., None], 3, axis=2))
    np.testing.assert_allclose(img[..., :3], want, atol=1e-7)
    np.testing.assert_array_equal(img[..., 3], 1.0)
