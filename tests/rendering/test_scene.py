"""Scene description: validation of Camera, Sky, RenderSettings, Scene and the JSON round trip;
scene files that are missing, not regular files (a FIFO), or hold unknown keys or strings for
numbers are refused, and so are strings and non-bools for parameters, naming them."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu


def two_clouds() -> list[cu.Cloud]:
    a = cu.Cloud(np.array([[0, 2, 0], [1.5, 2.5, 0]], np.float32), np.array([2.0, 1.5], np.float32))
    rot = np.array([[[0, -1, 0], [1, 0, 0], [0, 0, 1]]], np.float32)
    b = cu.Cloud(
        np.array([[10, 3, 5]], np.float32),
        np.array([[3.0, 1.0, 2.0]], np.float32),
        rotations=rot,
        model="metaball",
        phi=0.7,
        params={"generator": "test", "sigma": np.float32(1.5), "shape": (1, 2)},
    )
    return [a, b]


# --- Camera -----------------------------------------------------------------------------------
def test_camera_basis_is_orthonormal_and_right_handed() -> None:
    cam = cu.Camera(position=(0, 3, -40), target=(0, 3, 0))
    f, r, u = cam.basis()
    np.testing.assert_allclose(f, [0, 0, 1], atol=1e-7)
    # Looking along +z with +y up, right is -x in a right-handed frame (r = f × up).
    np.testing.assert_allclose(r, [-1, 0, 0], atol=1e-7)
    np.testing.assert_allclose(u, [0, 1, 0], atol=1e-7)


def test_camera_rays_follow_the_contract() -> None:
    cam = cu.Camera(position=(0, 0, 0), target=(0, 0, 1), fov=60)
    d = cam.ray_directions(4, 2)
    assert d.shape == (2, 4, 3) and d.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1, atol=1e-6)
    # Top rows look up, left columns look towards +x (r = -x).
    assert (d[0, :, 1] > 0).all() and (d[1, :, 1] < 0).all()
    assert d[0, 0, 0] > 0 > d[0, -1, 0]
    # Vertical fov: the ray through the top edge of a 1-pixel-high column makes fov/2 with f.
    th = math.tan(math.radians(30))
    tall = cam.ray_directions(1, 1000)
    assert math.isclose(tall[0, 0, 1] / tall[0, 0, 2], th * (1 - 1 / 1000), rel_tol=1e-5)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"position": (math.nan, 0, 0), "target": (0, 0, 1)}, "camera.position"),
        ({"position": (0, 0, 0), "target": (0, 0, math.inf)}, "camera.target"),
        ({"position": (1, 2, 3), "target": (1, 2, 3)}, "differ"),
        ({"position": (0, 0, 0), "target": (0, 5, 0)}, "parallel"),
        ({"position": (0, 0, 0), "target": (0, 0, 1), "up": (0, 0, 0)}, "camera.up"),
        ({"position": (0, 0, 0), "target": (0, 0, 1), "fov": 0}, "camera.fov"),
        ({"position": (0, 0, 0), "target": (0, 0, 1), "fov": 180}, "camera.fov"),
    ],
)
def test_camera_rejects_bad_input(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        cu.Camera(**kwargs)


def test_camera_rejects_non_numbers() -> None:
    with pytest.raises(TypeError, match="camera.position"):
        cu.Camera(position="abc", target=(0, 0, 1))


# --- Sky, settings ------------------------------------------------------------------------------
def test_sky_presets_and_reference() -> None:
    day, dusk = cu.Sky(), cu.Sky.sunset()
    sun = cu.Sun(direction=(0, 0.1, 1))
    up = np.array([[0, 1, 0]], np.float32)
    horizon = np.array([[1, 0, 0]], np.float32)
    np.testing.assert_allclose(day.colour(up, sun)[0], day.zenith, rtol=1e-6)
    np.testing.assert_allclose(day.colour(horizon, sun)[0], day.horizon, rtol=1e-6)
    assert day.zenith[2] > day.zenith[0]  # blue daylight
    assert dusk.horizon[0] > dusk.horizon[2]  # orange sunset horizon
    # Looking at the sun adds the disc on top of the base.
    at_sun = dusk.colour(np.array([sun.direction], np.float32), sun)[0]
    assert (at_sun > np.asarray(dusk.horizon) + 1).all()
    with pytest.raises(ValueError, match="sky.zenith"):
        cu.Sky(zenith=(-1, 0, 0))
    with pytest.raises(ValueError, match="sky.sun_disc_radius"):
        cu.Sky(sun_disc_radius=0)


@pytest.mark.parametrize(
    ("kwargs", "exc", "message"),
    [
        ({"kappa": 1.5}, ValueError, "settings.kappa"),
        ({"absorption": -1}, ValueError, "settings.absorption"),
        ({"step_min": 0.5, "step_max": 0.1}, ValueError, "settings.step_max"),
        ({"hg_g": 1.0}, ValueError, "settings.hg_g"),
        ({"max_steps": 0}, ValueError, "settings.max_steps"),
        ({"max_candidates": 10_000}, ValueError, "settings.max_candidates"),
        ({"march": "fast"}, ValueError, "settings.march"),
        ({"exact_noise": "yes"}, TypeError, "settings.exact_noise"),
        ({"max_steps": 2.5}, TypeError, "settings.max_steps"),
        ({"frequency": math.nan}, ValueError, "settings.frequency"),
        ({"light_method": "fast"}, ValueError, "settings.light_method"),
        ({"light_step": 0}, ValueError, "settings.light_step"),
    ],
)
def test_settings_reject_bad_input(kwargs: dict, exc: type, message: str) -> None:
    with pytest.raises(exc, match=message):
        cu.RenderSettings(**kwargs)


def test_lod_step_follows_the_paper_and_clamps() -> None:
    s = cu.RenderSettings(lod_a=0.5, lod_delta=0.01, step_min=0.05, step_max=0.4, lighting="paper")
    assert s.step_for(0) == 0.4  # 0.5 clamped
    assert math.isclose(s.step_for(50), 0.5 * math.exp(-0.5))
    assert s.step_for(1e4) == 0.05
    assert s.replace(fixed_step=0.1).step_for(1e4) == 0.1


# --- Scene and JSON -----------------------------------------------------------------------------
def test_scene_round_trips_through_json(tmp_path: Path) -> None:
    scene = cu.Scene(
        clouds=two_clouds(),
        sun=cu.Sun(direction=(0.2, 0.3, 1), colour=(1, 0.6, 0.3), intensity=2),
        sky=cu.Sky.sunset(),
        noise=cu.Noise(seed=2**63 + 5, size=32),
        settings=cu.RenderSettings(march="union", kappa=0.3, max_steps=500, lighting="paper"),
        camera=cu.Camera(position=(0, 3, -40), target=(0, 3, 0), fov=40),
    )
    path = scene.save(tmp_path / "s.json")
    back = cu.load_scene(path)
    assert back.sun == scene.sun and back.sky == scene.sky and back.settings == scene.settings
    assert back.camera == scene.camera and back.noise == scene.noise
    assert back.noise.seed == 2**63 + 5
    assert len(back.clouds) == 2
    for a, b in zip(scene.clouds, back.clouds, strict=True):
        np.testing.assert_array_equal(a.centres, b.centres)
        np.testing.assert_array_equal(a.radii, b.radii)
        np.testing.assert_array_equal(a.rotations, b.rotations)
        assert (a.model, a.kappa, a.phi) == (b.model, b.kappa, b.phi)
    assert back.clouds[1].params["sigma"] == 1.5
    # Only the final file is left behind (atomic write through a temporary).
    assert [p.name for p in tmp_path.iterdir()] == ["s.json"]


def test_load_scene_errors(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        cu.load_scene(bad)
    good = cu.Scene(clouds=two_clouds(), settings=cu.RenderSettings(lighting="paper")).to_dict()
    for key in ("clouds", "sun", "settings"):
        data = dict(good)
        del data[key]
        bad.write_text(json.dumps(data))
        with pytest.raises(ValueError, match=f"missing field.*{key}"):
            cu.load_scene(bad)
    data = json.loads(json.dumps(good))
    del data["clouds"][0]["radii"]
    bad.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"clouds\[0\].*radii"):
        cu.load_scene(bad)
    data = json.loads(json.dumps(good))
    data["settings"]["warp_speed"] = 9
    bad.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="warp_speed"):
        cu.load_scene(bad)
    data = json.loads(json.dumps(good))
    data["settings"]["march"] = "fast"
    bad.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="settings.march"):
        cu.load_scene(bad)
    bad.write_text("[1, 2]")
    with pytest.raises(ValueError, match="JSON object"):
        cu.load_scene(bad)
    with pytest.raises(OSError, match="cannot read"):
        cu.load_scene(tmp_path / "missing.json")


def test_save_to_unwritable_place_leaves_nothing(tmp_path: Path) -> None:
    scene = cu.Scene(clouds=two_clouds(), settings=cu.RenderSettings(lighting="paper"))
    with pytest.raises(OSError):
        scene.save(tmp_path / "no" / "such" / "folder" / "s.json")
    target = tmp_path / "dir.json"
    target.mkdir()  # a folder where the file should go: os.replace fails
    with pytest.raises(OSError):
        scene.save(target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.json"]


def test_scene_validation() -> None:
    with pytest.raises(TypeError, match=r"scene.clouds\[0\]"):
        cu.Scene(clouds=[np.zeros((3, 3))], settings=cu.RenderSettings(lighting="paper"))
    with pytest.raises(TypeError, match="scene.sun"):
        cu.Scene(sun=(0, 1, 0), settings=cu.RenderSettings(lighting="paper"))
    c = two_clouds()[0]
    from cumuli.scene import MAX_DRAWABLES

    # A field of particle clouds holds thousands; the GL marcher still draws at most 64 2018
    # clouds per pass (MarcherGL.check).
    with pytest.raises(ValueError, match="at most"):
        cu.Scene(clouds=[c] * (MAX_DRAWABLES + 1), settings=cu.RenderSettings(lighting="paper"))
    scene = cu.Scene(clouds=[c], settings=cu.RenderSettings(lighting="paper"))
    cam = scene.default_camera()
    lo, hi = scene.bounds()
    # The default camera looks at the clouds' centre.
    np.testing.assert_allclose(cam.target, (lo + hi) / 2, rtol=1e-6)
    assert scene.replace(sky=cu.Sky.sunset()).sky == cu.Sky.sunset()


def test_render_contract_is_where_the_code_cites_it() -> None:
    # Sources, shaders and docs cite RENDER_CONTRACT.md for the exact formulas: it must exist at
    # the repository root and hold the sections they refer to.
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    text = (root / "RENDER_CONTRACT.md").read_text(encoding="utf-8")
    for part in (
        "## Camera",
        "## Candidates",
        "## Marching",
        "## Density",
        "Sky",
        "## Light grids",
    ):
        assert part in text
    for formula in ("t + Δ/2", "max(t_u, t_in,k)", "exp(−φ · ρ · Δ / Δ_ref)", "alpha = 1 − T"):
        assert formula in text
    cited = [
        p
        for p in (*root.glob("shaders/**/*.glsl"), *root.glob("cpp/**/*.[ch]pp"))
        if "RENDER_CONTRACT" in p.read_text(encoding="utf-8")
    ]
    assert len(cited) >= 3


def _scene() -> cu.Scene:
    return cu.Scene(
        [cu.gaussian_cumulus(n=6, seed=1)],
        noise=cu.Noise(seed=2, size=16),
        settings=cu.RenderSettings(lighting="paper"),
    )


# --- scene files ------------------------------------------------------------------------------
def test_load_scene_of_a_missing_file_raises_file_not_found(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="nope.json"):
        cu.load_scene(tmp_path / "nope.json")


_FIFO_SCRIPT = """
import sys
import cumuli as cu
try:
    cu.load_scene(sys.argv[1])
except OSError as exc:
    print("REFUSED", type(exc).__name__, exc)
"""


def test_load_scene_and_cumuli_render_refuse_a_fifo_instead_of_hanging(tmp_path: Path) -> None:
    fifo = tmp_path / "scene.json"
    os.mkfifo(fifo)
    script = tmp_path / "load.py"
    script.write_text(_FIFO_SCRIPT)
    try:
        done = subprocess.run(
            [sys.executable, str(script), str(fifo)], capture_output=True, text=True, timeout=60
        )
        cli = subprocess.run(
            [sys.executable, "-m", "cumuli", "render", str(fifo), "-o", str(tmp_path / "x.png")],
            capture_output=True, text=True, timeout=60,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        pytest.fail("reading a FIFO hung")
    assert "REFUSED OSError" in done.stdout and "regular file" in done.stdout, done.stderr
    assert cli.returncode == 1 and "regular file" in cli.stderr


@pytest.mark.parametrize(
    ("where", "edit"),
    [
        ("scene", lambda d: d.update(colour=1)),
        ("scene.clouds[0]", lambda d: d["clouds"][0].update(colour=1)),
        ("scene.noise", lambda d: d["noise"].update(octaves=3)),
        ("scene.settings", lambda d: d["settings"].update(colour=1)),
        ("scene.sun", lambda d: d["sun"].update(size=1)),
    ],
)
def test_unknown_keys_in_a_scene_file_are_refused(tmp_path: Path, where: str, edit) -> None:
    data = _scene().to_dict()
    edit(data)
    path = tmp_path / "s.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="unknown field") as err:
        cu.load_scene(path)
    assert where in str(err.value)


def test_strings_do_not_pass_as_numbers_in_scene_files(tmp_path: Path) -> None:
    data = _scene().to_dict()
    data["clouds"][0]["kappa"] = "0.9"
    path = tmp_path / "s.json"
    path.write_text(json.dumps(data))
    with pytest.raises(TypeError, match="kappa"):
        cu.load_scene(path)


# --- strings, bools ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: cu.Sun(direction="123"), "sun.direction"),
        (lambda: cu.Sun(intensity="2"), "sun.intensity"),
        (lambda: cu.Camera((0, 0, -5), (0, 0, 0), fov="45"), "camera.fov"),
        (lambda: cu.Camera("012", (0, 0, 0)), "camera.position"),
        (lambda: cu.RenderSettings(hg_g="0.5", lighting="paper"), "settings.hg_g"),
        (lambda: cu.gaussian_cumulus(centre="000"), "centre"),
        (lambda: cu.gaussian_cumulus(hollow=float("nan")), "hollow"),
        (lambda: cu.gaussian_cumulus(remove_contained="no"), "remove_contained"),
        (lambda: cu.mesh_cloud(cu.meshes.icosphere(0), rotate=None), "rotate"),
        (lambda: cu.ellipsoids_from_mesh(*cu.meshes.icosphere(0), rotate=2), "rotate"),
    ],
)
def test_strings_and_non_bools_are_refused_naming_the_parameter(make, name: str) -> None:
    with pytest.raises(TypeError, match=name):
        make()


def test_render_settings_refuse_the_fbm_that_noise_refuses() -> None:
    with pytest.raises(ValueError, match="gain"):
        cu.Noise(seed=1).fbm(np.zeros((1, 3)), octaves=16, gain=1e3)
    with pytest.raises(ValueError, match="settings.*gain"):
        cu.RenderSettings(gain=1e3, octaves=16, lighting="paper")
    with pytest.raises(ValueError, match="settings.*frequency"):
        cu.RenderSettings(frequency=1e30, lacunarity=10.0, octaves=16, lighting="paper")
