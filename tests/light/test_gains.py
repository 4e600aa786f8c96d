"""The gains on the physical light's diffuse light take the cell of the lattice at
``GAIN_RESOLUTION`` 48 (``cumuli.light.gains``), the resolution they were first fitted at: the
same drawable gets the same gains, and nearly the same picture, at any ``physical_resolution``
(the default, 40, included)."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.light import physical
from cumuli.light.gains import GAIN_RESOLUTION, cell_size, gain_cell, lattice_gains
from cumuli.light.medium import extinction_grid
from cumuli.light.prepare import clear_memo

NOISE = cu.Noise(7, version=1)


def _volume(edge: int) -> cu.VolumeCloud:
    rng = np.random.default_rng(edge)
    density = rng.uniform(0.0, 1.0, (edge, edge, edge)).astype(np.float32)
    return cu.VolumeCloud(density=density, box=((0, 0, 0), (4.0, 3.0, 5.0)), sigma_t=2.0)


def test_the_gains_keep_the_48_lattice_cell_at_the_default_resolution() -> None:
    """The default light lattice (40) is coarser than the gains' (48): they do not follow it."""
    assert GAIN_RESOLUTION == 48
    assert cu.RenderSettings().physical_resolution == 40
    cloud = cu.gaussian_cumulus(seed=1)
    s = cu.RenderSettings()
    field = extinction_grid(cloud, NOISE, s, s.physical_resolution, 1, 1)
    lo, hi = field.box
    own = cell_size(lo, hi, field.values.shape)
    assert gain_cell(lo, hi) == pytest.approx(own * 40 / 48, rel=0.03)


@pytest.mark.parametrize(
    "drawable",
    [
        cu.gaussian_cumulus(seed=1),
        cu.metaball_cumulus(seed=3),
        cu.lsystem_cloud(seed=2),
        _volume(32),
        _volume(64),
    ],  # fmt: skip
    ids=["cumulus", "metaball", "lsystem", "volume 32", "volume 64"],
)
def test_the_gain_cell_is_the_gain_resolution_lattice_cell(drawable) -> None:
    """At ``GAIN_RESOLUTION`` the gains' cell is the light lattice's own cell; at any other
    resolution, it stays that one."""
    s = cu.RenderSettings(physical_resolution=GAIN_RESOLUTION)
    own = cu.registry.of(drawable).medium.own_lattice(drawable)
    n = s.physical_resolution
    resolution = None if own is not None and max(own) <= n else n
    field = extinction_grid(drawable, NOISE, s, resolution, 1, 1)
    lo, hi = field.box
    assert gain_cell(lo, hi, own) == cell_size(lo, hi, field.values.shape)
    finer = extinction_grid(drawable, NOISE, s.replace(physical_resolution=96), 96, 1, 1)
    if own is None or max(own) > n:
        assert cell_size(lo, hi, finer.values.shape) < 0.6 * gain_cell(lo, hi, own)


def test_the_light_grid_takes_the_default_cell_at_a_finer_resolution(monkeypatch) -> None:
    """The light lattice's gains at resolution 64 are those of the 48-lattice's cell, not
    of its own finer cell: the grid's sun channel with a gain of 2 over the same with no gain
    (``SUN_GAIN`` 1: the fluence itself) is ``lattice_gains`` on :func:`gain_cell`."""
    settings = cu.RenderSettings(physical_resolution=64)
    cloud = cu.gaussian_cumulus(seed=1)
    scene = cu.Scene(clouds=[cloud], noise=NOISE, settings=settings)
    clear_memo()
    monkeypatch.setattr(physical, "SUN_GAIN", 1.0)
    phi = np.asarray(physical.physical_light(cloud, scene, threads=2).grid)[..., 0]
    monkeypatch.setattr(physical, "SUN_GAIN", 2.0)
    light = physical.physical_light(cloud, scene, threads=2)
    field = extinction_grid(cloud, NOISE, settings, 64, physical.SUPERSAMPLE, 2)
    lo, hi = field.box
    ext = field.values
    assert phi.shape == ext.shape
    lit = phi > 1e-3 * phi.max()
    got = np.asarray(light.grid)[..., 0][lit] / phi[lit]
    want = lattice_gains(ext, lo, hi, 2.0, physical.GAIN_DEPTH, gain_cell(lo, hi))[lit]
    own = lattice_gains(ext, lo, hi, 2.0, physical.GAIN_DEPTH)[lit]
    np.testing.assert_allclose(got, want, rtol=2e-6)
    assert np.abs(own - want).max() > 0.05  # the finer cell's gains would differ


def _top_lit_mean(resolution: int) -> float:
    e, a = np.radians(80.0), np.radians(20.0)
    sun = cu.Sun(direction=(np.cos(e) * np.cos(a), np.sin(e), np.cos(e) * np.sin(a)))
    scene = cu.Scene(
        clouds=[cu.gaussian_cumulus(seed=1)],
        sun=sun,
        noise=NOISE,
        settings=cu.RenderSettings(physical_resolution=resolution, haze=0.0, air_extinction=0.0),
    )
    camera = cu.Camera(position=(0.0, 2.0, -45.0), target=(0.0, 1.0, 0.0), fov=38.0)
    clear_memo()
    image = cu.render_cpu(scene, camera, 80, 60, threads=2)
    covered = image[..., 3] > 0.5
    return float(image[..., :3].mean(-1)[covered].mean())


def test_a_finer_light_does_not_darken_the_cloud() -> None:
    """A top-lit cumulus's radiance at resolution 40 (the default), 64 and 96 stays within 6 % of
    48's (with the gains on their own cell it fell 6 % at 64 and 15 % at 96; with them +2 % and
    +4 %)."""
    base = _top_lit_mean(48)
    for n in (40, 64, 96):
        assert abs(_top_lit_mean(n) / base - 1.0) < 0.06, n


def test_lattice_gains_rejects_a_bad_cell() -> None:
    ext = np.ones((3, 3, 3), np.float32)
    for cell in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="cell"):
            lattice_gains(ext, (0, 0, 0), (1, 1, 1), 2.0, 1.0, cell=cell)
