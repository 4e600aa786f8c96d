"""Harris 2002 particle clouds as a drawable kind: through every stage
(model, light step, GL drawer and its CPU twin), one pass for a scene of particle clouds, mixed
scenes through the compositor (parity, per-pixel order), scene files, public names, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.light.prepare import clear_memo
from cumuli.rendering.compositor import plan
from cumuli.testing import assert_image_close, only

W, H = 64, 48
SUN = cu.Sun(direction=(0.4, 0.8, 0.3), intensity=2.0)
BLACK = cu.Sky(zenith=(0, 0, 0), horizon=(0, 0, 0), ground=(0, 0, 0), sun_disc_intensity=0)
CAMERA = cu.Camera(position=(0.0, 3.0, -70.0), target=(0.0, 3.0, 0.0), fov=35)
SETTINGS = cu.RenderSettings(exact_noise=True, absorption=3.0, lighting="paper")


def puff(centre: tuple[float, float, float], seed: int, n: int = 250) -> cu.ParticleCloud:
    return cu.particle_cumulus(centre, n, seed=seed, radius=(2.0, 3.5))


def trio(sky: cu.Sky = BLACK) -> cu.Scene:
    clouds = [puff((-8, 0, 0), 1), puff((6, 2, 25), 2), puff((14, -1, -10), 3)]
    return cu.Scene(
        clouds,
        sun=SUN,
        sky=sky,
        sprite_settings=cu.SpriteSettings(ambient=(0.1,) * 3),
        settings=cu.RenderSettings(lighting="paper"),
    )


def test_particle_cloud_is_wired_through_every_stage() -> None:
    pc = puff((0, 0, 0), 1)
    kind = cu.registry.get("particles")
    assert kind.model is cu.ParticleCloud and pc.kind == "particles"
    assert kind.light is not None and kind.gl_drawer is not None and kind.cpu_drawer is not None
    assert kind.groups and kind.caster is not None and kind.medium is None
    lo, hi = pc.layer_box()
    np.testing.assert_array_equal(lo, pc.bounds()[0])
    c, r = pc.sphere
    # The box holds every splat: centres ± radii.
    assert (pc.centres - pc.radii[:, None] >= lo - 1e-5).all()
    assert (pc.centres + pc.radii[:, None] <= hi + 1e-5).all()
    back = cu.ParticleCloud.from_dict(pc.to_dict())
    for name in ("centres", "radii", "tau", "albedo"):
        np.testing.assert_array_equal(getattr(back, name), getattr(pc, name))


def test_the_light_step_lights_particles_for_the_sun_and_extra_lights() -> None:
    clear_memo()
    extra = (cu.Sun((-0.5, 0.6, 0.2), (1.0, 0.5, 0.6), 0.7),)
    pc = puff((0, 0, 0), 4)
    scene = cu.Scene([pc], sun=SUN, lights=extra, settings=cu.RenderSettings(lighting="paper"))
    lit = cu.prepare_light(scene)
    light = lit.lights[0]
    assert isinstance(light, cu.ParticleLight) and light.light.shape == (pc.n, 2)
    ref = cu.particle_light(pc, [SUN, *extra], scene.sprite_settings)
    np.testing.assert_array_equal(light.light, ref.light)
    # Memoised by content: again, and for the cloud moved by the wind, the same light object.
    assert cu.prepare_light(scene).lights[0] is light
    moved = scene.replace(clouds=[pc.translated((13.7, 0.3, -4.1))])
    assert cu.prepare_light(moved).lights[0] is light
    # Colours are applied at render: a new colour keeps the light; a new direction does not.
    recoloured = scene.replace(sun=cu.Sun(SUN.direction, (1, 0.6, 0.3), 3.0))
    assert cu.prepare_light(recoloured).lights[0] is light
    turned = scene.replace(sun=cu.Sun((0.0, 1.0, 0.0)))
    assert cu.prepare_light(turned).lights[0] is not light
    other = scene.replace(sprite_settings=cu.SpriteSettings(light_resolution=64))
    assert cu.prepare_light(other).lights[0] is not light
    # Given light: kept when current, recomputed when made for other lights.
    assert cu.prepare_light(scene, lights=[ref]).lights[0] is ref
    stale = cu.particle_light(pc, [SUN], scene.sprite_settings)
    assert cu.prepare_light(scene, lights=[stale]).lights[0].n_lights == 2
    # Several clouds share one C++ call and give the same values one by one.
    # (Their own light: in the scene the other cloud's shadow then darkens the sun's column.)
    two = cu.prepare_light(
        cu.Scene(
            [pc, puff((20, 0, 0), 5)],
            sun=SUN,
            lights=extra,
            settings=cu.RenderSettings(lighting="paper"),
        )
    )
    np.testing.assert_array_equal((two.lights[0].unshadowed or two.lights[0]).light, ref.light)
    assert not pc.params.get("light")  # nothing stored on the cloud


@pytest.mark.gl
def test_a_scene_of_particle_clouds_is_one_pass_gl_and_cpu_agree() -> None:
    scene = trio(cu.Sky())
    assert plan(scene) == [("particles", [0, 1, 2])]
    lit = cu.prepare_light(scene)
    gl = cu.render(lit, CAMERA, W, H)
    cpu = cu.render(lit, CAMERA, W, H, backend="cpu")
    # The sprite contract's parity (RENDER_CONTRACT "Sprites").
    assert_image_close(gl, cpu, **only(channel_mean_abs=1e-5, max_abs=1e-4))
    assert (cpu[..., 3] > 0.5).sum() > 50
    with cu.Renderer() as r:
        direct = r.drawer("particles").draw(lit, [0, 1, 2], CAMERA, W, H, True)
        np.testing.assert_array_equal(r.render(lit, CAMERA, W, H), direct)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_clouds_are_splatted_back_to_front(backend: str) -> None:
    # Two overlapping clouds under a black sky: the one-pass image is near over far, whichever
    # side the camera looks from (clouds sorted by the distance to their sphere centres).
    # Each cloud alone is drawn with the light it has in the scene (they shade each other).
    near, far = puff((0, 0, -10), 6), puff((4, 1, 12), 7)
    scene = cu.prepare_light(
        cu.Scene([far, near], sun=SUN, sky=BLACK, settings=cu.RenderSettings(lighting="paper"))
    )

    def alone(k: int, camera: cu.Camera) -> np.ndarray:
        layer = cu.LitScene(scene.scene.replace(clouds=[scene.scene.clouds[k]]), (scene.lights[k],))
        return cu.render(layer, camera, W, H, backend=backend)

    for camera, front in ((CAMERA, 1), (cu.Camera((0, 3, 90), (0, 3, 0), fov=35), 0)):
        both = cu.render(scene, camera, W, H, backend=backend).astype(np.float64)
        a, b = alone(front, camera), alone(1 - front, camera)
        expect = a[..., :3] + (1 - a[..., 3:]) * b[..., :3]
        np.testing.assert_allclose(both[..., :3], expect, atol=2e-5)
        overlap = (a[..., 3] > 0.3) & (b[..., 3] > 0.3)
        assert overlap.sum() > 10
        wrong = b[..., :3] + (1 - b[..., 3:]) * a[..., :3]
        assert np.abs(both[..., :3] - wrong)[overlap].max() > 1e-2


def mixed(sky: cu.Sky | None = None) -> cu.Scene:
    """A 2018 cumulus, a Gaussian-blob volume and a particle cloud, overlapping on screen."""
    pc = puff((6, 2, 20), 8)
    density, box = puff((-6, 0, 35), 9, n=120).to_volume(20)
    volume = cu.VolumeCloud(density=density, box=box, sigma_t=0.6, albedo=0.9, g=0.2)
    cumulus = cu.gaussian_cumulus(centre=(-4.0, 0.0, 0.0), seed=1)
    return cu.Scene(
        [cumulus, volume, pc], sun=SUN, sky=sky or cu.Sky(), noise=cu.Noise(seed=7, size=32),
        settings=SETTINGS,
    )  # fmt: skip


@pytest.mark.gl
def test_mixed_scene_gl_and_cpu_agree() -> None:
    scene = cu.prepare_light(mixed())
    assert plan(scene.scene) == [("cloud", [0]), ("volume", [1]), ("particles", [2])]
    gl = cu.render(scene, CAMERA, W, H)
    cpu = cu.render(scene, CAMERA, W, H, backend="cpu")
    assert np.isfinite(gl).all()
    assert_image_close(gl, cpu, **only(channel_mean_abs=1e-3))  # the render pass's tolerance
    alone = [
        cu.render(scene.scene.replace(clouds=[c]), CAMERA, W, H, backend="cpu")[..., 3]
        for c in scene.scene.clouds
    ]
    assert ((alone[0] > 0.05) & (alone[2] > 0.05)).sum() > 10  # they overlap on screen


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_mixed_scene_composites_by_the_over_operator(backend: str) -> None:
    # Black sky: each drawable alone renders its layer (C, 1 − T). The cumulus's box is entered
    # before the particles' wherever both are hit from this camera, so the composite is
    # cumulus over particles there.
    # Each layer is drawn with the light it has in the scene (the particles shade the cumulus).
    scene = mixed(BLACK)
    pair = cu.prepare_light(scene.replace(clouds=[scene.clouds[0], scene.clouds[2]]))
    both = cu.render(pair, CAMERA, W, H, backend=backend).astype(np.float64)
    layers = [
        cu.render(cu.LitScene(pair.scene.replace(clouds=[c]), (light,)), CAMERA, W, H,
                  backend=backend)
        for c, light in zip(pair.scene.clouds, pair.lights, strict=True)
    ]  # fmt: skip
    near, far = layers
    expect = near[..., :3] + (1 - near[..., 3:]) * far[..., :3]
    np.testing.assert_allclose(both[..., :3], expect, atol=2e-5)
    hidden = (near[..., 3] > 0.995) & (far[..., 3] > 0.3)
    assert hidden.sum() >= 3
    np.testing.assert_allclose(both[hidden], near[hidden], atol=1e-2)


def test_scene_files_carry_particles_solids_and_settings(tmp_path: Path) -> None:
    scene = mixed().replace(
        camera=CAMERA,
        lights=(cu.Sun((0, 1, 0), (1, 0.5, 0.5), 0.3),),
        solids=(cu.Solid((1, 2, 3), 1.5, (0.9, 0.1, 0.1)), cu.Solid((0, 0, 30), 0.5)),
        sprite_settings=cu.SpriteSettings.preset("skyworks"),
        impostor_settings=cu.ImpostorSettings(tolerance=0.5, exact=True, inside_factor=2),
    )
    back = cu.load_scene(scene.save(tmp_path / "harris.json"))
    assert back.to_dict() == scene.to_dict()
    assert back.kinds == ("cloud", "volume", "particles")
    for name in ("centres", "radii", "tau", "albedo"):
        np.testing.assert_array_equal(getattr(back.clouds[2], name), getattr(scene.clouds[2], name))
    assert back.solids == scene.solids and back.sprite_settings == scene.sprite_settings
    assert back.impostor_settings == scene.impostor_settings
    # Files without the new fields (written before them) still load, with the defaults.
    doc = scene.to_dict()
    for key in ("solids", "sprite_settings", "impostor_settings"):
        del doc[key]
    old = cu.Scene.from_dict(doc)
    assert old.solids == () and old.sprite_settings == cu.SpriteSettings()


def test_public_names() -> None:
    for name in (
        "ParticleCloud", "particle_cumulus", "particle_fill", "load_particles", "SpriteSettings",
        "particle_light", "skylight_lights", "ImpostorSettings", "ImpostorCache", "Solid",
        "ParticleLight", "ground_shadow",
    ):  # fmt: skip
        assert name in cu.__all__ and hasattr(cu, name), name


def test_bad_input_names_the_field(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="scene.solids"):
        cu.Scene(solids=[1], settings=cu.RenderSettings(lighting="paper"))
    with pytest.raises(ValueError, match="at most 16"):
        cu.Scene(
            solids=[cu.Solid((k, 0, 0)) for k in range(17)],
            settings=cu.RenderSettings(lighting="paper"),
        )
    with pytest.raises(TypeError, match="sprite_settings"):
        cu.Scene(sprite_settings={"phase": "hg"}, settings=cu.RenderSettings(lighting="paper"))
    with pytest.raises(TypeError, match="impostor_settings"):
        cu.Scene(impostor_settings=None, settings=cu.RenderSettings(lighting="paper"))
    with pytest.raises(ValueError, match="radius"):
        cu.Solid((0, 0, 0), -1.0)
    with pytest.raises(ValueError, match="colour"):
        cu.Solid((0, 0, 0), 1.0, (1, -1, 0))
    doc = trio().replace(solids=(cu.Solid((0, 0, 0)),)).to_dict()
    doc["solids"][0]["radius"] = "big"
    with pytest.raises(ValueError, match=r"scene.solids\[0\]"):
        cu.Scene.from_dict(doc)
    doc = trio().to_dict()
    doc["clouds"][1]["tau"] = {"dtype": "float32", "shape": [3], "base64": "!!"}
    with pytest.raises(ValueError, match=r"scene.clouds\[1\]"):
        cu.Scene.from_dict(doc)
    doc = trio().to_dict()
    doc["clouds"][0]["colour"] = [1, 2, 3]
    with pytest.raises(ValueError, match="unknown"):
        cu.Scene.from_dict(doc)
    doc = trio().to_dict()
    doc["impostor_settings"] = {"tolerance": 9.0}
    with pytest.raises(ValueError, match="tolerance"):
        cu.Scene.from_dict(doc)
    doc = trio().to_dict()
    doc["sprite_settings"] = {"phase": "mie"}
    with pytest.raises(ValueError, match="sprite_settings"):
        cu.Scene.from_dict(doc)
    # A failed render changes nothing and says what is wrong before any light pass.
    with pytest.raises(ValueError, match="width"):
        cu.render(trio(), CAMERA, 0, 10, backend="cpu")


def test_cumuli_demo_harris_renders_fig_13(tmp_path: Path) -> None:
    from cumuli import cli
    from cumuli.demo import harris_scene

    path = tmp_path / "fig13.exr"
    args = ["demo", "--harris", "-o", str(path), "--width", "48", "--height", "36"]
    assert cli.main([*args, "--backend", "cpu"]) == 0
    scene = harris_scene()
    assert scene.kinds == ("particles",) * 4 and len(scene.lights) == 1
    expect = cu.render(scene, scene.default_camera(), 48, 36, backend="cpu")
    expect[..., 3] = 1.0
    np.testing.assert_allclose(cu.read_image(path), expect, atol=1e-6)
    # Orange sun and pink light: the clouds' lit parts are warm, red above blue.
    cloud = expect[..., :3][cu.render(scene, scene.default_camera(), 48, 36, "cpu")[..., 3] > 0.5]
    assert cloud.size and (cloud[:, 0] > cloud[:, 2]).mean() > 0.8
