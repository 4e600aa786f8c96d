"""Checks before expensive work and float32 overflow refused for both backends
(item 7): every size limit is enforced before anything large is allocated or computed, and
values that would overflow float32 in the renderers are refused when the object is made.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli._util import validate as check
from cumuli.anim import endless
from cumuli.light import prepare
from cumuli.model import volume as mvolume

BOX = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
CAMERA = cu.Camera((0.5, 0.5, -3.0), (0.5, 0.5, 0.5), fov=40)


def _volume(n: int = 4) -> tuple[np.ndarray, np.ndarray]:
    return np.full((n, n, n), 0.5, np.float32), np.ones((n, n, n, 4), np.float32)


# --- item 6: sizes before work ------------------------------------------------------------------
@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_render_volume_refuses_too_many_pixels_before_allocating(backend: str) -> None:
    vol, light = _volume()
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match="pixels"):
            cu.render_volume(vol, light, BOX, CAMERA, 16384, 16384, backend=backend)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1 << 24


@pytest.mark.gl
def test_the_volume_renderer_refuses_too_many_pixels() -> None:
    vol, light = _volume()
    with cu.VolumeRenderer() as vr, pytest.raises(ValueError, match="pixels"):
        vr.render(vol, light, BOX, CAMERA, 16384, 8193)
    from cumuli.rendering.volume import render_volume_cpu

    with pytest.raises(ValueError, match="pixels"):
        render_volume_cpu(
            vol, light, BOX, CAMERA, 16384, 8193, cu.Sun(), cu.Sky(), sigma_t=1.0, albedo=1.0,
            g=0.2, step=None,
        )  # fmt: skip


def _tiny_database(n: int) -> cu.VolumeDatabase:
    vols = np.random.default_rng(0).uniform(0, 1, (n, 1, 1, 1)).astype(np.float32)
    return cu.VolumeDatabase(vols, (0, 0, 0), (1, 1, 1))


def test_the_similarity_matrix_size_is_checked_before_allocating(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    limit = mvolume.MAX_SIMILARITY_VOLUMES
    assert limit == 1 << 13  # an (N, N) float64 matrix of at most 512 MiB
    monkeypatch.setattr(mvolume, "MAX_SIMILARITY_VOLUMES", 64)  # the same check, smaller sizes
    db = _tiny_database(65)

    def never(*args: object) -> None:
        raise AssertionError("the N×N matrix was computed")

    monkeypatch.setattr(mvolume._core, "similarity_matrix", never)
    for call in (
        db.similarity,
        lambda: cu.similarity_matrix(db.volumes),
        lambda: cu.EndlessAnimation(db),
        lambda: cu.transition_matrix(db),
    ):
        with pytest.raises(ValueError, match="MAX_SIMILARITY_VOLUMES"):
            call()


def test_the_similarity_limit_holds_at_its_real_size() -> None:
    db = _tiny_database(mvolume.MAX_SIMILARITY_VOLUMES + 1)
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match="volumes"):
            db.similarity()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20


def test_endless_frames_refuses_a_list_too_long_before_walking() -> None:
    anim = cu.EndlessAnimation(_tiny_database(6), crossfade_frames=1, seed=1)
    limit = endless.MAX_FRAME_LIST
    assert limit == 1 << 18
    with pytest.raises(ValueError, match="MAX_FRAME_LIST"):
        anim.frames(limit + 1, densities=False)
    assert anim.step().index == 0  # nothing was walked
    assert len(anim.frames(5, densities=False)) == 5


@pytest.mark.gl
def test_the_light_atlas_limit_is_checked_before_the_light_pass(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    cloud = cu.gaussian_cumulus(n=4, seed=1)
    settings = cu.RenderSettings(light_resolution=256, lighting="paper")
    scene = cu.Scene([cloud.translated((30 * k, 0, 0)) for k in range(9)], settings=settings)

    def never(*args: object) -> None:
        raise AssertionError("a light grid was computed")

    kind = cu.registry.get("cloud")
    monkeypatch.setitem(cu.registry._KINDS, "cloud", dataclasses.replace(kind, light=never))
    prepare.clear_memo()
    with pytest.raises(ValueError, match="GL_MAX_3D_TEXTURE_SIZE") as err:
        cu.render(scene, scene.default_camera(), 8, 8)
    assert "light_resolution" in str(err.value)
    with cu.Renderer() as r:
        with pytest.raises(ValueError, match="atlas"):
            r.drawer("cloud").check_light(scene, list(range(9)))
        r.drawer("cloud").check_light(scene, list(range(7)))  # 7 × 256 fits in 2048


# --- item 7: float32 overflow -------------------------------------------------------------------
@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: cu.Sun(intensity=1e300), "sun.intensity"),
        (lambda: cu.Sun(colour=(1e20, 1, 1), intensity=1e20), "sun"),
        (lambda: cu.Sun(colour=(1e39, 1, 1)), "sun.colour"),
        (lambda: cu.Sky(zenith=(1e39, 0, 0)), "sky.zenith"),
        (lambda: cu.Sky(horizon=(0, 1e13, 0)), "sky.horizon"),
        (lambda: cu.Sky(sun_disc_intensity=1e39), "sky.sun_disc_intensity"),
        (lambda: cu.Camera((1e39, 0, 0), (0, 0, 0)), "camera.position"),
        (lambda: cu.Camera((0, 0, 0), (0, 0, 1e16)), "camera.target"),
        (lambda: cu.RenderSettings(absorption=1e39, lighting="paper"), "settings.absorption"),
        (lambda: cu.RenderSettings(step_max=1e39, lighting="paper"), "settings.step_max"),
        (lambda: cu.VolumeCloud(np.ones((2, 2, 2)), BOX, sigma_t=1e39), "sigma_t"),
        (lambda: cu.VolumeCloud(np.ones((2, 2, 2)), ((0, 0, 0), (1e39, 1, 1))), "box_max"),
        (lambda: cu.VolumeCloud(np.full((2, 2, 2), 1e39), BOX), "density"),
        (lambda: cu.LightGrid(np.full((2, 2, 2), 1e30, np.float32), BOX), "light grid"),
    ],
)
def test_values_that_overflow_float32_are_refused_when_made(make, name: str) -> None:
    with pytest.raises((ValueError, TypeError)) as err:
        make()
    assert name in str(err.value)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_the_largest_accepted_values_render_finite_images(backend: str) -> None:
    big = check.MAX_RADIANCE
    sun = cu.Sun(colour=(1, 1, 1), intensity=big)
    sky = cu.Sky(zenith=(big, big, big), horizon=(big, 0, 0), sun_disc_intensity=big)
    scene = cu.Scene([cu.gaussian_cumulus(n=6, seed=1)], sun=sun, sky=sky,
                     noise=cu.Noise(seed=2, size=16),
                     settings=cu.RenderSettings(lighting="paper"))  # fmt: skip
    img = cu.render(scene, scene.default_camera(), 24, 16, backend=backend)
    assert np.isfinite(img).all() and img[..., :3].max() > 1e9
    far = cu.Camera((check.MAX_COORD, 0, 0), (0, 0, 0))
    assert np.isfinite(cu.render(scene, far, 8, 8, backend=backend)).all()
    vol, light = _volume()
    v = cu.render_volume(vol, light, BOX, CAMERA, 8, 6, sun, sky, backend=backend)
    assert np.isfinite(v).all()


def test_a_scene_file_with_an_overflowing_intensity_is_refused_by_the_cli(tmp_path: Path) -> None:
    scene = cu.Scene(
        [cu.gaussian_cumulus(n=6, seed=1)],
        noise=cu.Noise(seed=2, size=16),
        settings=cu.RenderSettings(lighting="paper"),
    )
    data = scene.to_dict()
    data["sun"]["intensity"] = 1e300
    path = tmp_path / "s.json"
    path.write_text(json.dumps(data))
    done = subprocess.run(
        [sys.executable, "-m", "cumuli", "render", str(path), "-o", str(tmp_path / "x.png"),
         "--size", "8x8", "--backend", "cpu"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 1
    assert "sun.intensity" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "x.png").exists()
