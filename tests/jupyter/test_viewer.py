"""The viewer without a browser: its session (camera, sun, light reuse, previews) and the
widget driven through its traits and messages as the browser would."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli.jupyter.orbit import Orbit, angles, direction
from cumuli.jupyter.session import ViewerSession


def _scene() -> cu.Scene:
    return cu.Scene(
        [cu.gaussian_cumulus(n=8, seed=2)], noise=cu.Noise(seed=1, size=32),
        sun=cu.Sun(direction=(0.5, 0.6, -0.3)),
    )  # fmt: skip


def test_orbit_gives_the_camera_back_and_moves_it() -> None:
    cam = cu.Camera((3.0, 5.0, -40.0), (1.0, 2.0, 0.0), fov=40.0)
    orbit = Orbit.from_camera(cam)
    back = orbit.camera()
    np.testing.assert_allclose(back.position, cam.position, atol=1e-4)
    np.testing.assert_allclose(back.target, cam.target)
    assert back.fov == 40.0
    turned = orbit.rotated(50, 0)
    assert turned.azimuth == pytest.approx(orbit.azimuth - 20.0)
    assert turned.distance == orbit.distance and turned.target == orbit.target
    assert orbit.rotated(0, 1e5).elevation == 89.0  # never over the pole
    far = orbit.zoomed(2.0)
    assert far.distance == pytest.approx(2 * orbit.distance)
    with pytest.raises(ValueError, match="zoom"):
        orbit.zoomed(0.0)
    moved = orbit.panned(100, 0, 540)
    shift = np.subtract(moved.target, orbit.target)
    _, r, _ = orbit.camera().basis()
    assert float(np.dot(shift, r)) < 0 and abs(float(shift[1])) < 1e-6  # left, not up
    for az, el in [(0.0, 0.0), (90.0, 30.0), (-120.0, -10.0)]:
        assert angles(direction(az, el)) == pytest.approx((az, el))
    assert math.isclose(float(np.linalg.norm(direction(33, 44))), 1.0)


def test_session_reuses_the_light_while_the_camera_moves() -> None:
    s = ViewerSession(_scene(), size=(32, 18), preview_size=(16, 9), backend="cpu")
    first = s.render()
    lit = s.lit()
    s.rotate(40, -10)
    moved = s.render()
    assert s.lit() is lit  # camera only: the same light step
    assert first.shape == moved.shape == (18, 32, 4) and not np.array_equal(first, moved)
    want = cu.render(lit, s.orbit.camera(), 32, 18, backend="cpu", progress=False)
    np.testing.assert_array_equal(moved, want)
    preview = s.render(preview=True)
    assert preview.shape == (9, 16, 4)
    s.set(sun_elevation=70.0)
    assert s.lit() is not lit  # a new sun: new light
    np.testing.assert_allclose(s.scene().sun.direction, direction(s.sun_azimuth, 70.0), atol=1e-6)
    s.set(lighting="physical")
    assert s.lit().scene.settings.lighting == "physical"
    with pytest.raises(ValueError, match="lighting"):
        s.set(lighting="magic")
    with pytest.raises(ValueError, match="no setting"):
        s.set(colour=1)
    with pytest.raises(ValueError, match="time"):
        s.set(time=5.0)  # a still scene has no time axis
    with pytest.raises(TypeError, match="Scene"):
        ViewerSession(42)  # type: ignore[arg-type]


def test_session_follows_time() -> None:
    scenes = {0.0: _scene(), 1.0: _scene().replace(clouds=[cu.gaussian_cumulus(n=8, seed=5)])}
    s = ViewerSession(lambda t: scenes[round(t)], size=(24, 16), duration=1.0)
    a = s.render()
    s.set(time=1.0)
    b = s.render()
    assert s.duration == 1.0 and not np.array_equal(a, b)


def test_a_cloud_in_the_wind_gives_the_scene_a_time_axis() -> None:
    still = _scene()
    base = still.clouds[0]
    windy = still.replace(clouds=[cu.Cloud(base.centres, base.radii, wind=(3.0, 0.0))])
    s = ViewerSession(windy, size=(24, 16), backend="cpu")
    assert s.duration > 0
    s.set(time=2.0)
    assert s.scene_at_time().clouds[0].offset == (6.0, 0.0, 0.0)
    assert ViewerSession(still, size=(24, 16), backend="cpu").duration == 0.0


anywidget = pytest.importorskip("anywidget", reason="the widget needs anywidget (cumuli[jupyter])")


def test_widget_drives_camera_sun_and_frames() -> None:
    v = cu.Viewer(_scene(), size=(32, 18), preview_size=(16, 9), backend="cpu")
    assert v.frames == 1 and v.frame.startswith(b"\x89PNG") and v.frame_kind == "full"
    cam0, frame0 = dict(v.camera), v.frame
    v._on_message(v, {"type": "orbit", "dx": 30, "dy": 5}, [])
    assert v.frame_kind == "preview" and v.frames == 2
    assert v.camera["azimuth"] != cam0["azimuth"] and v.camera["elevation"] != cam0["elevation"]
    v._on_message(v, {"type": "end"}, [])
    assert v.frame_kind == "full" and v.frame != frame0 and v.frames == 3
    v._on_message(v, {"type": "zoom", "factor": 0.5}, [])
    assert v.camera["distance"] == pytest.approx(cam0["distance"] * 0.5)
    v._on_message(v, {"type": "pan", "dx": 10, "dy": 0}, [])
    assert v.camera["target"] != cam0["target"]
    v._on_message(v, {"type": "zoom", "factor": "x"}, [])
    assert "ValueError" in v.error
    lit = v.session.lit()
    before = v.frame
    v.sun_elevation = 75.0  # a slider, as the browser sets it
    assert v.session.sun_elevation == 75.0 and v.session.lit() is not lit and v.frame != before
    assert v.error == ""
    n, linear = v.frames, v.session.last
    v.exposure = 2.0  # the same frame, brighter, without a render
    assert v.frames == n + 1 and v.session.last is linear
    v.lighting = "bogus"
    assert "lighting" in v.error
    bundle = v._repr_mimebundle_()
    data = bundle[0] if isinstance(bundle, tuple) else bundle
    assert data["image/png"] == v.frame and "application/vnd.jupyter.widget-view+json" in data
