"""Shadows of particle clouds and billboards on the media (beyond Harris 2002 and Torchelsen &
Musse 2005, whose clouds light only themselves; their shadows on one another are applied in
:func:`cumuli.light.between.through_media`).

The media — 2018 clouds and volumes — are lit through light fields sampled on grids: the paper
mode's NDT light grid of a `Cloud` (:class:`cumuli.LightGrid`), channel 0 (``exp(−σ_t f_sun)``)
of a `VolumeCloud`'s ``(D, H, W, 4)`` light, and the physical mode's :class:`PhysicalLight`
(the sun's optical depth on its sun-aligned lattice, and channel 0 of its diffuse grid, the
sunlight scattered many times). The sun's light reaching a grid point also crosses the scene's
particle clouds and billboards: :func:`shade` multiplies each sun term by that transmittance
``T`` at the term's own points (:func:`cumuli.light.shadow.caster_transmittance`, which the
ground's shadow uses too: Harris's shadow map of a particle cloud, the CAF a billboard cloud's
own billboards would get), and adds ``−ln T`` to an optical depth. Sky light and extra lights
are left as they are. In the physical mode the added depth joins the cloud's own ``τ_sun``, so
the multiple-scattering octaves soften the particles' shadow as they soften the cloud's own
self-shadow (light scattered forward through the particle cloud, roughly).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from cumuli.light.grid import LightGrid
from cumuli.light.physical import PhysicalLight

#: Transmittance below which an optical depth is capped (``−ln`` of it, ≈ 69).
MIN_TRANSMITTANCE = 1e-30


def voxel_centres(box: Any, shape: tuple[int, int, int]) -> np.ndarray:
    """``(D·H·W, 3)`` float32 world centres of the voxels of a ``(D, H, W)`` grid over ``box``
    ``(lo, hi)``, in the grid's ``[z, y, x]`` order (voxel ``(i, j, k)`` at
    ``lo + ((i, j, k) + ½)(hi − lo)/(W, H, D)``)."""
    lo, hi = (np.asarray(v, np.float64) for v in box)
    d, h, w = shape
    axes = [lo[a] + (np.arange(n) + 0.5) * (hi[a] - lo[a]) / n for a, n in enumerate((w, h, d))]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([x, y, z], -1).reshape(-1, 3).astype(np.float32)


def frame_nodes(frame: tuple, shape: tuple[int, int, int]) -> np.ndarray:
    """``(nw·nv·nu, 3)`` float32 world points of the nodes of a physical light's sun lattice
    ``frame`` ``(u, v, w, lo, hi, res)`` (node ``(i, j, k)`` at frame coordinates
    ``lo + ((i, j, k) + ½)(hi − lo)/res``), in its ``sun_depth[k, j, i]`` order."""
    u, v, w, lo, hi, res = frame
    basis = np.array([u, v, w], np.float64)  # rows: orthonormal axes
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    nw, nv, nu = shape
    coords = [
        lo[a] + (np.arange(n) + 0.5) * (hi[a] - lo[a]) / n for a, n in enumerate((nu, nv, nw))
    ]
    cw, cv, cu = np.meshgrid(coords[2], coords[1], coords[0], indexing="ij")
    frame_xyz = np.stack([cu, cv, cw], -1).reshape(-1, 3)
    return (frame_xyz @ basis).astype(np.float32)


Transmittance = Callable[[np.ndarray], np.ndarray | None]


class ShadedVolumeLight(np.ndarray):
    """A `VolumeCloud`'s ``(D, H, W, 4)`` float32 light with the shadows of the scene's particle
    clouds and billboards in its channel 0, holding the volume's own light as ``shaded_from``
    (kept by copies and pickling; parts of it and arithmetic results do not carry it), so that a
    copy given back to the light step is replaced by the own light and not shaded twice."""

    shaded_from: np.ndarray | None

    def __new__(cls, values: np.ndarray, own: np.ndarray) -> ShadedVolumeLight:
        light = np.asarray(values, np.float32).view(cls)
        light.shaded_from = own
        light.setflags(write=False)
        return light

    def __array_finalize__(self, obj: Any) -> None:
        # Whole copies (copy, deepcopy, .copy()) keep the mark; parts of the light do not.
        whole = isinstance(obj, ShadedVolumeLight) and obj.shape == self.shape
        self.shaded_from = obj.shaded_from if whole else None

    def __array_wrap__(self, out: Any, context: Any = None, return_scalar: bool = False) -> Any:
        return np.asarray(out) if not return_scalar else out[()]

    def __reduce__(self) -> Any:
        return (_rebuild_shaded, (np.asarray(self).copy(), self.shaded_from))


def _rebuild_shaded(values: np.ndarray, own: Any) -> Any:
    return values if own is None else ShadedVolumeLight(values, own)


def shade(light: Any, box: Any, transmittance: Transmittance) -> Any:
    """``light`` (a medium's light, see the module docstring) with its sun terms multiplied by
    ``transmittance(points)`` (``(N,)`` in [0, 1] at ``(N, 3)`` world points, or None for all
    ones); ``box``: a volume's box (its light array has none). Returns ``light`` itself when
    nothing is shaded, else a new object of the same kind."""
    if isinstance(light, LightGrid):
        t = transmittance(voxel_centres(light.box, light.shape))
        if t is None or (t == 1.0).all():
            return light
        values = light.values * t.reshape(light.shape)
        record = None if light.record is None else replace(light.record, shaded=True)
        return LightGrid(values, light.box, light.sun, record)
    if isinstance(light, PhysicalLight):
        t_sun = transmittance(frame_nodes(light.frame, light.sun_depth.shape))
        t_grid = transmittance(voxel_centres(light.box, light.grid.shape[:3]))
        unchanged = [t is None or (t == 1.0).all() for t in (t_sun, t_grid)]
        if all(unchanged):
            return light
        depth = light.sun_depth
        if not unchanged[0]:
            extra = -np.log(np.maximum(t_sun, MIN_TRANSMITTANCE)).reshape(depth.shape)
            depth = (depth + extra).astype(np.float32)
        grid = light.grid
        if not unchanged[1]:
            grid = grid.copy()
            grid[..., 0] *= t_grid.reshape(grid.shape[:3])
        return replace(light, sun_depth=depth, grid=grid, shaded_from=light)
    if isinstance(light, np.ndarray) and light.ndim == 4 and light.shape[-1] == 4:
        t = transmittance(voxel_centres(box, light.shape[:3]))
        if t is None or (t == 1.0).all():
            return light
        out = np.array(light, np.float32)
        out[..., 0] *= t.reshape(light.shape[:3])
        return ShadedVolumeLight(out, light)
    raise TypeError(f"no sun term to shade in a {type(light).__name__}")
