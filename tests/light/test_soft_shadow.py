"""Soft ground shadows in the physical mode: the sun disc's penumbra, growing with the caster's
distance, and the sunlight a cloud scatters through onto the ground."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli.ground import sky_irradiance
from cumuli.light.soft_shadow import _box_1d, chord_midpoints, diffuse_transmittance
from cumuli.rendering.air import shadow_lookup

GROUND = cu.Ground(height=0.0, albedo=(0.3, 0.3, 0.3))
EXTENT = ((-20.0, -20.0), (20.0, 20.0))


def caster(height: float, extinction_scale: float = 200.0, **settings) -> cu.Scene:
    """A metaball cloud ``height`` above the ground (dense: a sharp edge), the sun overhead."""
    cloud = cu.metaball_cumulus(centre=(0.0, height, 0.0))
    return cu.Scene(
        [cloud], sun=cu.Sun(direction=(0.0, 1.0, 0.0), intensity=6.0), ground=GROUND,
        noise=cu.Noise(seed=5, size=32),
        settings=cu.RenderSettings(physical_resolution=16, extinction_scale=extinction_scale,
                                   **settings),
    )  # fmt: skip


def edge_width(t: np.ndarray) -> float:
    """Width (texels) of the shadow's edge along the middle row: texels between 10 % and 90 %
    of the way from the darkest to open ground, halved (the row crosses two edges)."""
    row = t[t.shape[0] // 2].astype(np.float64)
    lo = row.min()
    u = (row - lo) / (1.0 - lo)
    return float(((u > 0.1) & (u < 0.9)).sum()) / 2


def test_the_box_filter_keeps_constants_and_ramps_a_step() -> None:
    flat = np.full((3, 9), 0.4)
    np.testing.assert_allclose(_box_1d(flat, np.full(flat.shape, 3.0), 1), flat)
    step = np.repeat(np.r_[np.zeros(10), np.ones(10)][None], 2, 0)
    out = _box_1d(step, np.full(step.shape, 4.0), 1)[0]
    # A box of 4 texels: a linear ramp over 4 texels centred on the step.
    np.testing.assert_allclose(out[7:13], [0, 0.125, 0.375, 0.625, 0.875, 1.0])
    np.testing.assert_array_equal(_box_1d(step, np.zeros(step.shape), 1), step)


def test_the_diffuse_transmission_is_the_two_stream_estimate() -> None:
    tau = np.array([0.0, 0.5, 5.0, 20.0, 80.0])
    t = diffuse_transmittance(tau, 0.88, 1.0)
    assert t[0] == 1.0 and (np.diff(t) < 0).all() and (t >= np.exp(-tau)).all()
    assert t[3] == pytest.approx(1 / (1 + 0.75 * 0.12 * 20.0))
    assert diffuse_transmittance(tau, 0.88, 0.0) == pytest.approx(np.exp(-tau))
    mid = chord_midpoints(
        ((-1, 4, -1), (1, 6, 1)), np.array([[0.0, 0.0, 0.0], [5, 0, 0]]), (0, 1, 0)
    )
    assert mid[0] == pytest.approx(5.0) and np.isnan(mid[1])


def test_the_penumbra_grows_with_the_casters_height() -> None:
    widths = {}
    for angle in (0.0, 2.0):
        for height in (10.0, 80.0):
            s = caster(height, sun_angular_diameter=angle, diffuse_shadows=False)
            widths[angle, height] = edge_width(cu.shadow_map(s, EXTENT, 160))
    # A point sun: the cloud's own edge, whatever its height.
    assert widths[0.0, 80.0] == pytest.approx(widths[0.0, 10.0], abs=1.0)
    # The sun's disc (2°): 80 units up the penumbra is 80·0.035 = 2.8 units = 11 texels wide.
    assert widths[2.0, 10.0] < widths[0.0, 10.0] + 3
    assert widths[2.0, 80.0] > widths[2.0, 10.0] + 5
    texel = 40.0 / 160
    extra = (widths[2.0, 80.0] - widths[0.0, 80.0]) * texel
    assert 0.3 * 80 * math.radians(2.0) < extra < 1.5 * 80 * math.radians(2.0)


def test_the_ground_under_a_thick_cloud_gets_light_through_it() -> None:
    s = caster(40.0, extinction_scale=12.0, air_extinction=0.0, haze=0.0, resolve=False)
    hard_scene = s.replace(
        settings=s.settings.replace(diffuse_shadows=False, sun_angular_diameter=0.0)
    )
    cam = cu.Camera(position=(0.0, 5.0, 0.0), target=(0.0, 0.0, 0.01), fov=20)
    lit, lit_hard = cu.prepare_light(s), cu.prepare_light(hard_scene)
    soft, hard = (
        cu.render_cpu(lit, cam, 8, 6)[3, 4, :3],
        cu.render_cpu(lit_hard, cam, 8, 6)[3, 4, :3],
    )
    d = cam.ray_directions(8, 6)[3, 4].astype(np.float64)
    x, z = np.array([5.0 / -d[1] * d[0]]), np.array([5.0 / -d[1] * d[2]])
    t_soft, t_hard = (float(shadow_lookup(m.shadow, x, z)[0]) for m in (lit, lit_hard))
    a_pi = np.asarray(GROUND.albedo) / math.pi
    sky_only = a_pi * np.asarray(sky_irradiance(s.sky))
    sun = a_pi * np.asarray(s.sun.radiance)
    np.testing.assert_allclose(hard, sky_only + sun * t_hard, rtol=1e-3)
    np.testing.assert_allclose(soft, sky_only + sun * t_soft, rtol=1e-3)
    # Under the middle of the cloud the direct light through it is nearly nothing; the light
    # the cloud scatters through is the two-stream share (the penumbra only adds to it).
    tau = -math.log(t_hard)
    assert tau > 5
    two_stream = float(diffuse_transmittance(np.array(tau), s.settings.mean_cosine, 0.99))
    assert t_soft >= 0.95 * two_stream > 0.2
    assert (soft > 1.5 * sky_only).all() and (soft < 0.8 * (sky_only + sun)).all()
