"""The physical mode's edge pass (RENDER_CONTRACT "Physical lighting", "Edges"): two more rays
in each pixel of a cloud's outline, before the resolve pass.

One ray through a pixel's centre sees a thin strand or a cloud's limb as covering the whole pixel
or none of it; the resolve pass's tent then spreads that coverage over the neighbours. Against a
reference that integrates each pixel (Mitsuba's box filter), the L-system's thin strands were off
by 0.017 in block coverage. The edge pass finds the outline after the first march, as the pixels
whose 3×3 neighbourhood's coverage spans more than :data:`EDGE_RANGE`, marches those pixels again
with two rays of an image twice the size, the sub-pixels on the pixel's diagonal (:data:`RAYS`:
the pattern of 2× multisampling; their jitter is that image's, so their samples interleave),
takes their mean, and keeps the result out of the tent (``unfiltered`` of
``_core.finish_physical``): the two rays are the pixel's own antialiasing. Elsewhere the image and
its tent are unchanged.

It costs two rays on the outline's pixels: 3–12 % of the pixels of the 160×120 reference views,
fewer at larger sizes (an outline grows with the image's edge, the image with its square), and
the outline's rays are a cloud's longest (a grazing ray through a limb never turns opaque).
It runs for the 2018 marcher's single pass (a scene of 2018 clouds and no solids); layered
scenes keep the tent alone. On GL the list draw binds the scene's buffers and textures again;
measured on llvmpipe that is ~3 ms of the back-lit reference view's edge pass (52 ms at 160×120,
240 ms at 640×480), so the pass keeps no bound state between the two draws.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: A pixel is on an edge when the coverage ``1 − T`` in its 3×3 neighbourhood spans more than
#: this.
EDGE_RANGE = 0.1
#: The edge pass marches an image SUB times the size ...
SUB = 2
#: ... at these of each edge pixel's SUB × SUB sub-pixels (row, column): the two on its diagonal,
#: at (¼, ¼) and (¾, ¾) of the pixel, the standard pattern of 2× multisampling. All four cost
#: twice as much for little gain: on the references' L-system view |ΔT| was 0.0081 with four
#: rays and is 0.0087 with these two (goal 0.01), the other views' errors unchanged to 0.1 %.
RAYS = ((0, 0), (1, 1))
#: Most rays the edge pass marches (their ``(N, 4)`` float32 values are then 256 MiB at most);
#: an image whose outline needs more keeps the tent alone.
MAX_RAYS = 1 << 24
#: Longest edge of the image twice the size (the CPU marcher's and llvmpipe's texture limit).
MAX_SUB_EDGE = 1 << 14


def core_pass() -> tuple[float, int, tuple[tuple[int, int], ...], int, int]:
    """The pass's constants as ``_core.render_cpu_edged(edges=...)`` takes them: the CPU twin
    marches the image and its outline in one call (the occupancy grids and candidate fans built
    once), with the same result as :func:`supersample_edges` over two calls."""
    return EDGE_RANGE, SUB, RAYS, MAX_RAYS, MAX_SUB_EDGE


def edge_mask(alpha: np.ndarray) -> np.ndarray:
    """``(H, W)`` coverage → ``(H, W)`` bool: the pixels whose 3×3 neighbourhood (edges clamped)
    spans more than :data:`EDGE_RANGE`."""
    from cumuli import _core

    a = np.asarray(alpha)
    if a.ndim != 2:
        raise ValueError(f"alpha must be an (H, W) array, got shape {a.shape}")
    return _core.coverage_edges(a, EDGE_RANGE)


def supersample_edges(
    image: np.ndarray, march: Callable[[np.ndarray], np.ndarray], writable: bool = False
) -> tuple[np.ndarray, np.ndarray | None]:
    """``image`` (``(H, W, 4)``) with its edge pixels replaced by the mean of their rays
    (:data:`RAYS`), and the mask of those pixels (None when there are none, or too many:
    :data:`MAX_RAYS`). ``writable``: ``image`` (float32) is the caller's to spend and is
    changed in place, sparing a copy of the frame; otherwise it is left as it is.

    ``march(pixels)`` draws the same scene at ``(SUB·H, SUB·W)`` at the ``(N, 2)`` int32 pixels
    (rows, columns) of that image only, returning their ``(N, 4)`` values in that order."""
    h, w = image.shape[:2]
    if SUB * max(h, w) > MAX_SUB_EDGE:
        return image, None
    edges = edge_mask(image[..., 3])
    count = int(np.count_nonzero(edges))
    if count == 0 or count * len(RAYS) > MAX_RAYS:
        return image, None
    ys, xs = np.nonzero(edges)
    # Each edge pixel's rays side by side: neighbours in the list, in the cache and on a thread.
    offsets = np.array(RAYS, np.int32)  # (rays, 2)
    pixels = SUB * np.stack([ys, xs], axis=1).astype(np.int32)[:, None, :] + offsets[None]
    values = np.asarray(march(pixels.reshape(-1, 2)), np.float32)
    mean = values.reshape(len(ys), len(RAYS), 4).astype(np.float64).mean(axis=1)
    out = image if writable else np.array(image, np.float32, copy=True)
    out[ys, xs] = mean.astype(np.float32)
    return out, edges
