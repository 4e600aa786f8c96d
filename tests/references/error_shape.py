"""Where the physical mode's error against Mitsuba 3 comes from: the medium, or the light's shape.

Two measurements on every reference view (``mitsuba_views.VIEWS``), each against its committed
Mitsuba image with the comparison's 4×4 block metric:

- **The same medium.** Mitsuba renders the view's extinction voxelised on a lattice of
  ``mitsuba_views.voxel`` units; cumuli draws the cloud itself (its primitives and fBm, sampled
  wherever its rays step). ``same_medium`` draws that very lattice instead, as a trilinear
  `VolumeCloud` without detail, lit and drawn by the same physical mode. If the errors barely
  move, the voxelisation is not what cumuli misses.
- **The error by depth inside the silhouette.** Each covered block's distance from the nearest
  uncovered block (1: on the outline; :func:`silhouette_depth`) groups the blocks in bands; a
  band's median cumuli/Mitsuba ratio shows a trend from rim to core, and
  :func:`band_normalised_median` is the block median left once each band is divided by its own
  median: the most that any correction by depth alone could take away.

Run::

    python tests/references/error_shape.py [--views backlit,sunset] [--threads 2]

It prints, per view, the errors of the cloud and of its lattice, their draw times, each band's
ratio and the band-normalised median.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import cumuli as cu

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import mitsuba_views as mv  # noqa: E402

#: The depth bands reported (block distances from the outline, lower bound inclusive).
BANDS = ((1, 2), (2, 3), (3, 5), (5, 10_000))


def silhouette_depth(mask: np.ndarray) -> np.ndarray:
    """Each True cell's distance from the nearest False cell or the border, in 4-neighbour steps
    (1: a cell with an uncovered neighbour), 0 where ``mask`` is False."""
    if mask.ndim != 2 or mask.dtype != bool:
        raise TypeError(f"mask must be a 2-D bool array, got {mask.dtype} {mask.shape}")
    depth = np.zeros(mask.shape, np.int32)
    inside = mask.copy()
    k = 0
    while inside.any():
        k += 1
        depth[inside] = k
        # A cell stays inside the next ring when its four neighbours are inside this one.
        eroded = np.zeros_like(inside)
        eroded[1:-1, 1:-1] = (
            inside[1:-1, 1:-1]
            & inside[:-2, 1:-1]
            & inside[2:, 1:-1]
            & inside[1:-1, :-2]
            & inside[1:-1, 2:]
        )
        inside = eroded
    return depth


def block_ratios(img: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(ratio, depth)`` of the covered blocks: cumuli's block mean luminance over Mitsuba's,
    and the block's :func:`silhouette_depth` on the reference's coverage."""
    mask = mv.blocks(ref[..., 3]) >= mv.COVERED
    if not mask.any():
        raise ValueError("the reference covers no block")
    a, b = mv.blocks(img[..., :3].mean(-1)), mv.blocks(ref[..., :3].mean(-1))
    ratio = a / np.maximum(b, 1e-12)
    depth = silhouette_depth(mask)
    return ratio[mask], depth[mask]


def band_ratios(
    ratio: np.ndarray, depth: np.ndarray, bands: Sequence[tuple[int, int]] = BANDS
) -> list[dict[str, float]]:
    """Per band ``[lo, hi)`` of depth: its blocks and their median ratio (NaN when empty)."""
    out = []
    for lo, hi in bands:
        inside = (depth >= lo) & (depth < hi)
        median = float(np.median(ratio[inside])) if inside.any() else math.nan
        out.append({"lo": lo, "hi": hi, "blocks": int(inside.sum()), "ratio": median})
    return out


def band_normalised_median(ratio: np.ndarray, depth: np.ndarray) -> float:
    """The block median |ratio − 1| once the blocks of each depth are divided by their own
    median ratio: what is left after the best correction by silhouette depth alone."""
    scaled = ratio.astype(np.float64)
    for d in np.unique(depth):
        same = depth == d
        scaled[same] = ratio[same] / np.median(ratio[same])
    return float(np.median(np.abs(scaled - 1.0)))


def same_medium(name: str) -> tuple[cu.Scene, cu.Camera]:
    """View ``name`` with its cloud replaced by the lattice Mitsuba renders: the extinction on
    the view's voxels (``mitsuba_views.reference_field``), drawn trilinear, no detail."""
    scene, camera = mv.VIEWS[name]()
    field = mv.reference_field(name, scene)
    volume = cu.VolumeCloud(
        density=np.ascontiguousarray(field.values, np.float32),
        box=field.box,
        sigma_t=1.0,  # the field holds σt itself
        detail=0.0,
        reconstruction="linear",
    )
    return scene.replace(clouds=[volume]), camera


def _band_label(lo: int, hi: int) -> str:
    """``3-4`` for [3, 5), ``1`` for [1, 2), ``5+`` for the open last band."""
    if hi >= BANDS[-1][1]:
        return f"{lo}+"
    return str(lo) if hi == lo + 1 else f"{lo}-{hi - 1}"


def _draw_ms(scene: cu.Scene, camera: cu.Camera, threads: int, repeats: int = 5) -> float:
    lit = cu.prepare_light(scene, threads=threads, progress=False)
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        cu.render_cpu(lit, camera, mv.WIDTH, mv.HEIGHT, threads=threads)
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--views", default=",".join(mv.VIEWS), help="comma-separated view names")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    names = [v for v in args.views.split(",") if v]
    unknown = sorted(set(names) - set(mv.VIEWS))
    if unknown:
        raise SystemExit(f"unknown views {unknown}; known: {sorted(mv.VIEWS)}")
    for name in names:
        ref = cu.read_image(mv.view_file(name))
        for label, (scene, camera) in (("cloud", mv.VIEWS[name]()), ("lattice", same_medium(name))):
            img = cu.render_cpu(scene, camera, mv.WIDTH, mv.HEIGHT, threads=args.threads)
            e = mv.block_errors(img, ref)
            ms = _draw_ms(scene, camera, args.threads)
            errors = f"p90 {e['block_p90']:.4f} |dT| {e['transmittance']:.4f}"
            print(f"{name:9s} {label:7s} block median {e['block_median']:.4f} {errors} "
                  f"draw {ms:.1f} ms")  # fmt: skip
            if label == "cloud":
                ratio, depth = block_ratios(img, ref)
                bands = "  ".join(
                    f"d{_band_label(b['lo'], b['hi'])}: {b['ratio']:.3f} ({b['blocks']})"
                    for b in band_ratios(ratio, depth)
                )
                left = band_normalised_median(ratio, depth)
                print(f"{'':9s} by depth {bands}; band-normalised median {left:.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
