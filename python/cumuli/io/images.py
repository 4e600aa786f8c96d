"""Image files through OpenImageIO: float32 OpenEXR and 8-bit sRGB PNG.

cumuli images are ``(H, W, 4)`` float32 **linear** RGBA with row 0 at the top (DESIGN §3). Alpha
is *unassociated* (straight): colour channels are not multiplied by alpha. That is what PNG stores
too, so :func:`write_image` tells OpenImageIO not to touch alpha (``oiio:UnassociatedAlpha``);
otherwise OIIO would un-premultiply on write and premultiply on read, and a PNG round trip would
darken every translucent pixel.

- ``.exr``: float32 RGBA (not HALF: a write/read round trip returns the same bits), lossless ZIP.
- ``.png``: 8-bit sRGB through :func:`to_srgb8` (the sRGB transfer function on RGB, alpha linear).

Writes are atomic: the file is written to a temporary in the destination folder and moved over the
destination with :func:`os.replace`, so a failed write leaves neither a partial file nor the
temporary behind. Errors: unsupported extension → ``ValueError``; bad array → ``TypeError`` /
``ValueError``; a missing folder or any OpenImageIO failure → ``OSError``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import OpenImageIO as oiio

from cumuli._atomic import atomic_target

#: Extensions write_image and read_image handle, and what they store.
FORMATS = {".exr": "float32 linear RGBA (OpenEXR, ZIP)", ".png": "8-bit sRGB RGBA"}

#: Largest edge accepted (OpenEXR and PNG allow more, but nothing cumuli makes is near it).
MAX_EDGE = 1 << 16
#: Largest image read_image decodes (2²⁸ RGBA float32 pixels = 4 GiB).
MAX_READ_PIXELS = 1 << 28


def _extension(path: str | os.PathLike[str]) -> str:
    ext = Path(path).suffix.lower()
    if ext not in FORMATS:
        raise ValueError(
            f"path has an unsupported image extension {ext!r}; use one of {sorted(FORMATS)}"
        )
    return ext


def _as_rgba(img: Any, name: str = "img") -> np.ndarray:
    """``img`` as a C-contiguous float32 ``(H, W, 4)`` array of finite values (alpha 1 added)."""
    if not isinstance(img, np.ndarray):
        raise TypeError(f"{name} must be a numpy array, got {type(img).__name__}")
    if img.dtype.kind != "f":
        raise TypeError(f"{name} must be a float array (linear RGBA), got dtype {img.dtype}")
    if img.ndim != 3 or img.shape[2] not in (3, 4):
        raise ValueError(f"{name} must have shape (H, W, 3) or (H, W, 4), got {img.shape}")
    h, w = img.shape[:2]
    if not (1 <= h <= MAX_EDGE and 1 <= w <= MAX_EDGE):
        raise ValueError(f"{name} must be 1 to {MAX_EDGE} pixels on each side, got {h}×{w}")
    if not np.isfinite(img).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    if img.shape[2] == 3:
        out = np.empty((h, w, 4), dtype=np.float32)
        out[..., :3] = img
        out[..., 3] = 1.0
        return out
    return np.ascontiguousarray(img, dtype=np.float32)


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


def to_srgb8(img: np.ndarray, exposure: float = 1.0, tonemap: str = "none") -> np.ndarray:
    """Display bytes of a linear image: ``(H, W, 3|4)`` float → ``uint8`` of the same shape.

    RGB is multiplied by ``exposure``, tone mapped (:data:`TONEMAPS`: ``"none"`` clips to
    [0, 1], ``"aces"`` and ``"reinhard"`` roll highlights off instead) and goes through the sRGB
    transfer function; alpha is scaled linearly and stays unassociated (colours are not
    multiplied by it). Values are rounded to nearest.
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


def _write_with_oiio(tmp: Path, ext: str, rgba: np.ndarray) -> None:
    h, w = rgba.shape[:2]
    if ext == ".exr":
        data: np.ndarray = rgba
        spec = oiio.ImageSpec(w, h, 4, oiio.FLOAT)
        spec.attribute("compression", "zip")
    else:
        data = to_srgb8(rgba)
        spec = oiio.ImageSpec(w, h, 4, oiio.UINT8)
        spec.attribute("oiio:ColorSpace", "sRGB")
    spec.channelnames = ("R", "G", "B", "A")
    spec.alpha_channel = 3
    spec.attribute("oiio:UnassociatedAlpha", 1)
    out = oiio.ImageOutput.create(ext.lstrip("."))
    if out is None:
        raise _oiio_error("creating an image writer for", tmp)
    try:
        if not out.open(str(tmp), spec):
            raise _oiio_error("opening", tmp, out)
        if not out.write_image(data):
            raise _oiio_error("writing", tmp, out)
    finally:
        closed = out.close()
    if not closed:
        raise _oiio_error("closing", tmp, out)


def write_image(
    path: str | os.PathLike[str], img: np.ndarray, exposure: float = 1.0, tonemap: str = "none"
) -> Path:
    """Write a linear ``(H, W, 3|4)`` float image to ``.exr`` (float32) or ``.png`` (8-bit sRGB).

    Row 0 is the top of the picture. ``exposure`` and ``tonemap`` are :func:`to_srgb8`'s and
    apply to ``.png`` only (an ``.exr`` keeps the linear radiance). The write is atomic
    (temporary file in the same folder, then :func:`os.replace`); on failure nothing is left
    behind. Returns the path written.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or path-like, got {type(path).__name__}")
    target = Path(path)
    ext = _extension(target)
    rgba = _as_rgba(img)
    to_srgb8(rgba[:1, :1], exposure, tonemap)  # checks both before anything is written
    if ext == ".png" and (exposure != 1.0 or tonemap != "none"):
        # The display values (in [0, 1], float64: to_srgb8 of them gives the same bytes).
        shown = rgba.astype(np.float64)
        shown[..., :3] = tone_map(shown[..., :3] * float(exposure), tonemap)
        rgba = shown
    folder = target.parent
    if not folder.is_dir():
        raise FileNotFoundError(f"path's folder {str(folder)!r} does not exist")
    if target.is_dir():
        raise IsADirectoryError(f"path {str(target)!r} is a directory")
    # The temporary keeps the extension: OpenImageIO picks the format from it.
    with atomic_target(target, suffix=f".tmp{ext}") as tmp:
        _write_with_oiio(tmp, ext, rgba)
    return target


def read_image(path: str | os.PathLike[str]) -> np.ndarray:
    """Read an ``.exr`` or ``.png`` into ``(H, W, 4)`` float32 linear RGBA, row 0 at the top.

    EXR values are returned as stored. 8/16-bit files are decoded from sRGB unless they declare a
    linear colour space. One channel is read as grey, two as grey + alpha, three get alpha 1.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or path-like, got {type(path).__name__}")
    source = Path(path)
    _extension(source)
    if not source.is_file():
        raise FileNotFoundError(f"image {str(source)!r} does not exist or is not a file")
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp = oiio.ImageInput.open(str(source), config)
    if inp is None:
        raise _oiio_error("opening", source)
    try:
        spec = inp.spec()
        # The declared size is checked before the pixels are decoded: a small, highly
        # compressed file can declare gigabytes.
        if not (1 <= spec.width <= MAX_EDGE and 1 <= spec.height <= MAX_EDGE):
            raise ValueError(
                f"image {str(source)!r} is {spec.width}×{spec.height}: each side must be 1 to "
                f"{MAX_EDGE} pixels"
            )
        if spec.width * spec.height > MAX_READ_PIXELS or not 1 <= spec.nchannels <= 4:
            raise ValueError(
                f"image {str(source)!r} ({spec.width}×{spec.height}×{spec.nchannels}) is larger "
                f"than {MAX_READ_PIXELS} pixels or has more than 4 channels"
            )
        integer = spec.format.basetype in (oiio.UINT8, oiio.UINT16)
        pixels = inp.read_image(0, 0, 0, spec.nchannels, "float" if not integer else spec.format)
        if pixels is None:
            raise _oiio_error("reading", source, inp)
        colour_space = spec.get_string_attribute("oiio:ColorSpace").lower()
    finally:
        inp.close()
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    if integer:
        scale = 255.0 if pixels.dtype == np.uint8 else 65535.0
        data = pixels.astype(np.float64) / scale
        colour = slice(0, min(3, data.shape[2])) if data.shape[2] != 2 else slice(0, 1)
        if "lin" not in colour_space:
            data[..., colour] = srgb_to_linear(data[..., colour])
        pixels = data.astype(np.float32)
    pixels = pixels.astype(np.float32, copy=False)
    h, w, c = pixels.shape
    out = np.empty((h, w, 4), dtype=np.float32)
    if c == 1:
        out[..., :3] = pixels
        out[..., 3] = 1.0
    elif c == 2:
        out[..., :3] = pixels[..., :1]
        out[..., 3] = pixels[..., 1]
    elif c == 3:
        out[..., :3] = pixels
        out[..., 3] = 1.0
    else:
        out[...] = pixels[..., :4]
    return out
