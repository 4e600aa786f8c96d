"""The sun's transmittance on a drawable's world lattice (``_core.lattice_transmittance``): e^−τ
of its sun lattice at the world lattice's texel centres, the trilinear read of
``_core.sample_frame`` at those points; and the sky irradiance from the visibility moments on
any number of threads."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.demo import cumulus_scene
from cumuli.light.physical import own_sun_depth

F32 = np.float32


def _centres(lo: tuple, cell: tuple, dims: tuple[int, int, int]) -> np.ndarray:
    """Texel centres ``lo + (index + ½)·cell`` in float32, ``[z][y][x]`` order, (N, 3)."""
    axes = [
        F32(lo[a]) + (np.arange(dims[a], dtype=F32) + F32(0.5)) * F32(cell[a]) for a in range(3)
    ]
    zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([xx, yy, zz], -1).reshape(-1, 3)


def test_transmittance_is_the_frame_read_at_the_lattice_centres() -> None:
    scene = cumulus_scene(settings=cu.RenderSettings(physical_resolution=16))
    frame, depth = own_sun_depth(scene.clouds[0], scene, 2)
    lo, hi = scene.clouds[0].layer_box()
    dims = (13, 7, 11)
    lo32 = tuple(float(F32(v)) for v in lo)
    cell = tuple(float(F32((hi[a] - lo[a]) / dims[a])) for a in range(3))
    got = _core.lattice_transmittance(depth, frame, lo32, cell, dims, 2)
    assert got.shape == (11, 7, 13) and got.dtype == np.float32
    tau = _core.sample_frame(depth, frame, _centres(lo32, cell, dims), 1).reshape(11, 7, 13)
    assert tau.max() > 1.0  # the cloud shades part of the lattice
    np.testing.assert_allclose(got, np.exp(-tau.astype(np.float64)), rtol=3e-7, atol=0)
    for threads in (1, 3):
        assert np.array_equal(
            _core.lattice_transmittance(depth, frame, lo32, cell, dims, threads), got
        )


def test_transmittance_rejects_bad_input() -> None:
    scene = cumulus_scene(settings=cu.RenderSettings(physical_resolution=8))
    frame, depth = own_sun_depth(scene.clouds[0], scene, 1)
    with pytest.raises(ValueError, match="frame's shape"):
        _core.lattice_transmittance(depth[1:], frame, (0, 0, 0), (1, 1, 1), (4, 4, 4))
    with pytest.raises(ValueError, match="cell"):
        _core.lattice_transmittance(depth, frame, (0, 0, 0), (1, -1, 1), (4, 4, 4))
    with pytest.raises(ValueError, match="lo"):
        _core.lattice_transmittance(depth, frame, (0, float("nan"), 0), (1, 1, 1), (4, 4, 4))
    with pytest.raises(ValueError, match="dims"):
        _core.lattice_transmittance(depth, frame, (0, 0, 0), (1, 1, 1), (4, 0, 4))


def test_sky_irradiance_is_the_same_on_any_thread_count() -> None:
    rng = np.random.default_rng(4)
    vis = rng.normal(size=(5, 6, 7, 9))
    coeffs = rng.normal(size=27).astype(F32)
    one = _core.sky_irradiance_from(vis, coeffs, 1)
    want = np.maximum(0.0, np.einsum("dhwc,kc->dhwk", vis, coeffs.reshape(3, 9).astype(np.float64)))
    np.testing.assert_allclose(one, want, rtol=1e-6, atol=1e-6)
    for threads in (2, 3):
        assert np.array_equal(_core.sky_irradiance_from(vis, coeffs, threads), one)
