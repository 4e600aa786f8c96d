"""Sharp volumes: how the physical mode reads a `VolumeCloud`'s density between its voxels.

A low-resolution volume (an endless animation's 16³–64³ database frame) drawn trilinearly shows
its cells: the density has kinks on every cell face and its outline is made of voxel-sized
facets. In the physical mode the volume marcher (GLSL and its C++ twin) instead reads

- the **tricubic B-spline** of the voxels (``reconstruction="cubic"``, C² across cell faces), and
- **erodes** it with the scene's fBm (Jiménez de Parga & Gómez Palomo 2018, eq. 1) the way
  Schneider's Nubis clouds erode a low-resolution shape with high-frequency noise (SIGGRAPH 2015
  and 2017): with ``ρn = min(ρ/ρ_max, 1)`` and ``e = detail · n(x)`` (``n`` the fBm over its
  largest value), ``ρ' = ρ_max · max(ρn − e, 0)/(1 − e)`` — a remap that only removes density
  and removes the most where it is low, so edges are carved into sub-voxel detail while the core
  keeps its density. ``ρ_max`` is the core density (:func:`core_density`): the volume's largest,
  or less where a voxel is optically thick already.

The detail noise runs at ``detail_frequency`` lattice texels per world unit (default
:data:`DETAIL_TEXELS_PER_VOXEL` per voxel of the volume, so its first octave is about one feature
per voxel and the others finer), with the render settings' octaves, gain and lacunarity.
The paper mode reads neither (its images do not change).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from cumuli.noise import Noise

#: The detail noise's default frequency: lattice texels per voxel of the volume (the fBm's first
#: octave, at ``lacunarity`` × that, then has about one texel per voxel).
DETAIL_TEXELS_PER_VOXEL = 0.5
#: The optical depth across one voxel from which its density counts as core (not eroded).
CORE_VOXEL_DEPTH = 8.0


@dataclass(frozen=True)
class VolumeDetail:
    """What the volume marcher needs for a sharp volume: the reconstruction (``cubic``), the
    erosion ``strength`` (0: none), ``1/ρ_max`` and the fBm ``(octaves, gain, lacunarity,
    frequency)`` of the ``noise``."""

    cubic: bool
    strength: float
    inv_max: float
    fbm: tuple[int, float, float, float]
    noise: Noise


def detail_frequency(volume: Any) -> float:
    """The detail noise's frequency of ``volume``: its own ``detail_frequency`` or
    :data:`DETAIL_TEXELS_PER_VOXEL` over its smallest voxel edge."""
    if volume.detail_frequency is not None:
        return float(volume.detail_frequency)
    lo, hi = volume.box
    d, h, w = volume.shape
    edge = min((hi[0] - lo[0]) / w, (hi[1] - lo[1]) / h, (hi[2] - lo[2]) / d)
    return DETAIL_TEXELS_PER_VOXEL / edge


def core_density(volume: Any, settings: Any) -> float:
    """``ρ_core``, the density from which a voxel counts as core: the volume's largest, or less
    where a voxel of it is optically thick already — the density whose optical depth across the
    smallest voxel edge is :data:`CORE_VOXEL_DEPTH` (at σt from the settings' mode)."""
    biggest = float(volume.density.max())
    lo, hi = volume.box
    d, h, w = volume.shape
    edge = min((hi[0] - lo[0]) / w, (hi[1] - lo[1]) / h, (hi[2] - lo[2]) / d)
    sigma_t = volume.extinction_per_density(settings)
    thick = CORE_VOXEL_DEPTH / (sigma_t * edge) if sigma_t > 0.0 else math.inf
    core = min(biggest, thick)
    return core if core > 0.0 else 1.0


def volume_detail(volume: Any, scene: Any) -> VolumeDetail | None:
    """The :class:`VolumeDetail` of a `VolumeCloud` in ``scene`` (None in the paper mode, where
    the volume is read trilinearly and not eroded)."""
    settings = scene.settings
    if not settings.physical:
        return None
    inv_max = 1.0 / core_density(volume, settings)
    fbm = (
        int(settings.octaves), float(settings.gain), float(settings.lacunarity),
        detail_frequency(volume),
    )  # fmt: skip
    return VolumeDetail(
        volume.reconstruction == "cubic", float(volume.detail), inv_max, fbm, scene.noise
    )


__all__ = [
    "CORE_VOXEL_DEPTH",
    "DETAIL_TEXELS_PER_VOXEL",
    "VolumeDetail",
    "core_density",
    "detail_frequency",
    "volume_detail",
]
