"""Impostor mathematics of Harris 2002 §3."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.gl.sprites import camera_dict
from cumuli.rendering.impostors import (
    ImpostorSettings,
    ImpostorState,
    impostor_resolution,
    impostor_view,
    needs_screen_impostor,
    needs_update,
    required_resolution,
    translation_error,
)

W, H = 640, 480


def test_tight_view_geometry() -> None:
    eye, centre, r = (3.0, 4.0, -50.0), (1.0, 2.0, 10.0), 12.0
    v = impostor_view(eye, centre, r)
    d = math.dist(eye, centre)
    assert v.distance == pytest.approx(d)
    assert v.fov == pytest.approx(2 * math.degrees(math.asin(r / d)))
    assert v.half_size == pytest.approx(d * r / math.sqrt(d * d - r * r))
    n = (np.array(centre) - eye) / d
    assert np.allclose(v.near_point, np.array(eye) + (d - r) * n)
    assert np.allclose(v.far_point, np.array(eye) + (d + r) * n)
    assert np.allclose(np.cross(v.right, v.up), -np.asarray(v.forward))  # r × u = −f
    # The quad's corners land on the corners of the impostor camera's square image.
    res = 256
    cam = camera_dict(v.camera(), res, res)
    proj = _core.project_sprites(
        v.quad().astype(np.float32), np.ones((4, 2), np.float32), np.zeros(4, np.float32), cam
    )
    assert np.allclose(proj[:, :2], [(0, res), (res, res), (res, 0), (0, 0)], atol=1e-3)
    # The sphere touches the image edges: its tangent cone has half-angle β.
    assert math.degrees(math.asin(r / d)) == pytest.approx(v.fov / 2)
    straight_down = impostor_view((0, 50, 0), (0, 0, 0), 5)  # degenerate up: falls back to +x
    assert np.allclose(straight_down.right, [0, 0, 1]) and straight_down.camera().fov > 0
    with pytest.raises(ValueError, match="inside"):
        impostor_view((0, 0, 0), (0, 0, 1), 2)


def test_translation_error_lateral_and_axial() -> None:
    """§10.3.2: α_trans = atan2(2Rδ, d² − R² + δ²) ≈ δ·2R/(d² − R²) for lateral δ; 0 axially."""
    d, r = 80.0, 15.0
    v = impostor_view((0, 0, -d), (0, 0, 0), r)
    for delta in (1e-3, 0.1, 1.0, 10.0):
        got = translation_error(v.near_point, v.far_point, (delta, 0, -d))
        exact = math.degrees(math.atan2(2 * r * delta, d * d - r * r + delta * delta))
        assert got == pytest.approx(exact, rel=1e-9)
        if delta <= 0.1:
            assert got == pytest.approx(math.degrees(delta * 2 * r / (d * d - r * r)), rel=1e-4)
    for t in (-100.0, -20.0, 0.0, 30.0, 60.0):  # along the original line of sight
        assert translation_error(v.near_point, v.far_point, (0, 0, -d + t)) < 1e-9


def orbit_cameras(d: float, frames: int) -> list[cu.Camera]:
    return [
        cu.Camera(
            (d * math.sin(2 * math.pi * f / frames), 0.0, -d * math.cos(2 * math.pi * f / frames)),
            (0.0, 0.0, 0.0),
            fov=50.0,
        )
        for f in range(frames)
    ]


@pytest.mark.parametrize("tolerance", [0.15, 0.5, 1.0])
def test_orbit_regeneration_count_matches_prediction(tolerance: float) -> None:
    """§10.3.2: along a circular orbit of radius d about the cloud, α_trans(φ) =
    atan(2Rd|sin φ|/(d² − R²)), so an impostor lasts ⌈φ*/Δφ⌉ frames with
    sin φ* = (d² − R²)tan(tol)/(2Rd)."""
    d, r, frames = 60.0, 10.0, 3600
    s = ImpostorSettings(tolerance=tolerance)
    cams = orbit_cameras(d, frames)
    state = ImpostorState.generate((0, 0, 0), r, cams[0], W, H, s)
    updates = 0
    for cam in cams[1:]:
        reason = needs_update(state, cam, W, H, s)
        if reason is not None:
            assert reason == "translation"
            updates += 1
            state = ImpostorState.generate((0, 0, 0), r, cam, W, H, s)
    phi_star = math.asin((d * d - r * r) * math.tan(math.radians(tolerance)) / (2 * r * d))
    step = 2 * math.pi / frames
    predicted = (frames - 1) // math.ceil(phi_star / step)
    assert abs(updates - predicted) <= 1
    assert updates > 0


def test_resolution_trigger_on_a_fly_towards_path() -> None:
    """§10.3.3: the resolution update fires exactly when f_px·2R/d exceeds the texture size."""
    r = 10.0
    s = ImpostorSettings()
    cams = [cu.Camera((0, 0, -dist), (0, 0, 0), fov=50) for dist in np.linspace(600, 12, 400)]
    state = ImpostorState.generate((0, 0, 0), r, cams[0], W, H, s)
    f_px = (H / 2) / math.tan(math.radians(25))
    sizes = [state.res]
    for cam in cams[1:]:
        dist = -cam.position[2]
        reason = needs_update(state, cam, W, H, s)
        expected = f_px * 2 * r / dist > state.res
        screen = needs_screen_impostor(cam.position, (0, 0, 0), r, cam, W, H, s)
        if screen:
            assert reason == "screen"
            break
        assert (reason == "resolution") == expected, (dist, reason, state.res)
        assert reason in (None, "resolution")
        if reason:
            state = ImpostorState.generate((0, 0, 0), r, cam, W, H, s)
            sizes.append(state.res)
    assert sizes == sorted(sizes) and len(sizes) >= 4
    assert all(size & (size - 1) == 0 for size in sizes)  # powers of two
    assert sizes[-1] <= s.max_res


def test_resolution_rules() -> None:
    s = ImpostorSettings()
    assert impostor_resolution(0.5, s) == 16
    assert impostor_resolution(100.0, s) == 128 and impostor_resolution(128.0, s) == 128
    assert impostor_resolution(129.0, s) == 256 and impostor_resolution(1e9, s) == 2048
    assert impostor_resolution(100.0, ImpostorSettings(pow2=False)) == 100
    cam = cu.Camera((0, 0, -100), (0, 0, 0), fov=50)
    f_px = (H / 2) / math.tan(math.radians(25))
    assert required_resolution(cam, H, (0, 0, 0), 10) == pytest.approx(f_px * 20 / 100)
    assert required_resolution(cam, H, (0, 0, 0), 10, res_scale=2) == pytest.approx(f_px * 40 / 100)
    sky = ImpostorSettings.preset("skyworks")
    assert sky.tolerance == 0.125 and sky.resolution_rule == "skyworks"
    for dist, want in ((100.0, 128), (30.0, 256), (10.5, 320), (8.0, 80), (4.0, 40), (1e4, 16)):
        got = impostor_resolution(
            0.0, sky, camera=cam, width=W, height=H, radius=10.0, distance=dist
        )
        assert got == want, dist


def test_screen_impostors_and_reasons() -> None:
    """§7.4: inside the sphere, near plane cutting it, or wider than the view → screen impostor
    at ⌈W/4⌉ × ⌈H/4⌉, regenerated every frame; versions and pure translation (§7.3.5)."""
    s = ImpostorSettings()
    inside = cu.Camera((1, 0, 0), (0, 0, 5), fov=60)
    st = ImpostorState.generate((0, 0, 0), 10, inside, 641, 479, s)
    assert st.screen and st.size == (161, 120) and st.view is None
    assert needs_update(st, inside, 641, 479, s) == "screen"
    narrow = cu.Camera((0, 0, -10.5), (0, 0, 0), fov=10)  # 2β ≈ 144° ≫ the view
    assert needs_screen_impostor(narrow.position, (0, 0, 0), 10, narrow, W, H, s)
    near_cut = ImpostorSettings(near=1.0)
    close = cu.Camera((0, 0, -10.5), (0, 0, 0), fov=170)
    assert needs_screen_impostor(close.position, (0, 0, 0), 10, close, W, H, near_cut)
    assert not needs_screen_impostor(close.position, (0, 0, 0), 10, close, W, H, s)
    far = cu.Camera((0, 0, -100), (0, 0, 0), fov=50)
    st = ImpostorState.generate((0, 0, 0), 10, far, W, H, s, light_version=2, cloud_version=5)
    assert not st.screen
    assert needs_update(None, far, W, H, s) == "missing"
    assert needs_update(st, far, W, H, s, light_version=2, cloud_version=5) is None
    assert needs_update(st, far, W, H, s, light_version=3, cloud_version=5) == "light"
    assert needs_update(st, far, W, H, s, light_version=2, cloud_version=6) == "cloud"
    # Wind: the cloud moved by (30, 0, 0) and so did the eye: nothing to redo.
    moved = cu.Camera((30, 0, -100), (30, 0, 0), fov=50)
    assert (
        needs_update(st, moved, W, H, s, offset=(30, 0, 0), light_version=2, cloud_version=5)
        is None
    )
    assert needs_update(st, moved, W, H, s, light_version=2, cloud_version=5) == "translation"
    behind = cu.Camera((0, 0, 100), (0, 0, 0), fov=50)  # passed the cloud's mid-plane
    assert needs_update(st, behind, W, H, s, light_version=2, cloud_version=5) == "backwards"


@pytest.mark.parametrize(
    "field, value",
    [
        ("tolerance", 0.0),
        ("tolerance", 6.0),
        ("res_scale", 0.0),
        ("min_res", 0),
        ("max_res", 8),
        ("inside_factor", 9),
        ("resolution_rule", "fast"),
        ("near", -1.0),
        ("pow2", 1),
        ("release_after", 0),
    ],
)
def test_settings_validation(field: str, value: object) -> None:
    with pytest.raises((ValueError, TypeError), match=field):
        ImpostorSettings(**{field: value})


def test_bad_input() -> None:
    with pytest.raises(ValueError, match="radius"):
        impostor_view((0, 0, -10), (0, 0, 0), 0.0)
    with pytest.raises(ValueError, match="eye"):
        translation_error((0, 0, 0), (0, 0, 1), (float("nan"), 0, 0))
    with pytest.raises(TypeError, match="state"):
        needs_update("state", cu.Camera((0, 0, -5), (0, 0, 0)), W, H)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="settings"):
        needs_update(None, cu.Camera((0, 0, -5), (0, 0, 0)), W, H, settings={})  # type: ignore
