"""The physical mode's sky visibility along the lattice's own directions.

``_core.sky_irradiance(..., method="lattice")`` (``cumuli.light.physical.SKY_RAYS``) takes the
26 steps to a voxel's neighbours as its rays: on cubic voxels they are the nodes of Lebedev's
26-point rule, and the optical depth along each is exact for the trilinear field (Simpson's
rule on a polynomial of degree ≤ 3, chained from voxel to voxel). These tests check it against
a numpy twin that integrates the same rays finely, against the per-voxel march (the default),
and its contract: thread-count independence, the fallback on stretched voxels, bad input.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.sky import sky_args

F = np.float32
COEFFS = _core.sky_sh(sky_args(cu.Sky()), 3, 3)
#: Lebedev's 26-point weights (× 4π) by the number of axes a step moves along.
LEBEDEV = {1: 1 / 21, 2: 4 / 105, 3: 9 / 280}


def _trilinear_clamped(ext: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``ext`` ([z][y][x]) at voxel coordinates ``u`` (N, 3) as (x, y, z), centres at i + ½,
    clamped to the edges."""
    d, h, w = ext.shape
    s = u - 0.5
    i0 = np.floor(s).astype(int)
    f = s - i0
    out = np.zeros(len(u))
    for corner in itertools.product((0, 1), repeat=3):
        idx = [np.clip(i0[:, a] + corner[a], 0, (w, h, d)[a] - 1) for a in range(3)]
        wgt = np.prod([f[:, a] if corner[a] else 1 - f[:, a] for a in range(3)], axis=0)
        out += wgt * ext[idx[2], idx[1], idx[0]]
    return out


def _lattice_twin(ext: np.ndarray, lo, hi, samples: int = 4000) -> np.ndarray:
    """E_sky at every voxel from the 26 lattice rays, τ by a fine midpoint rule to the box."""
    d, h, w = ext.shape
    vs = (np.asarray(hi, float) - np.asarray(lo, float)) / (w, h, d)
    steps = [s for s in itertools.product((-1, 0, 1), repeat=3) if any(s)]
    zz, yy, xx = np.meshgrid(range(d), range(h), range(w), indexing="ij")
    centres = np.stack([xx, yy, zz], -1).reshape(-1, 3) + 0.5
    dirs = np.array([np.asarray(s, float) * vs for s in steps])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    basis = _core.sh_eval(3, dirs.astype(F)).astype(float)
    vis = np.zeros((len(centres), 9))
    for k, s in enumerate(steps):
        step = np.asarray(s, float)
        moved = step != 0
        # Steps to the box face: the first moving axis to reach 0 or its size.
        size = np.array((w, h, d))[moved]
        far = np.where(step[moved] > 0, size - centres[:, moved], centres[:, moved])
        t_exit = far.min(axis=1)
        t = (np.arange(samples) + 0.5) / samples
        length = np.linalg.norm(step * vs)
        tau = np.zeros(len(centres))
        for chunk in np.array_split(t, 20):
            pts = centres[:, None, :] + (chunk[None, :, None] * t_exit[:, None, None]) * step
            vals = _trilinear_clamped(ext, pts.reshape(-1, 3)).reshape(len(centres), -1)
            tau += vals.sum(axis=1) * (t_exit / samples) * length
        weight = 4 * math.pi * LEBEDEV[int(moved.sum())]
        vis += (np.exp(-tau) * weight)[:, None] * basis[k]
    e = vis @ COEFFS.astype(float).T
    return np.maximum(e, 0.0).reshape(d, h, w, 3)


def test_lattice_rays_integrate_the_trilinear_field_exactly() -> None:
    """On a random medium with voxels near cubes (every voxel holds some), the lattice rays'
    irradiance is the numpy twin's: the optical depth of each ray is exact, not marched."""
    rng = np.random.default_rng(3)
    ext = rng.uniform(0.05, 2.0, (6, 7, 8)).astype(F)
    lo, hi = (-1.0, 0.0, 2.0), (1.0 + 0.1, 1.75, 3.5)  # voxels 0.2625 × 0.25 × 0.25
    got = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 3, 1.0, 1, method="lattice")
    np.testing.assert_allclose(got, _lattice_twin(ext, lo, hi), rtol=2e-4, atol=1e-6)


def test_lattice_rays_are_as_accurate_as_the_march_they_replace() -> None:
    """Against a march of 512 directions at ⅛-voxel steps, on a smooth cloud of 3 optical
    depths per unit at its centre: the lattice's 26 rays err by less than the 18-direction march
    of one-voxel steps, and by under 0.5 % on average."""
    n = 24
    g = (np.arange(n) + 0.5) / n * 4 - 2
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    ext = (3.0 * np.exp(-(x**2 + y**2 + z**2) / 0.5)).astype(F)
    lo, hi = (-2.0,) * 3, (2.0,) * 3
    ref = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 16, 0.125, 2, method="march")
    march = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 3, 1.0, 2, method="march")
    lattice = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 3, 1.0, 2, method="lattice")
    inside = ext > 0.05

    def err(e: np.ndarray) -> float:
        return float(np.abs(e - ref)[inside].mean() / ref[inside].mean())

    assert err(lattice) < err(march)
    assert err(lattice) < 0.005


@pytest.mark.parametrize("threads", [2, 3, 5])
def test_lattice_rays_do_not_depend_on_the_thread_count(threads: int) -> None:
    rng = np.random.default_rng(8)
    ext = (rng.random((20, 24, 22)) > 0.6).astype(F) * 4.0
    lo, hi = (0.0, 0.0, 0.0), (2.2, 2.4, 2.0)
    one = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 3, 1.0, 1, method="lattice")
    many = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 3, 1.0, threads, method="lattice")
    assert np.array_equal(one, many)


def test_stretched_voxels_fall_back_to_the_march() -> None:
    """Lattice steps stand for Lebedev's directions only on voxels near cubes: with sides more
    than 10 % apart the march is taken, within 10 % the lattice."""
    rng = np.random.default_rng(5)
    ext = rng.uniform(0.0, 3.0, (8, 8, 8)).astype(F)
    for hi_x, lattice in ((1.2, False), (1.08, True)):
        lo, hi = (0.0, 0.0, 0.0), (hi_x, 1.0, 1.0)
        rays = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 3, 1.0, 1, method="lattice")
        march = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 3, 1.0, 1, method="march")
        assert np.array_equal(rays, march) is not lattice


def test_lattice_rays_see_through_a_dense_cube_only_what_is_left() -> None:
    """No cut-off: at the centre of a cube of 4 optical depths per voxel, five voxels from its
    faces, every lattice ray crosses at least 18 optical depths; open lattices are the open sky."""
    lo, hi = (-2.0, -2.0, -2.0), (2.0, 2.0, 2.0)
    ext = np.zeros((16, 16, 16), F)
    open_sky = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 3, 1.0, method="lattice")
    np.testing.assert_allclose(open_sky, np.broadcast_to(open_sky[0, 0, 0], open_sky.shape))
    ext[3:13, 3:13, 3:13] = 16.0
    e = _core.sky_irradiance(ext, lo, hi, COEFFS, 3, 3, 1.0, method="lattice")
    for ch in range(3):
        centre, corner, sky = e[8, 8, 8, ch], e[3, 3, 3, ch], open_sky[0, 0, 0, ch]
        assert centre <= math.exp(-18) * sky
        assert centre < corner < sky


def test_the_physical_light_takes_the_sky_along_the_lattice_by_default(monkeypatch) -> None:
    """The lattice's 26 directions are the physical default (refitted, nearer Mitsuba 3 than
    the march: docs/lighting.md), and the setting reaches the light step: the march gives
    another sky light."""
    from cumuli.light import physical
    from cumuli.light.prepare import clear_memo

    assert physical.SKY_RAYS == "lattice"
    scene = cu.Scene(
        clouds=[cu.gaussian_cumulus(seed=3)], settings=cu.RenderSettings(lighting="physical")
    )
    clear_memo()
    lattice = physical.physical_light(scene.clouds[0], scene, 1).grid
    monkeypatch.setattr(physical, "SKY_RAYS", "march")
    clear_memo()
    march = physical.physical_light(scene.clouds[0], scene, 1).grid
    clear_memo()
    assert lattice.shape == march.shape
    sky = (slice(None),) * 3 + (slice(1, 4),)  # the RGB sky channels
    assert not np.allclose(lattice[sky], march[sky], rtol=1e-3)
    assert np.array_equal(lattice[..., 0] > 0, march[..., 0] > 0)


def test_the_core_keeps_the_march_as_its_own_default() -> None:
    """``_core.sky_irradiance`` without ``method`` marches (the physical step names its rays)."""
    rng = np.random.default_rng(2)
    ext = rng.uniform(0.0, 2.0, (6, 6, 6)).astype(F)
    default = _core.sky_irradiance(ext, (0, 0, 0), (1, 1, 1), COEFFS, 3, 3, 1.0, 1)
    march = _core.sky_irradiance(ext, (0, 0, 0), (1, 1, 1), COEFFS, 3, 3, 1.0, 1, method="march")
    lattice = _core.sky_irradiance(
        ext, (0, 0, 0), (1, 1, 1), COEFFS, 3, 3, 1.0, 1, method="lattice"
    )
    assert np.array_equal(default, march)
    assert not np.array_equal(default, lattice)


def test_unknown_ray_method_is_refused() -> None:
    ext = np.ones((4, 4, 4), F)
    with pytest.raises(ValueError, match="'lattice' or 'march'"):
        _core.sky_irradiance(ext, (0, 0, 0), (1, 1, 1), COEFFS, 3, 3, 1.0, 1, method="sweep")
