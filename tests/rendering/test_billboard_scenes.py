"""Billboard clouds in scenes (Torchelsen & Musse 2005; spec §7, §13.4–13.5): beside 2018 marched
clouds and volume frames through the compositor (GL and CPU, parity, per-pixel order, the over
operator), a `Weather` as a scene sequence (`Weather.scene_at`, `render_frames`), the
``cumuli demo --torchelsen`` command and the public names."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.cli import main
from cumuli.io.images import read_image
from cumuli.rendering.compositor import plan
from cumuli.testing import assert_image_close, only

W, H = 64, 48
SUN = cu.Sun(direction=(0.4, 0.8, 0.3), intensity=2.0)
SKY = cu.Sky()
BLACK = cu.Sky(zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0), sun_disc_intensity=0)
CAMERA = cu.Camera(position=(0.0, 3.0, -70.0), target=(0.0, 3.0, 0.0), fov=35)
SETTINGS = cu.RenderSettings(exact_noise=True, absorption=3.0, lighting="paper")
SHADING = cu.BillboardShading(exact_textures=True, ambient=(0.3, 0.35, 0.45))
BACKENDS = ["cpu", pytest.param("gl", marks=pytest.mark.gl)]


@pytest.fixture(scope="module")
def frame() -> cu.VolumeCloud:
    shape = cu.gaussian_cumulus(centre=(0, 0, 0), n=12, seed=2)
    db = cu.evolving_cloud_volumes(shape, cu.Noise(seed=3, size=32), 2, 20, density_scale=4.0)
    lighting = cu.VolumeLighting(db, SUN, cu.Sky(), sigma_t=2.0, sh_order=2, sh_samples=2,
                                 ms_points=0)  # fmt: skip
    return cu.VolumeCloud.from_frame(lighting, 0).translated((14.0, 2.0, 30.0))


@pytest.fixture(scope="module")
def nimbus() -> cu.BillboardCloud:
    cloud = cu.seed_box_cloud(cu.seedbox_presets.nimbus(), seed=4)
    return cloud.translated(-cloud.centre.astype(float) + np.array([2.0, 2.0, 0.0]))


def mixed(frame, nimbus, sky=SKY, billboards_near=True) -> cu.Scene:
    cumulus = cu.gaussian_cumulus(centre=(-4.0, 0.0, 0.0), seed=1)
    bb = nimbus.translated((0.0, 0.0, -20.0 if billboards_near else 25.0))
    return cu.Scene([cumulus, bb, frame], sun=SUN, sky=sky, noise=cu.Noise(seed=7, size=32),
                    settings=SETTINGS, billboard_shading=SHADING)  # fmt: skip


def alone(scene: cu.Scene, k: int) -> cu.Scene:
    return scene.replace(clouds=[scene.clouds[k]])


@pytest.mark.gl
def test_mixed_scene_gl_and_cpu_agree(frame, nimbus) -> None:
    scene = cu.prepare_light(mixed(frame, nimbus))
    assert plan(scene.scene) == [("cloud", [0]), ("billboards", [1]), ("volume", [2])]
    gl = cu.render(scene, CAMERA, W, H)
    cpu = cu.render(scene, CAMERA, W, H, backend="cpu")
    assert_image_close(gl, cpu, **only(channel_mean_abs=1e-3))
    a = [cu.render(alone(scene.scene, k), CAMERA, W, H, backend="cpu")[..., 3] for k in range(3)]
    assert ((a[0] > 0.05) & (a[1] > 0.05)).sum() > 20  # billboards over the cumulus
    assert ((a[1] > 0.05) & (a[2] > 0.05)).sum() > 5  # and over the volume


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("billboards_near", [True, False])
def test_the_nearer_cloud_hides_the_farther(frame, nimbus, backend, billboards_near) -> None:
    scene = mixed(frame, nimbus, billboards_near=billboards_near)
    both = cu.render(scene, CAMERA, W, H, backend=backend)
    marched = cu.render(alone(scene, 0), CAMERA, W, H, backend=backend)
    bb = cu.render(alone(scene, 1), CAMERA, W, H, backend=backend)
    near, far = (bb, marched) if billboards_near else (marched, bb)
    opaque = (near[..., 3] > 0.99) & (far[..., 3] > 0.99)
    assert opaque.sum() >= 5
    np.testing.assert_allclose(both[opaque], near[opaque], atol=2e-2)
    assert np.abs(both[opaque] - far[opaque]).max() > 0.05


@pytest.mark.parametrize("backend", BACKENDS)
def test_layers_compose_by_the_over_operator(frame, nimbus, backend) -> None:
    scene = mixed(frame, nimbus, sky=BLACK).replace(clouds=mixed(frame, nimbus).clouds[:2])
    lit = cu.prepare_light(scene)
    both = cu.render(lit, CAMERA, W, H, backend=backend).astype(np.float64)
    # The billboards with the light they have in the scene (the cumulus' shadow on their CAF).
    bb_alone = cu.LitScene(alone(scene, 1), (lit.lights[1],))
    bb = cu.render(bb_alone, CAMERA, W, H, backend=backend).astype(np.float64)
    marched = cu.render(alone(scene, 0), CAMERA, W, H, backend=backend).astype(np.float64)
    expect = bb[..., :3] + (1 - bb[..., 3:]) * marched[..., :3]
    np.testing.assert_allclose(both[..., :3], expect, atol=1e-5)
    np.testing.assert_allclose(both[..., 3], 1 - (1 - bb[..., 3]) * (1 - marched[..., 3]),
                               atol=1e-5)  # fmt: skip


# --- weather as a scene sequence ---------------------------------------------------------------
@pytest.fixture
def sky_weather() -> cu.Weather:
    model = cu.seedbox_presets.cumulus()
    layer = cu.CloudLayer(30.0, 4.0, wind=(5.0, 0.0), states=(
        cu.SkyState(0.0, (model,), variants=3, count=6),
        cu.SkyState(1.0, (cu.seedbox_presets.rain(),), variants=2, count=12, sun_scale=0.5,
                    background=cu.weather_presets.STORMY),
    ))  # fmt: skip
    return cu.Weather(((-60.0, -60.0), (60.0, 60.0)), [layer], cv=[(0.0, 0.0), (20.0, 1.0)],
                      seed=3)  # fmt: skip


def test_scene_at_holds_the_fields_and_the_base(sky_weather, nimbus) -> None:
    base = cu.Scene(
        [nimbus],
        sun=SUN,
        billboard_shading=SHADING,
        camera=CAMERA,
        settings=cu.RenderSettings(lighting="paper"),
    )
    scene = sky_weather.scene_at(base)
    assert scene.kinds == ("billboards", "billboard_field")
    assert scene.clouds[0] is nimbus and scene.clouds[1].n == 6
    assert scene.camera == CAMERA and scene.billboard_shading == SHADING
    assert scene.sky == base.sky and scene.sun == SUN
    for _ in range(20):
        sky_weather.step(1.0)
    late = sky_weather.scene_at(base)
    assert late.sky.zenith == cu.weather_presets.STORMY.zenith
    assert late.sun.intensity == pytest.approx(0.5 * SUN.intensity)
    assert late.sun.direction == SUN.direction
    with pytest.raises(TypeError, match="base"):
        sky_weather.scene_at("sky")


def test_render_frames_films_a_weather(tmp_path: Path, sky_weather) -> None:
    cam = cu.Camera(position=(0.0, 5.0, -90.0), target=(0.0, 30.0, 0.0), fov=60)
    paths = cu.render_frames(sky_weather, cam, tmp_path, 32, 24, backend="cpu", frames=3,
                             dt=4.0, progress=False, pattern="f{:02d}.exr")  # fmt: skip
    assert [p.name for p in paths] == ["f00.exr", "f01.exr", "f02.exr"]
    assert sky_weather.t == pytest.approx(8.0)
    twin = cu.Weather(sky_weather.area, sky_weather.layers, sky_weather.schedule, seed=3)
    for k in range(3):
        expect = cu.render(twin.scene_at(), cam, 32, 24, backend="cpu")
        got = read_image(paths[k])
        np.testing.assert_allclose(got[..., :3], expect[..., :3], atol=1e-6)
        twin.step(4.0)
    assert not np.allclose(read_image(paths[0]), read_image(paths[2]))  # the clouds drifted
    with pytest.raises(ValueError, match="dt"):
        cu.render_frames(sky_weather, [cam], tmp_path, 8, 8, backend="cpu", progress=False)
    with pytest.raises(ValueError, match="frames"):
        cu.render_frames(sky_weather, cam, tmp_path, 8, 8, backend="cpu", dt=1.0)
    with pytest.raises(ValueError, match="locally"):
        cu.render_frames(sky_weather, [cam], tmp_path, 8, 8, dt=1.0, client=object())
    with pytest.raises(ValueError, match="Weather only"):
        cu.render_frames(
            cu.Scene(settings=cu.RenderSettings(lighting="paper")),
            [cam],
            tmp_path,
            8,
            8,
            dt=1.0,
            frames=2,
        )
    with pytest.raises(ValueError, match="dt"):
        cu.render_frames(
            cu.Scene(settings=cu.RenderSettings(lighting="paper")),
            [cam],
            tmp_path,
            8,
            8,
            dt=float("nan"),
        )
    assert sky_weather.t == pytest.approx(8.0)  # refused calls did not step it


def test_demo_torchelsen_writes_the_fig14_sequence(tmp_path: Path, capsys) -> None:
    out = tmp_path / "fig14.png"
    assert main(["demo", "--torchelsen", "-o", str(out), "--backend", "cpu", "--width", "96",
                 "--height", "64"]) == 0  # fmt: skip
    assert "Fig. 14" in capsys.readouterr().out
    img = read_image(tmp_path / "fig14.exr")
    assert img.shape == (64, 96, 4) and (img[..., 3] == 1).all()
    sunny, stormy = img[:16, :48, :3].mean(), img[32:48, 48:, :3].mean()  # top sky rows
    assert stormy < sunny - 0.05  # CV 1 is darker than CV 0


def test_public_names() -> None:
    for name in ("SeedBox", "BasisModel", "BillboardCloud", "BillboardField", "seed_box_cloud",
                 "cloud_variants", "sprite_atlas", "seedbox_presets", "absorption_factors",
                 "BillboardShading", "SkyState", "CloudLayer", "Schedule", "Weather",
                 "load_weather", "weather_presets", "load_billboards"):  # fmt: skip
        assert name in cu.__all__ and getattr(cu, name) is not None
    assert (
        cu.Scene(settings=cu.RenderSettings(lighting="paper")).billboard_shading
        == cu.BillboardShading()
    )


def test_cli_renders_a_billboard_scene_file(tmp_path: Path, nimbus) -> None:
    path = cu.Scene(
        [nimbus],
        sun=SUN,
        billboard_shading=SHADING,
        camera=CAMERA,
        settings=cu.RenderSettings(lighting="paper"),
    ).save(tmp_path / "sky.json")
    out = tmp_path / "sky.exr"
    assert main(["render", str(path), "-o", str(out), "--backend", "cpu", "--size", "32x24"]) == 0
    expect = cu.render(cu.load_scene(path), CAMERA, 32, 24, backend="cpu")
    np.testing.assert_allclose(read_image(out)[..., :3], expect[..., :3], atol=1e-6)
