"""Image files through OpenImageIO: float32 OpenEXR and 8-bit sRGB PNG.

cumuli images are ``(H, W, 4)`` float32 **linear** RGBA with row 0 at the top (DESIGN §3). Alpha
is *unassociated* (straight): colour channels are not multiplied by alpha. That is what PNG stores
too, so :func:`write_image` tells OpenImageIO not to touch alpha (``oiio:UnassociatedAlpha``);
otherwise OIIO would un-premultiply on write and premultiply on read, and a PNG round trip would
darken every translucent pixel.

- ``.exr``: float32 RGBA (not HALF: a write/read round trip returns the same bits), lossless ZIP.
- ``.png``: 8-bit sRGB through :func:`to_srgb8` (the sRGB transfer function on RGB, alpha linear).

**Alpha.** A render's alpha is the clouds' coverage ``1 − T`` while its colour is already
composited over the sky, so :func:`write_image` saves what you see by default
(``alpha="opaque"``: alpha 1); ``alpha="keep"`` writes the image's own alpha (for compositing
elsewhere, and for an exact EXR round trip).

**Safety.** Writes are atomic and verified: the file is written to a temporary in the destination
folder, read back and compared with what was meant (a full disk that the PNG writer does not
report is caught there), flushed, and only then renamed over the destination (see
:mod:`cumuli._util.atomic`). **Memory** stays bounded: conversion goes in slabs of rows, so a write
needs little beyond its input and a read little beyond its float32 output; images larger than
:data:`MAX_PIXELS` are refused before anything is decoded or encoded. Errors: unsupported
extension → ``ValueError``; bad array → ``TypeError`` / ``ValueError``; a missing folder, a
non-regular file or any OpenImageIO failure → ``OSError``.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import OpenImageIO as oiio

from cumuli._util.atomic import atomic_target, resolve_target

#: Extensions write_image and read_image handle, and what they store.
FORMATS = {".exr": "float32 linear RGBA (OpenEXR, ZIP)", ".png": "8-bit sRGB RGBA"}
#: OpenImageIO format names (the temporary file has no extension to pick them from).
_OIIO_FORMATS = {".exr": "openexr", ".png": "png"}
#: What write_image does with alpha.
ALPHA_MODES = ("opaque", "keep")

#: Largest edge accepted (OpenEXR and PNG allow more, but nothing cumuli makes is near it).
MAX_EDGE = 1 << 16
#: Largest image read_image decodes and write_image writes, in pixels: 2²⁶ (8192 × 8192, as
#: large as cumuli renders; 1 GiB as float32 RGBA). Checked from the header, before decoding.
MAX_PIXELS = 1 << 26
#: Kept for callers of the old name.
MAX_READ_PIXELS = MAX_PIXELS
#: Pixels converted per slab of rows (bounds the intermediates of the sRGB conversion).
SLAB_PIXELS = 1 << 16


def _extension(path: str | os.PathLike[str]) -> str:
    ext = Path(path).suffix.lower()
    if ext not in FORMATS:
        raise ValueError(
            f"path has an unsupported image extension {ext!r}; use one of {sorted(FORMATS)}"
        )
    return ext


def _as_rgba(img: Any, name: str = "img") -> np.ndarray:
    """``img`` as a C-contiguous float32 ``(H, W, 3|4)`` array of finite values (no copy when
    it already is one; the finiteness check goes slab by slab)."""
    if not isinstance(img, np.ndarray):
        raise TypeError(f"{name} must be a numpy array, got {type(img).__name__}")
    if img.dtype.kind != "f":
        raise TypeError(f"{name} must be a float array (linear RGBA), got dtype {img.dtype}")
    if img.ndim != 3 or img.shape[2] not in (3, 4):
        raise ValueError(f"{name} must have shape (H, W, 3) or (H, W, 4), got {img.shape}")
    h, w = img.shape[:2]
    if not (1 <= h <= MAX_EDGE and 1 <= w <= MAX_EDGE):
        raise ValueError(f"{name} must be 1 to {MAX_EDGE} pixels on each side, got {h}×{w}")
    if h * w > MAX_PIXELS:
        raise ValueError(f"{name} has {h}×{w} = {h * w} pixels, more than the limit {MAX_PIXELS}")
    for y0, y1 in _slabs(h, w):
        if not np.isfinite(img[y0:y1]).all():
            raise ValueError(f"{name} contains NaN or infinite values")
    return np.ascontiguousarray(img, dtype=np.float32)


def _slabs(height: int, width: int) -> Iterator[tuple[int, int]]:
    """Row ranges of about :data:`SLAB_PIXELS` pixels (at least one row)."""
    rows = max(1, SLAB_PIXELS // width)
    for y0 in range(0, height, rows):
        yield y0, min(height, y0 + rows)


def linear_to_srgb(linear: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1) on values clipped to [0, 1], as float64."""
    c = np.clip(linear.astype(np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def srgb_to_linear(encoded: np.ndarray) -> np.ndarray:
    """Inverse of :func:`linear_to_srgb` (sRGB-encoded values in [0, 1] → linear), as float64."""
    e = encoded.astype(np.float64)
    return np.where(e <= 0.04045, e / 12.92, np.power((e + 0.055) / 1.055, 2.4))


#: Tone-mapping operators of :func:`to_srgb8` (applied to ``exposure · RGB``, linear in and out).
TONEMAPS = ("none", "aces", "reinhard")
#: The display defaults of :func:`to_srgb8`, :func:`write_image`, the CLI, the demo and the
#: notebooks (the one place they are set): the physical lighting mode's radiance exposed by 0.8
#: through the ACES filmic curve. The paper lighting mode was made for a plain clip
#: (``exposure=1.0, tonemap="none"``, :data:`PAPER_DISPLAY`).
DISPLAY_EXPOSURE = 0.8
DISPLAY_TONEMAP = "aces"
PAPER_DISPLAY: tuple[float, str] = (1.0, "none")


def display_for(lighting: str) -> tuple[float, str]:
    """``(exposure, tonemap)`` to show a render of the lighting mode ``lighting``: the display
    defaults for ``"physical"``, :data:`PAPER_DISPLAY` for ``"paper"``."""
    if lighting == "paper":
        return PAPER_DISPLAY
    if lighting == "physical":
        return DISPLAY_EXPOSURE, DISPLAY_TONEMAP
    raise ValueError(f"lighting must be 'paper' or 'physical', got {lighting!r}")


def tone_map(rgb: np.ndarray, operator: str = "none") -> np.ndarray:
    """Linear radiance → linear display values in [0, 1] (float64).

    ``"none"`` clips; ``"aces"`` is Narkowicz's fit of the ACES filmic curve (2015),
    ``x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)``; ``"reinhard"`` is ``x / (1 + x)`` (Reinhard et
    al. 2002), per channel.
    """
    if operator not in TONEMAPS:
        raise ValueError(f"tonemap must be one of {TONEMAPS}, got {operator!r}")
    x = np.maximum(np.asarray(rgb, dtype=np.float64), 0.0)
    if operator == "aces":
        x = x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14)
    elif operator == "reinhard":
        x = x / (1.0 + x)
    return np.clip(x, 0.0, 1.0)


def to_srgb8(
    img: np.ndarray, exposure: float = DISPLAY_EXPOSURE, tonemap: str = DISPLAY_TONEMAP
) -> np.ndarray:
    """Display bytes of a linear image: ``(H, W, 3|4)`` float → ``uint8`` of the same shape.

    RGB is multiplied by ``exposure``, tone mapped (:data:`TONEMAPS`: ``"none"`` clips to
    [0, 1], ``"aces"`` and ``"reinhard"`` roll highlights off instead) and goes through the sRGB
    transfer function (defaults: :data:`DISPLAY_EXPOSURE` and :data:`DISPLAY_TONEMAP`, made for
    the physical lighting mode; a paper-mode render is shown with ``1.0, "none"``); alpha is
    scaled linearly and stays unassociated (colours are not multiplied by it). Values are
    rounded to nearest.
    """
    if isinstance(exposure, bool) or not isinstance(
        exposure, (int, float, np.integer, np.floating)
    ):
        raise TypeError(f"exposure must be a number, got {type(exposure).__name__}")
    if not (np.isfinite(exposure) and exposure >= 0):
        raise ValueError(f"exposure must be finite and >= 0, got {exposure}")
    if tonemap not in TONEMAPS:
        raise ValueError(f"tonemap must be one of {TONEMAPS}, got {tonemap!r}")
    operator = tonemap
    if not isinstance(img, np.ndarray):
        raise TypeError(f"img must be a numpy array, got {type(img).__name__}")
    if img.dtype.kind != "f":
        raise TypeError(f"img must be a float array (linear RGBA), got dtype {img.dtype}")
    if img.ndim != 3 or img.shape[2] not in (3, 4):
        raise ValueError(f"img must have shape (H, W, 3) or (H, W, 4), got {img.shape}")
    if not np.isfinite(img).all():
        raise ValueError("img contains NaN or infinite values")
    out = np.empty(img.shape, dtype=np.float64)
    rgb = img[..., :3]
    if exposure != 1.0 or operator != "none":
        rgb = tone_map(rgb.astype(np.float64) * float(exposure), operator)
    out[..., :3] = linear_to_srgb(rgb)
    if img.shape[2] == 4:
        out[..., 3] = np.clip(img[..., 3], 0.0, 1.0)
    return np.floor(out * 255.0 + 0.5).astype(np.uint8)


def from_srgb8(data: np.ndarray) -> np.ndarray:
    """Inverse of :func:`to_srgb8`: ``uint8`` sRGB(A) → float32 linear, same shape."""
    if not isinstance(data, np.ndarray) or data.dtype != np.uint8:
        raise TypeError("data must be a uint8 numpy array")
    if data.ndim != 3 or data.shape[2] not in (3, 4):
        raise ValueError(f"data must have shape (H, W, 3) or (H, W, 4), got {data.shape}")
    scaled = data.astype(np.float64) / 255.0
    out = scaled.copy()
    out[..., :3] = srgb_to_linear(scaled[..., :3])
    return out.astype(np.float32)


def _oiio_error(what: str, path: Path, obj: Any = None) -> OSError:
    msg = (obj.geterror() if obj is not None else "") or oiio.geterror() or "unknown error"
    return OSError(f"{what} {str(path)!r} failed: {msg}")


def _slab_data(ext: str, rgba: np.ndarray, y0: int, y1: int, opaque: bool) -> np.ndarray:
    """Rows ``[y0, y1)`` as the file stores them: float32 RGBA (EXR) or sRGB8 RGBA (PNG)."""
    rows = rgba[y0:y1]
    if rows.shape[2] == 3 or opaque:
        full = np.empty((y1 - y0, rows.shape[1], 4), np.float32)
        full[..., :3] = rows[..., :3]
        full[..., 3] = 1.0
        rows = full
    return rows if ext == ".exr" else to_srgb8(rows, 1.0, "none")


def _write_with_oiio(tmp: Path, ext: str, rgba: np.ndarray, opaque: bool = False) -> None:
    """Write ``rgba`` to ``tmp`` in ``ext``'s format, slab by slab."""
    h, w = rgba.shape[:2]
    if ext == ".exr":
        spec = oiio.ImageSpec(w, h, 4, oiio.FLOAT)
        spec.attribute("compression", "zip")
    else:
        spec = oiio.ImageSpec(w, h, 4, oiio.UINT8)
        spec.attribute("oiio:ColorSpace", "sRGB")
    spec.channelnames = ("R", "G", "B", "A")
    spec.alpha_channel = 3
    spec.attribute("oiio:UnassociatedAlpha", 1)
    out = oiio.ImageOutput.create(_OIIO_FORMATS[ext])
    if out is None:
        raise _oiio_error("creating an image writer for", tmp)
    try:
        if not out.open(str(tmp), spec):
            raise _oiio_error("opening", tmp, out)
        for y0, y1 in _slabs(h, w):
            if not out.write_scanlines(y0, y1, 0, _slab_data(ext, rgba, y0, y1, opaque)):
                raise _oiio_error("writing", tmp, out)
    finally:
        closed = out.close()
    if not closed:
        raise _oiio_error("closing", tmp, out)


def _verify(tmp: Path, ext: str, rgba: np.ndarray, opaque: bool) -> None:
    """Read ``tmp`` back slab by slab and compare it with what was written: a writer that did
    not report a short write (OpenImageIO's PNG writer on a full disk) is caught here."""
    h, w = rgba.shape[:2]
    inp = oiio.ImageInput.open(str(tmp), _read_config())
    if inp is None:
        raise OSError(
            f"writing {str(tmp)!r} failed: the file read back is not a valid image "
            f"(disk full?): {oiio.geterror()}"
        )
    try:
        spec = inp.spec()
        if (spec.width, spec.height, spec.nchannels) != (w, h, 4):
            raise OSError(f"writing {str(tmp)!r} failed: the file read back has the wrong size")
        kind = oiio.FLOAT if ext == ".exr" else oiio.UINT8
        for y0, y1 in _slabs(h, w):
            back = inp.read_scanlines(y0, y1, 0, 0, 4, kind)
            want = _slab_data(ext, rgba, y0, y1, opaque)
            if back is None or not np.array_equal(np.asarray(back).reshape(want.shape), want):
                raise OSError(
                    f"writing {str(tmp)!r} failed: the file read back differs from the image "
                    f"(disk full or I/O error): {inp.geterror() or 'rows differ'}"
                )
    finally:
        inp.close()


def write_image(
    path: str | os.PathLike[str],
    img: np.ndarray,
    alpha: str = "opaque",
    *,
    exposure: float = DISPLAY_EXPOSURE,
    tonemap: str = DISPLAY_TONEMAP,
) -> Path:
    """Write a linear ``(H, W, 3|4)`` float image to ``.exr`` (float32) or ``.png`` (8-bit sRGB).

    Row 0 is the top of the picture. ``alpha="opaque"`` (the default) saves what you see: alpha 1
    everywhere (a render's colour is already composited over the sky; its alpha is the clouds'
    coverage ``1 − T``); ``alpha="keep"`` writes the image's alpha (straight, not premultiplied).
    ``exposure`` and ``tonemap`` are :func:`to_srgb8`'s and apply to ``.png`` only (an ``.exr``
    keeps the linear radiance).
    The write is atomic and verified (temporary file in the same folder, read back, flushed,
    then :func:`os.replace`; a symlink is written through, the file mode kept); on failure
    nothing is left behind and an existing file is unchanged. At most :data:`MAX_PIXELS`
    pixels. Returns the path written.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or path-like, got {type(path).__name__}")
    if not isinstance(alpha, str) or alpha not in ALPHA_MODES:
        raise ValueError(f"alpha must be one of {ALPHA_MODES}, got {alpha!r}")
    target = Path(path)
    ext = _extension(target)
    rgba = _as_rgba(img)
    to_srgb8(rgba[:1, :1], exposure, tonemap)  # checks both before anything is written
    if ext == ".png" and (exposure != 1.0 or tonemap != "none"):
        # The display values (in [0, 1], float64: to_srgb8 of them gives the same bytes).
        shown = rgba.astype(np.float64)
        shown[..., :3] = tone_map(shown[..., :3] * float(exposure), tonemap)
        rgba = shown
    real = resolve_target(target)
    folder = real.parent
    if not folder.is_dir():
        raise FileNotFoundError(f"path's folder {str(folder)!r} does not exist")
    if real.is_dir():
        raise IsADirectoryError(f"path {str(target)!r} is a directory")
    opaque = alpha == "opaque"
    with atomic_target(target, verify=lambda tmp: _verify(tmp, ext, rgba, opaque)) as tmp:
        _write_with_oiio(tmp, ext, rgba, opaque)
    return target


def _read_config() -> Any:
    """Reader options: straight alpha, as written (OIIO would premultiply otherwise)."""
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    return config


def _lut(bits: int, srgb: bool) -> np.ndarray:
    """float32 value of every ``bits``-bit code: sRGB-decoded or linear (code / max)."""
    codes = np.arange(1 << bits, dtype=np.float64) / float((1 << bits) - 1)
    return (srgb_to_linear(codes) if srgb else codes).astype(np.float32)


def read_image(path: str | os.PathLike[str]) -> np.ndarray:
    """Read an ``.exr`` or ``.png`` into ``(H, W, 4)`` float32 linear RGBA, row 0 at the top.

    EXR values are returned as stored. 8/16-bit files are decoded from sRGB unless they declare a
    linear colour space. One channel is read as grey, two as grey + alpha, three get alpha 1.
    The declared size is checked first (at most :data:`MAX_PIXELS` pixels, :data:`MAX_EDGE` a
    side); pixels are then decoded slab by slab into the output, so memory stays close to the
    output's ``16·W·H`` bytes.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or path-like, got {type(path).__name__}")
    source = Path(path)
    _extension(source)
    try:
        mode = source.stat().st_mode
    except FileNotFoundError:
        raise FileNotFoundError(f"image {str(source)!r} does not exist") from None
    if not stat.S_ISREG(mode):
        raise OSError(f"image {str(source)!r} is not a regular file")
    inp = oiio.ImageInput.open(str(source), _read_config())
    if inp is None:
        raise _oiio_error("opening", source)
    try:
        return _decode(inp, source)
    finally:
        inp.close()


def _decode(inp: Any, source: Path) -> np.ndarray:
    spec = inp.spec()
    w, h, c = spec.width, spec.height, spec.nchannels
    # The declared size is checked before the pixels are decoded: a small, highly compressed
    # file can declare gigabytes.
    if not (1 <= w <= MAX_EDGE and 1 <= h <= MAX_EDGE):
        raise ValueError(
            f"image {str(source)!r} is {w}×{h}: each side must be 1 to {MAX_EDGE} pixels"
        )
    if w * h > MAX_PIXELS:
        raise ValueError(
            f"image {str(source)!r} declares {w}×{h} = {w * h} pixels, more than the limit "
            f"{MAX_PIXELS} (cumuli.io.images.MAX_PIXELS); nothing was decoded"
        )
    if not 1 <= c <= 4:
        raise ValueError(f"image {str(source)!r} has {c} channels; 1 to 4 are read")
    bits = {oiio.UINT8: 8, oiio.UINT16: 16}.get(spec.format.basetype)
    srgb = "lin" not in spec.get_string_attribute("oiio:ColorSpace").lower()
    colour_lut = linear_lut = None
    if bits is not None:
        colour_lut, linear_lut = _lut(bits, srgb), _lut(bits, False)
    kind = spec.format if bits is not None else oiio.FLOAT
    out = np.empty((h, w, 4), dtype=np.float32)
    for y0, y1 in _slabs(h, w):
        raw = inp.read_scanlines(y0, y1, 0, 0, c, kind)
        if raw is None:
            raise _oiio_error("reading", source, inp)
        raw = np.asarray(raw).reshape(y1 - y0, w, c)
        rows = out[y0:y1]
        grey = c in (1, 2)
        colours = 1 if grey else 3
        if bits is not None:
            rows[..., :3] = colour_lut[raw[..., :colours]]
        else:
            rows[..., :3] = raw[..., :colours]
        if c in (2, 4):
            a = raw[..., c - 1]
            rows[..., 3] = linear_lut[a] if bits is not None else a
        else:
            rows[..., 3] = 1.0
    return out
