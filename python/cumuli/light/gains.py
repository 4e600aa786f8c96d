"""The gains on the physical light's diffuse lattice light (``cumuli.light.physical``).

The camera sees the first mean free path of a lattice cell that spans several, where the
diffuse light is larger than the cell's mean fluence that the diffusion solves for, and the
whole of a cell thinner than one: the fluence is read with a gain that rises with the cell's
optical thickness ``τc = σt·h`` from 1 to ``G∞``, ``G(τc) = 1 + (G∞ − 1)(1 − e^{−τc/τg})``.

The cell edge ``h`` is the one the drawable's lattice has at ``physical_resolution`` 48
(:data:`GAIN_RESOLUTION`, the default when the gains were first fitted against Mitsuba 3),
whatever resolution the scene asks for, today's default 40 included (:func:`gain_cell`): with the
actual cell they fell as the lattice was refined (``τc`` halves with the cell), so that a finer
light darkened the picture — the top-lit reference view's cloud mean went from −8 % at 48 to
−15 % at 64 and −25 % at 96. With the gains' cell held, one extinction gets one gain at any
resolution and the picture moves by a few per cent (docs/fidelity.md).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cumuli.light.medium import lattice_shape

#: The ``physical_resolution`` whose lattice sets the gains' cell (:func:`gain_cell`): 48, the
#: default at which the gains were first fitted. It is kept when the default resolution moves
#: (40 since then), so that a gain is a property of the medium's cell, not of the light's grid.
GAIN_RESOLUTION = 48


def cell_size(lo: Any, hi: Any, shape: tuple[int, ...]) -> float:
    """The geometric mean of the edges of a ``(D, H, W)`` lattice's cells over the box."""
    d, h, w = shape[:3]
    edges = (np.asarray(hi, np.float64) - np.asarray(lo, np.float64)) / (w, h, d)
    return float(np.prod(np.abs(edges)) ** (1.0 / 3.0))


def gain_cell(lo: Any, hi: Any, own: tuple[int, int, int] | None = None) -> float:
    """The cell edge ``h`` of the gains of a drawable whose light lattice spans the box
    ``lo``–``hi``: that of the lattice its light has at :data:`GAIN_RESOLUTION` — its own
    lattice ``own`` (``(x, y, z)`` voxels, a trilinear volume's) where it is no finer, else
    :data:`GAIN_RESOLUTION` cells on the box's longest edge and the others in proportion —
    whatever the scene's ``physical_resolution``."""
    if own is not None and max(own) <= GAIN_RESOLUTION:
        x, y, z = own
    else:
        x, y, z = lattice_shape((lo, hi), GAIN_RESOLUTION)
    return cell_size(lo, hi, (z, y, x))


def lattice_gains(
    extinction: Any,
    lo: Any,
    hi: Any,
    gain: float,
    depth: float,
    cell: float | None = None,
) -> np.ndarray:
    """The gain ``G(τc) = 1 + (G∞ − 1)(1 − e^{−τc/τg})`` of every cell of an extinction lattice
    ``(D, H, W)`` over the box ``lo``–``hi``: ``τc = σt·h``, ``G∞ = gain``, ``τg = depth``
    (``cumuli.light.physical.GAIN_DEPTH`` in the light step; 0: ``gain`` everywhere),
    ``h`` = ``cell`` (None: the geometric mean of the lattice's own cell edges; the light step
    passes :func:`gain_cell`'s).

    The light step takes these gains in ``_core.physical_grid``; this is their numpy reference
    (the same values)."""
    ext = np.asarray(extinction, np.float64)
    if ext.ndim != 3:
        raise ValueError(f"extinction must be a (D, H, W) lattice, got shape {ext.shape}")
    if not (math.isfinite(gain) and gain > 0.0):
        raise ValueError(f"gain must be finite and > 0, got {gain}")
    if not (math.isfinite(depth) and depth >= 0.0):
        raise ValueError(f"gain_depth must be finite and >= 0, got {depth}")
    h = cell_size(lo, hi, ext.shape) if cell is None else float(cell)
    if not (math.isfinite(h) and h > 0.0):
        raise ValueError(f"cell must be finite and > 0, got {cell}")
    if depth == 0.0:
        return np.full(ext.shape, gain, np.float32)
    rise = -np.expm1(-np.maximum(ext, 0.0) * h / depth)
    return (1.0 + (gain - 1.0) * rise).astype(np.float32)
