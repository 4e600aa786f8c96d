"""One scene, every kind of cloud: the compositor (RENDER_CONTRACT "Compositor").

A 2018 cumulus (marched) and an endless-animation volume frame (`VolumeCloud`) that overlap on
screen, drawn by GL and by the CPU twins: parity, the per-pixel order (the nearer cloud hides
the farther where both are opaque), the compositing equation itself, the single-pass path for
scenes of one kind, and scene files holding both kinds (version 2; version 1 still loads).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.testing import assert_image_close, only

W, H = 64, 48
SUN = cu.Sun(direction=(0.4, 0.8, 0.3), intensity=2.0)
SKY = cu.Sky()
BLACK = cu.Sky(zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0), sun_disc_intensity=0)
CAMERA = cu.Camera(position=(0.0, 3.0, -70.0), target=(0.0, 3.0, 0.0), fov=35)
SETTINGS = cu.RenderSettings(exact_noise=True, absorption=3.0, lighting="paper")


@pytest.fixture(scope="module")
def frame() -> cu.VolumeCloud:
    """Frame 0 of a small endless animation, lit for SUN and SKY, behind the cumulus."""
    shape = cu.gaussian_cumulus(centre=(0, 0, 0), n=12, seed=2)
    db = cu.evolving_cloud_volumes(shape, cu.Noise(seed=3, size=32), 2, 20, density_scale=4.0)
    lighting = cu.VolumeLighting(db, SUN, SKY, sigma_t=2.0, sh_order=2, sh_samples=2, ms_points=0)
    return cu.VolumeCloud.from_frame(lighting, 0).translated((6.0, 2.0, 30.0))


def mixed(frame: cu.VolumeCloud, sky: cu.Sky = SKY, near_volume: bool = False) -> cu.Scene:
    cumulus = cu.gaussian_cumulus(centre=(-4.0, 0.0, 0.0), seed=1)
    if near_volume:  # the volume in front, the cumulus behind it
        cumulus = cumulus.translated((0.0, 0.0, 45.0))
        frame = frame.translated((0.0, 0.0, -45.0))
    return cu.Scene(
        [cumulus, frame], sun=SUN, sky=sky, noise=cu.Noise(seed=7, size=32), settings=SETTINGS
    )


def alone(scene: cu.Scene, k: int) -> cu.Scene:
    return scene.replace(clouds=[scene.clouds[k]])


@pytest.mark.gl
def test_mixed_scene_gl_and_cpu_agree(frame: cu.VolumeCloud) -> None:
    scene = cu.prepare_light(mixed(frame))
    gl = cu.render(scene, CAMERA, W, H)
    cpu = cu.render(scene, CAMERA, W, H, backend="cpu")
    assert np.isfinite(gl).all() and gl.shape == (H, W, 4)
    # The render pass's parity tolerance (RENDER_CONTRACT): mean per channel ≤ 1e-3.
    assert_image_close(gl, cpu, **only(channel_mean_abs=1e-3))
    # Both clouds are in the picture and overlap on screen.
    a0 = cu.render(alone(scene.scene, 0), CAMERA, W, H, backend="cpu")[..., 3]
    a1 = cu.render(alone(scene.scene, 1), CAMERA, W, H, backend="cpu")[..., 3]
    assert ((a0 > 0.05) & (a1 > 0.05)).sum() > 20


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
@pytest.mark.parametrize("near_volume", [False, True])
def test_the_nearer_cloud_hides_the_farther(
    frame: cu.VolumeCloud, backend: str, near_volume: bool
) -> None:
    scene = mixed(frame, near_volume=near_volume)
    both = cu.render(scene, CAMERA, W, H, backend=backend)
    cumulus = cu.render(alone(scene, 0), CAMERA, W, H, backend=backend)
    volume = cu.render(alone(scene, 1), CAMERA, W, H, backend=backend)
    near, far = (volume, cumulus) if near_volume else (cumulus, volume)
    opaque = (near[..., 3] > 0.995) & (far[..., 3] > 0.995)
    assert opaque.sum() >= 5
    # Where the nearer cloud is opaque the farther one cannot show through.
    np.testing.assert_allclose(both[opaque], near[opaque], atol=1e-2)
    assert np.abs(both[opaque] - far[opaque]).max() > 0.05


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_layers_compose_by_the_over_operator(frame: cu.VolumeCloud, backend: str) -> None:
    # Under a black sky a cloud alone renders its premultiplied layer (C, 1 − T); the composite
    # is C_near + T_near·C_far wherever both boxes are hit (the cumulus is entered first).
    scene = mixed(frame, sky=BLACK)
    both = cu.render(scene, CAMERA, W, H, backend=backend).astype(np.float64)
    near = cu.render(alone(scene, 0), CAMERA, W, H, backend=backend).astype(np.float64)
    far = cu.render(alone(scene, 1), CAMERA, W, H, backend=backend).astype(np.float64)
    expect_rgb = near[..., :3] + (1 - near[..., 3:]) * far[..., :3]
    expect_a = 1 - (1 - near[..., 3]) * (1 - far[..., 3])
    np.testing.assert_allclose(both[..., :3], expect_rgb, atol=1e-5)
    np.testing.assert_allclose(both[..., 3], expect_a, atol=1e-5)


def test_order_is_per_pixel_by_box_entry(frame: cu.VolumeCloud) -> None:
    # Seen from behind (camera on +z), the volume is nearer: the same scene composites the
    # other way round, without any change to the scene.
    scene = mixed(frame, sky=BLACK)
    back = cu.Camera(position=(0.0, 3.0, 100.0), target=(0.0, 3.0, 0.0), fov=35)
    both = cu.render(scene, back, W, H, backend="cpu").astype(np.float64)
    cumulus = cu.render(alone(scene, 0), back, W, H, backend="cpu").astype(np.float64)
    volume = cu.render(alone(scene, 1), back, W, H, backend="cpu").astype(np.float64)
    expect = volume[..., :3] + (1 - volume[..., 3:]) * cumulus[..., :3]
    np.testing.assert_allclose(both[..., :3], expect, atol=1e-5)


@pytest.mark.gl
def test_a_scene_of_one_kind_takes_the_single_pass(frame: cu.VolumeCloud) -> None:
    # Only 2018 clouds: the marcher draws them all in one pass (the paper's rule); one volume:
    # the volume marcher over the sky. Both equal their drawer's own image bit for bit.
    two = cu.Scene(
        [cu.gaussian_cumulus(seed=1), cu.gaussian_cumulus(centre=(25, 0, 10), seed=2)],
        noise=cu.Noise(seed=7, size=32),
        settings=SETTINGS,
    )
    from cumuli.rendering.compositor import plan

    assert plan(two) == [("cloud", [0, 1])]
    assert plan(mixed(frame)) == [("cloud", [0]), ("volume", [1])]
    lit = cu.prepare_light(two)
    with cu.Renderer() as r:
        direct = r.drawer("cloud").draw(lit, [0, 1], CAMERA, W, H, True)
        np.testing.assert_array_equal(r.render(lit, CAMERA, W, H), direct)
    single = cu.Scene([frame], sun=SUN, sky=SKY, settings=cu.RenderSettings(lighting="paper"))
    img = cu.render(single, CAMERA, W, H, backend="cpu")
    ref = cu.render_volume(
        frame.density, frame.light, frame.box, CAMERA, W, H, SUN, SKY, backend="cpu",
        sigma_t=frame.sigma_t, albedo=frame.albedo, g=frame.g,
    )  # fmt: skip
    np.testing.assert_array_equal(img, ref)


def test_volume_light_is_computed_for_another_sun(frame: cu.VolumeCloud) -> None:
    # The frame's light was made for SUN; under another sun the light step recomputes it.
    scene = cu.Scene(
        [frame],
        sun=cu.Sun(direction=(-0.5, 0.6, -0.2)),
        sky=SKY,
        settings=cu.RenderSettings(lighting="paper"),
    )
    light = cu.prepare_light(scene).lights[0]
    assert light.shape == (*frame.shape, 4)
    assert not np.array_equal(light, frame.light)
    assert cu.prepare_light(mixed(frame)).lights[1] is frame.light


def test_scene_with_both_kinds_round_trips(tmp_path: Path, frame: cu.VolumeCloud) -> None:
    scene = mixed(frame).replace(camera=CAMERA, lights=(cu.Sun((0, 1, 0), (1, 0.5, 0.5), 0.3),))
    path = scene.save(tmp_path / "mixed.json")
    back = cu.load_scene(path)
    assert back.to_dict() == scene.to_dict()
    assert back.kinds == ("cloud", "volume")
    np.testing.assert_array_equal(back.clouds[1].density, frame.density)
    np.testing.assert_array_equal(back.clouds[1].light, frame.light)
    assert back.clouds[1].light_sun == SUN and back.lights == scene.lights
    np.testing.assert_array_equal(
        cu.render(back, CAMERA, 16, 12, backend="cpu"),
        cu.render(scene, CAMERA, 16, 12, backend="cpu"),
    )


def test_version_1_scene_files_still_load(tmp_path: Path) -> None:
    scene = cu.Scene(
        [cu.gaussian_cumulus(seed=1)],
        noise=cu.Noise(seed=7, size=16),
        settings=cu.RenderSettings(lighting="paper"),
    )
    doc = scene.to_dict()
    doc["version"] = 1
    del doc["lights"]
    for c in doc["clouds"]:
        del c["kind"]  # version 1: every cloud is a 2018 cloud
    (tmp_path / "v1.json").write_text(json.dumps(doc))
    back = cu.load_scene(tmp_path / "v1.json")
    assert back.kinds == ("cloud",)
    np.testing.assert_array_equal(back.clouds[0].centres, scene.clouds[0].centres)


def test_bad_scene_contents_are_refused(tmp_path: Path, frame: cu.VolumeCloud) -> None:
    doc = mixed(frame).to_dict()
    for change, match in [
        (lambda d: d["clouds"][1].update(kind="smoke"), "kind 'smoke'"),
        (lambda d: d["clouds"][1].update(colour=1), "unknown field"),
        (lambda d: d["clouds"][1]["density"].update(base64="!!"), "base64"),
        (lambda d: d["clouds"][1]["density"].update(shape=[2, 2]), "bytes"),
        (lambda d: d.update(version=9), "version"),
        (lambda d: d.update(extra=1), "unknown field"),
    ]:
        bad = json.loads(json.dumps(doc))
        change(bad)
        (tmp_path / "bad.json").write_text(json.dumps(bad))
        with pytest.raises(ValueError, match=match):
            cu.load_scene(tmp_path / "bad.json")
    with pytest.raises(TypeError, match="drawable"):
        cu.Scene(["not a cloud"], settings=cu.RenderSettings(lighting="paper"))
    with pytest.raises(TypeError, match="lights"):
        cu.Scene(lights=["sun"], settings=cu.RenderSettings(lighting="paper"))
