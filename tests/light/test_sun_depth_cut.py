"""The sun's march through the physical mode's light lattice stops where no light is left.

``_core.light_space_depth(..., depth_cut=c)`` ends each drawable's march along a column after
the segment where its optical depth passes ``c``: every node before keeps the exact depth, bit
for bit, and every node after holds a depth above ``c`` (at most the exact one). The physical
light marches with ``SUN_DEPTH_CUT``, where neither the sun's transmittance nor any octave the
drawers add is worth a sample.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.light import physical as phys


def _default_cloud() -> tuple[cu.Scene, cu.Cloud]:
    cloud = cu.gaussian_cumulus(seed=1)
    return cu.Scene([cloud], sun=cu.Sun(direction=(0.45, 0.75, 0.5), intensity=6)), cloud


def _depth_args(drawable, scene: cu.Scene, n: int = 16) -> tuple[tuple, float]:
    """The arguments of the physical light's sun march for ``drawable`` on an n-node lattice."""
    lo, hi = drawable.layer_box()
    frame = phys.sun_frame(lo, hi, scene.sun.direction, n)
    clouds, volumes = phys.medium_args([drawable], scene.settings)
    step = (frame[4][2] - frame[3][2]) / (phys.ALONG * n)
    args = (clouds, volumes, scene.noise._core, *phys.fbm_args(scene.settings), frame)
    return args, float(step)


def _check_cut(exact: np.ndarray, cut_depth: np.ndarray, cut: float) -> None:
    changed = exact != cut_depth
    assert changed.any(), "the lattice never reaches the cut: the test checks nothing"
    assert np.all(cut_depth[changed] > cut)
    assert np.all(cut_depth[changed] <= exact[changed])
    # Nothing exact at or below the cut is touched.
    assert not np.any(changed & (exact <= cut))


@pytest.mark.parametrize("cut", [3.0, 12.0, 30.0])
def test_a_cut_cloud_march_keeps_every_node_before_it_bit_for_bit(cut: float) -> None:
    scene, cloud = _default_cloud()
    args, step = _depth_args(cloud, scene, 24)
    exact = _core.light_space_depth(*args, step, 2)
    assert np.array_equal(exact, _core.light_space_depth(*args, step, 2, depth_cut=math.inf))
    got = _core.light_space_depth(*args, step, 2, depth_cut=cut)
    _check_cut(exact, got, cut)
    assert np.array_equal(got, _core.light_space_depth(*args, step, 1, depth_cut=cut))


def test_a_cut_volume_march_keeps_every_node_before_it_bit_for_bit() -> None:
    rng = np.random.default_rng(3)
    density = rng.uniform(0.0, 1.0, (9, 11, 13)).astype(np.float32)
    volume = cu.VolumeCloud(density, ((-4.0, -3.0, -5.0), (4.0, 3.0, 5.0)), sigma_t=2.0)
    scene = cu.Scene([volume], sun=cu.Sun(direction=(0.3, 0.8, -0.4), intensity=6))
    args, step = _depth_args(volume, scene, 12)
    exact = _core.light_space_depth(*args, step, 2)
    got = _core.light_space_depth(*args, step, 2, depth_cut=5.0)
    _check_cut(exact, got, 5.0)


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan])
def test_a_depth_cut_must_be_positive(bad: float) -> None:
    scene, cloud = _default_cloud()
    args, step = _depth_args(cloud, scene, 4)
    with pytest.raises(ValueError, match="depth_cut"):
        _core.light_space_depth(*args, step, 1, depth_cut=bad)


def test_the_physical_light_cuts_where_no_octave_is_left() -> None:
    # The drawers' octave term, in the phase's forward peak where it is largest, at the cut
    # against its largest value: a constant refitted so that deep light counts fails here.
    settings = cu.RenderSettings()
    tau = np.linspace(0.0, 10.0, 2001)
    peak = phys.octave_sum(settings, tau, 1.0, phys.OCTAVES).max()
    at_cut = phys.octave_sum(settings, phys.SUN_DEPTH_CUT, 1.0, phys.OCTAVES)
    assert at_cut < 1e-4 * peak
    assert math.exp(-phys.SUN_DEPTH_CUT) < 1e-12


def test_the_physical_lights_sun_depth_is_the_exact_march_up_to_the_cut() -> None:
    scene, cloud = _default_cloud()
    scene = cu.Scene([cloud], sun=scene.sun, settings=cu.RenderSettings(physical_resolution=16))
    light = phys.physical_light(cloud, scene, threads=2)
    frame, own = phys.own_sun_depth(cloud, scene)
    assert light.frame == frame and light.sun_depth is own  # one cloud: its own lattice
    n = scene.settings.physical_resolution
    step = min(phys.march_step(cloud, scene.settings.light_step),
               (frame[4][2] - frame[3][2]) / (phys.ALONG * n))  # fmt: skip
    clouds, volumes = phys.medium_args([cloud], scene.settings)
    args = (clouds, volumes, scene.noise._core, *phys.fbm_args(scene.settings), frame)
    exact = _core.light_space_depth(*args, float(step), 2)
    _check_cut(exact, light.sun_depth, phys.SUN_DEPTH_CUT)
