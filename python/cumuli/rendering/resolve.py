"""The physical mode's resolve pass (RENDER_CONTRACT "Physical lighting", "Resolve"): a 3×3
tent filter over the finished image, the same pass for both backends (the renderers run it in
the core after the air, :func:`cumuli.rendering.air.finish`; :func:`tent_filter` is its numpy
reference, bit for bit).

The physical marcher jitters each pixel's samples by interleaved gradient noise (Jimenez 2014),
a pattern made to be averaged over a pixel's 3×3 neighbourhood: unfiltered it shows as a
diagonal hatch at 2× zoom, and cloud outlines step from pixel to pixel. The tent
``[1, 2, 1]ᵀ[1, 2, 1]/16`` (edges clamped) averages the hatch out and smooths the outlines, at
the price of softening detail by about a pixel; it is not supersampling.
"""

from __future__ import annotations

import numpy as np

#: The tent's weights along one axis (their outer product, normalised, is the 3×3 kernel).
TENT = (0.25, 0.5, 0.25)


def tent_filter(image: np.ndarray) -> np.ndarray:
    """``(H, W, C)`` float32 → the same filtered by the separable 3×3 tent (edges clamped)."""
    img = np.asarray(image, np.float32)
    a, b, c = (np.float32(w) for w in TENT)
    p = np.pad(img, ((0, 0), (1, 1), (0, 0)), mode="edge")
    rows = a * p[:, :-2] + b * p[:, 1:-1] + c * p[:, 2:]
    q = np.pad(rows, ((1, 1), (0, 0), (0, 0)), mode="edge")
    return (a * q[:-2] + b * q[1:-1] + c * q[2:]).astype(np.float32)


def resolve(image: np.ndarray, scene: object) -> np.ndarray:
    """``image`` resolved when ``scene``'s settings ask for it (the physical mode with
    ``resolve``), else ``image`` itself. A scene with solids is not resolved: a solid is opaque
    (alpha exactly 1 where it is hit) and its outline is exact; the tent would bleed both."""
    s = scene.settings  # type: ignore[attr-defined]
    if not (s.physical and s.resolve) or scene.solids:  # type: ignore[attr-defined]
        return image
    return tent_filter(image)
