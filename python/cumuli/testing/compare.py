"""Image comparison for tests: per-pixel and block metrics of a render against a reference, a
readable verdict, and the images a failure leaves behind (actual, expected, |Δ| and a heat map).

The metrics separate the pixels a reference *covers* (alpha above ``alpha_threshold``: the
clouds) from its background (the sky), because a sky that fills most of a frame dilutes any
whole-image average. Single pixels whose difference exceeds ``outlier_abs`` (a sample that
appears or vanishes where another driver rounds a transcendental function differently) are
counted rather than averaged. Block metrics compare ``block``×``block`` pixel means, the right
measure against a noisy reference such as a Monte Carlo render.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

#: Default tolerances: float renders of the same scene on two GL drivers (or on GL and the C++
#: marcher) pass them; a 2 % change of absorption or a 0.02 change of the phase asymmetry does not.
DEFAULTS: dict[str, float] = {
    "alpha_threshold": 0.05,  # expected alpha above this: a covered pixel
    "covered_mean_abs": 1e-4,  # mean |Δ| over covered pixels that are not outliers
    "background_max_abs": 1e-4,  # largest |Δ| of a background pixel that is not an outlier
    "outlier_abs": 0.05,  # a pixel with a channel beyond this is an outlier
    "outlier_share": 0.01,  # outliers allowed, as a share of the covered pixels (at least 1)
    "max_abs": 0.5,  # largest |Δ| anywhere, outliers included
    "mean_abs": 2e-3,  # mean |Δ| over the whole image
    "channel_mean_abs": float("inf"),  # largest per-channel mean |Δ| (off unless asked for)
}


def only(**limits: float) -> dict[str, Any]:
    """Tolerances with every per-pixel metric off (``inf``) except those given: e.g.
    ``assert_image_close(gl, cpu, **only(channel_mean_abs=1e-3))`` checks the per-channel mean
    alone, the usual check of two implementations of one renderer."""
    unknown = set(limits) - set(DEFAULTS) - {"alpha_threshold", "outlier_share"}
    if unknown:
        raise TypeError(f"unknown tolerance(s): {', '.join(sorted(unknown))}")
    off = {k: float("inf") for k in DEFAULTS if k not in ("alpha_threshold", "outlier_share")}
    return off | limits


@dataclass
class ImageComparison:
    """The metrics of one comparison (``compare_images``), the limits they were held to, and the
    metrics that failed. ``ok`` is true when none did."""

    shape: tuple[int, ...]
    metrics: dict[str, float] = field(default_factory=dict)
    limits: dict[str, float] = field(default_factory=dict)
    failed: list[str] = field(default_factory=list)
    where: dict[str, tuple[int, int]] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.failed

    def __getitem__(self, key: str) -> float:
        return self.metrics[key]

    def report(self) -> str:
        """Several lines: each failed metric with its value, limit and where it is worst."""
        if self.ok:
            return "images agree: " + ", ".join(f"{k}={v:.3g}" for k, v in self.metrics.items())
        lines = [f"images differ ({self.shape[1]}×{self.shape[0]} pixels) by:"]
        for key in self.failed:
            at = self.where.get(key)
            pos = f" — worst at row {at[0]}, column {at[1]}" if at else ""
            lines.append(f"  {key} = {self.metrics[key]:.4g} > limit {self.limits[key]:.4g}{pos}")
        lines.append("  all: " + ", ".join(f"{k}={v:.3g}" for k, v in self.metrics.items()))
        return "\n".join(lines)


def _as_image(a: object, what: str) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 2:
        arr = arr[..., None]
    if arr.ndim != 3 or arr.shape[2] not in (1, 2, 3, 4) or 0 in arr.shape:
        raise ValueError(f"{what} must be an (H, W) or (H, W, C≤4) image, got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{what} has NaN or infinite values")
    return arr


def _blocks(img: np.ndarray, size: int) -> np.ndarray:
    """Means of ``size``×``size`` pixel blocks of an ``(H, W, ...)`` array."""
    h, w = img.shape[0] // size * size, img.shape[1] // size * size
    return img[:h, :w].reshape(h // size, size, w // size, size, *img.shape[2:]).mean(axis=(1, 3))


def _argmax2(values: np.ndarray, mask: np.ndarray) -> tuple[int, int] | None:
    if not mask.any():
        return None
    flat = np.where(mask, values, -np.inf)
    return tuple(int(i) for i in np.unravel_index(int(np.argmax(flat)), flat.shape))  # type: ignore[return-value]


def compare_images(
    actual: object,
    expected: object,
    *,
    alpha_threshold: float = DEFAULTS["alpha_threshold"],
    covered_mean_abs: float = DEFAULTS["covered_mean_abs"],
    background_max_abs: float = DEFAULTS["background_max_abs"],
    outlier_abs: float = DEFAULTS["outlier_abs"],
    outlier_share: float = DEFAULTS["outlier_share"],
    max_abs: float = DEFAULTS["max_abs"],
    mean_abs: float = DEFAULTS["mean_abs"],
    channel_mean_abs: float = DEFAULTS["channel_mean_abs"],
    block: int | None = None,
    block_alpha: float = 0.5,
    block_rel_median: float = 0.15,
    block_rel_p90: float = 0.40,
    block_mean_ratio: float = 0.10,
) -> ImageComparison:
    """Compare two images of the same shape, ``(H, W)`` or ``(H, W, C)`` (C ≤ 4, linear floats).

    Per-pixel metrics (limits in brackets): ``covered_mean`` [covered_mean_abs], the mean |Δ|
    over covered, non-outlier pixels; ``background_max`` [background_max_abs]; ``outliers``
    [``outlier_share`` of the covered pixels, at least 1]; ``max`` [max_abs]; ``mean``
    [mean_abs]; ``channel_mean`` [channel_mean_abs], the largest of the per-channel means of
    |Δ| over the whole image (off by default). Covered pixels are those whose expected alpha
    (channel 4) exceeds ``alpha_threshold``; without an alpha channel every pixel is covered. A
    limit of ``inf`` switches a metric off (:func:`only` switches off all but those given).

    With ``block`` (pixels per block side) the RGB means of blocks are compared too, over the
    blocks whose expected mean alpha reaches ``block_alpha``: the median and 90th percentile of
    their relative error ``|a/b − 1|`` [block_rel_median, block_rel_p90] and the ratio of their
    overall means, ``|Σa/Σb − 1|`` [block_mean_ratio].
    """
    a, b = _as_image(actual, "actual"), _as_image(expected, "expected")
    if a.shape != b.shape:
        raise ValueError(f"actual has shape {a.shape} but expected has shape {b.shape}")
    diff = np.abs(a - b)
    pix = diff.max(axis=-1)
    covered = b[..., 3] > alpha_threshold if b.shape[2] == 4 else np.ones(pix.shape, bool)
    outlier = pix > outlier_abs
    allowed = max(1, int(outlier_share * covered.sum()))
    inner, outer = covered & ~outlier, ~covered & ~outlier
    out = ImageComparison(shape=a.shape)
    m, lim = out.metrics, out.limits
    where: dict[str, tuple[int, int] | None] = {}
    m["covered_pixels"] = int(covered.sum())
    m["covered_mean"] = float(diff[inner].mean()) if inner.any() else 0.0
    lim["covered_mean"] = covered_mean_abs
    where["covered_mean"] = _argmax2(pix, inner)
    m["background_max"] = float(pix[outer].max(initial=0.0))
    lim["background_max"] = background_max_abs
    where["background_max"] = _argmax2(pix, outer)
    m["outliers"] = int(outlier.sum())
    lim["outliers"] = allowed
    where["outliers"] = _argmax2(pix, outlier)
    m["max"] = float(pix.max())
    lim["max"] = max_abs
    where["max"] = _argmax2(pix, np.ones_like(outlier))
    m["mean"] = float(diff.mean())
    lim["mean"] = mean_abs
    if channel_mean_abs != float("inf"):
        m["channel_mean"] = float(diff.mean(axis=(0, 1)).max())
        lim["channel_mean"] = channel_mean_abs
    if block is not None:
        if not (isinstance(block, int) and 1 <= block <= min(a.shape[:2])):
            raise ValueError(f"block must be an int in [1, {min(a.shape[:2])}], got {block!r}")
        rgb = slice(0, min(3, a.shape[2]))
        ba, bb = _blocks(a[..., rgb].mean(-1), block), _blocks(b[..., rgb].mean(-1), block)
        if b.shape[2] == 4:
            mask = _blocks(b[..., 3], block) >= block_alpha
        else:
            mask = np.ones(bb.shape, bool)
        mask &= bb > 0
        if not mask.any():
            raise ValueError("no block of the expected image is covered: nothing to compare")
        rel = np.abs(ba / np.where(mask, bb, 1.0) - 1)
        m["blocks"] = int(mask.sum())
        m["block_rel_median"] = float(np.median(rel[mask]))
        lim["block_rel_median"] = block_rel_median
        m["block_rel_p90"] = float(np.percentile(rel[mask], 90))
        lim["block_rel_p90"] = block_rel_p90
        at = _argmax2(rel, mask)
        if at is not None:
            where["block_rel_p90"] = (at[0] * block, at[1] * block)
        m["block_mean_ratio"] = float(abs(ba[mask].sum() / bb[mask].sum() - 1))
        lim["block_mean_ratio"] = block_mean_ratio
    out.where = {k: v for k, v in where.items() if v is not None}
    out.failed = [k for k, limit in lim.items() if not m[k] <= limit]
    return out


def heat_map(actual: object, expected: object) -> np.ndarray:
    """``(H, W, 4)`` image of the largest channel |Δ| per pixel, scaled to its maximum: black
    (equal) through red and yellow to white (the largest difference)."""
    a, b = _as_image(actual, "actual"), _as_image(expected, "expected")
    t = np.abs(a - b).max(axis=-1)
    t = t / t.max() if t.max() > 0 else t
    img = np.ones((*t.shape, 4), np.float32)
    img[..., 0] = np.clip(3 * t, 0, 1)
    img[..., 1] = np.clip(3 * t - 1, 0, 1)
    img[..., 2] = np.clip(3 * t - 2, 0, 1)
    return img


def safe_name(text: str) -> str:
    """``text`` as a file name: letters, digits, ``-``, ``_`` and ``.`` kept, the rest ``_``."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_")[:120] or "image"


def write_failure_images(
    folder: Path, name: str, actual: np.ndarray, expected: np.ndarray
) -> list[Path]:
    """Write ``<name>_actual.exr``, ``<name>_expected.exr``, ``<name>_diff.exr`` (|Δ|) and
    ``<name>_heat.png`` into ``folder`` (created); return their paths."""
    from cumuli.io.images import write_image

    folder.mkdir(parents=True, exist_ok=True)
    a, e = as_rgba(actual), as_rgba(expected)
    stem = safe_name(name)
    return [
        write_image(folder / f"{stem}_actual.exr", a, "keep"),
        write_image(folder / f"{stem}_expected.exr", e, "keep"),
        write_image(folder / f"{stem}_diff.exr", np.abs(a - e)),
        write_image(folder / f"{stem}_heat.png", heat_map(a, e)),
    ]


def as_rgba(img: object) -> np.ndarray:
    """``img`` (``(H, W)`` or ``(H, W, C≤4)``) as float32 ``(H, W, 3|4)``: one channel repeated
    as grey, two as grey and alpha."""
    arr = _as_image(img, "image").astype(np.float32)
    if arr.shape[2] == 1:
        return np.repeat(arr, 3, axis=2)
    if arr.shape[2] == 2:
        return np.concatenate([np.repeat(arr[..., :1], 3, axis=2), arr[..., 1:]], axis=2)
    return arr


def current_test_name() -> str:
    """The running pytest test's id (``file::test[param]``), or ``image`` outside pytest."""
    return os.environ.get("PYTEST_CURRENT_TEST", "image").rsplit(" ", 1)[0]


def cell_pattern_energy(img: object, period: float) -> float:
    """The share of an image's horizontal luminance-gradient energy at a lattice's period in
    pixels (±12 %) and its second harmonic, over the rows where the cloud covers something
    (alpha > 0.5): near 0 for a smooth cloud, higher where the cells of a voxel lattice show
    (a volume read trilinearly from few voxels). ``period`` > 2 pixels."""
    rgba = as_rgba(img)
    if not period > 2.0:
        raise ValueError(f"period must be more than 2 pixels, got {period}")
    lum = rgba[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])
    alpha = rgba[..., 3] if rgba.shape[2] == 4 else np.ones(rgba.shape[:2], np.float32)
    rows = alpha.max(axis=1) > 0.5
    if rows.sum() == 0 or rgba.shape[1] < 8:
        raise ValueError("the image has no row the cloud covers, or is under 8 pixels wide")
    grad = np.diff(lum[rows], axis=1)
    grad = grad - grad.mean(axis=1, keepdims=True)
    power = (np.abs(np.fft.rfft(grad * np.hanning(grad.shape[1]), axis=1)) ** 2).sum(axis=0)
    f = np.fft.rfftfreq(grad.shape[1])
    band = np.zeros_like(f, dtype=bool)
    for k in (1, 2):
        band |= np.abs(f - k / period) < 0.12 * k / period
    total = power[1:].sum()
    return float(power[band].sum() / total) if total > 0 else 0.0
