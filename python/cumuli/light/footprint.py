"""Where a box's shadow can fall: its corners moved along the light onto horizontal planes.

Used for the ground's shadow map (the rectangle the scene's boxes can shade, and which ground
points may see a billboard cloud's boxes towards the sun)."""

from __future__ import annotations

import numpy as np


def box_corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The 8 corners ``(8, 3)`` float64 of the box ``[lo, hi]``."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    return np.array([np.where([k & 1, k & 2, k & 4], hi, lo) for k in range(8)])


def footprint(corners: np.ndarray, sun: np.ndarray, heights: tuple[float, float]) -> np.ndarray:
    """``(x0, x1, z0, z1)``: the rectangle of the corners moved along the light (``sun``, pointing
    towards the sun, ``sun[1] > 0``) down to each of the heights (corners below a height stay
    where they are). It holds every point at a height between the two whose ray towards the sun
    may cross the box the corners bound."""
    sun = np.asarray(sun, np.float64)
    feet = [corners - np.maximum((corners[:, 1] - y) / sun[1], 0.0)[:, None] * sun for y in heights]
    foot = np.concatenate(feet)
    return np.array([foot[:, 0].min(), foot[:, 0].max(), foot[:, 2].min(), foot[:, 2].max()])
