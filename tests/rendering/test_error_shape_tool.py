"""The error-shape diagnostics of the reference views (``tests/references/error_shape.py``):
the silhouette depth, the bands' ratios, the band-normalised median and the same-medium view."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "references"))
import error_shape as es  # noqa: E402
import mitsuba_views as mv  # noqa: E402

import cumuli as cu  # noqa: E402


def test_silhouette_depth_counts_rings_from_the_outline() -> None:
    mask = np.zeros((9, 9), bool)
    mask[1:8, 1:8] = True  # a 7×7 square: rings 1, 2, 3 and its centre at 4
    d = es.silhouette_depth(mask)
    assert d[0, 0] == 0 and d[1, 1] == 1 and d[1, 4] == 1
    assert d[2, 2] == 2 and d[3, 4] == 3 and d[4, 4] == 4
    assert d.max() == 4 and (d[~mask] == 0).all()
    # The image's border counts as outside.
    assert es.silhouette_depth(np.ones((3, 3), bool))[1, 1] == 2
    with pytest.raises(TypeError, match="2-D bool"):
        es.silhouette_depth(np.ones((3, 3)))


def test_bands_and_their_normalised_median() -> None:
    # A rim 10 % dark and a core 10 % bright, each with ±2 % of its own: the bands show the
    # trend, and dividing each depth by its median leaves only the ±2 %.
    depth = np.array([1, 1, 1, 1, 6, 6, 6, 6])
    ratio = np.array([0.88, 0.92, 0.88, 0.92, 1.08, 1.12, 1.08, 1.12])
    bands = es.band_ratios(ratio, depth)
    assert bands[0]["blocks"] == 4 and bands[0]["ratio"] == pytest.approx(0.90)
    assert bands[1]["blocks"] == 0 and np.isnan(bands[1]["ratio"])
    assert bands[-1]["ratio"] == pytest.approx(1.10)
    assert np.median(np.abs(ratio - 1)) == pytest.approx(0.10)
    # |0.88/0.90 − 1| = 0.0222 on the rim, |1.08/1.10 − 1| = 0.0182 in the core: median 0.0202.
    assert es.band_normalised_median(ratio, depth) == pytest.approx(0.0202, abs=1e-4)


def test_block_ratios_need_a_covered_block() -> None:
    ref = np.zeros((mv.HEIGHT, mv.WIDTH, 4), np.float32)
    with pytest.raises(ValueError, match="covers no block"):
        es.block_ratios(ref, ref)
    ref[40:80, 40:120] = (2.0, 2.0, 2.0, 1.0)
    img = ref.copy()
    img[..., :3] *= 1.5
    ratio, depth = es.block_ratios(img, ref)
    assert ratio.size == 10 * 20 and np.allclose(ratio, 1.5)
    assert depth.min() == 1 and depth.max() == 5


def test_the_same_medium_is_the_references_lattice() -> None:
    scene, camera = es.same_medium("lsystem")
    (volume,) = scene.clouds
    assert isinstance(volume, cu.VolumeCloud)
    assert volume.detail == 0.0 and volume.reconstruction == "linear"
    lo, hi = (np.asarray(b) for b in volume.box)
    edge = (hi - lo) / np.asarray(volume.density.shape[::-1])
    assert np.allclose(edge, mv.voxel("lsystem"), rtol=0.2)
    assert camera == mv.VIEWS["lsystem"]()[1]
