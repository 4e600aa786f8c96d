"""The physical mode's edge pass (RENDER_CONTRACT "Physical lighting", "Edges"): 2×2 rays in
each pixel of a cloud's outline, before the resolve pass.

One ray through a pixel's centre sees a thin strand or a cloud's limb as covering the whole pixel
or none of it; the resolve pass's tent then spreads that coverage over the neighbours. Against a
reference that integrates each pixel (Mitsuba's box filter), the L-system's thin strands were off
by 0.017 in block coverage. The edge pass finds the outline after the first march, as the pixels
whose 3×3 neighbourhood's coverage spans more than :data:`EDGE_RANGE`, marches those pixels again
with the 2×2 rays of an image twice the size (their jitter is that image's, so the four rays'
samples interleave), takes the mean of the four, and keeps the result out of the tent
(``unfiltered`` of ``_core.finish_physical``): the box of four rays is the pixel's own
antialiasing. Elsewhere the image and its tent are unchanged.

It costs four rays on the outline's pixels: 3–12 % of the pixels of the 160×120 reference views,
fewer at larger sizes (an outline grows with the image's edge, the image with its square).
It runs for the 2018 marcher's single pass (a scene of 2018 clouds and no solids); layered
scenes keep the tent alone.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: A pixel is on an edge when the coverage ``1 − T`` in its 3×3 neighbourhood spans more than
#: this.
EDGE_RANGE = 0.1
#: Rays per pixel edge in the edge pass (SUB × SUB rays per edge pixel).
SUB = 2
#: Largest image the edge pass runs on, in pixels of the image twice the size (its (2H, 2W, 4)
#: float32 buffer is then 512 MiB at most); larger images keep the tent alone.
MAX_SUB_PIXELS = 1 << 25
#: Longest edge of the image twice the size (the CPU marcher's and llvmpipe's texture limit).
MAX_SUB_EDGE = 1 << 14


def edge_mask(alpha: np.ndarray) -> np.ndarray:
    """``(H, W)`` coverage → ``(H, W)`` bool: the pixels whose 3×3 neighbourhood (edges clamped)
    spans more than :data:`EDGE_RANGE`."""
    a = np.asarray(alpha, np.float32)
    p = np.pad(a, 1, mode="edge")
    h, w = a.shape
    hi = np.full_like(a, -np.inf)
    lo = np.full_like(a, np.inf)
    for dy in range(3):
        for dx in range(3):
            window = p[dy : dy + h, dx : dx + w]
            np.maximum(hi, window, out=hi)
            np.minimum(lo, window, out=lo)
    return (hi - lo) > EDGE_RANGE


def supersample_edges(
    image: np.ndarray, march: Callable[[np.ndarray], np.ndarray]
) -> tuple[np.ndarray, np.ndarray | None]:
    """``image`` (``(H, W, 4)``) with its edge pixels replaced by the mean of their 2×2 rays, and
    the mask of those pixels (None when there are none, or the image is too large).

    ``march(mask)`` draws the same scene at ``(SUB·H, SUB·W)`` marching only the pixels where
    ``mask`` (that size) is true, the others 0."""
    h, w = image.shape[:2]
    if SUB * SUB * h * w > MAX_SUB_PIXELS or SUB * max(h, w) > MAX_SUB_EDGE:
        return image, None
    edges = edge_mask(image[..., 3])
    if not edges.any():
        return image, None
    fine = np.repeat(np.repeat(edges, SUB, axis=0), SUB, axis=1)
    sub = march(fine)
    # Only the edge pixels' rays are read: the outline is ~1 % of a large image's pixels, and a
    # mean over the whole image twice the size would cost more than marching them.
    ys, xs = np.nonzero(edges)
    total = np.zeros((len(ys), 4), np.float64)
    for dy in range(SUB):
        for dx in range(SUB):
            total += sub[SUB * ys + dy, SUB * xs + dx]
    out = np.array(image, np.float32, copy=True)
    out[ys, xs] = (total / (SUB * SUB)).astype(np.float32)
    return out, edges
