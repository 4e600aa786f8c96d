"""Bad input found by a second round of hostile inputs: each refused up front with an error
that names the file, the field or the parameter — and the same rule held by every sibling
loader, settings class and kind."""

from __future__ import annotations

import copy
import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.anim import cluster
from cumuli.anim.weather import Schedule, load_weather
from cumuli.gl import GLContext
from cumuli.model import seedbox_presets as presets

BOX = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))


# --- corrupt archives: every loader wraps what zipfile and zlib raise ---------------------------
def _save(loader: str, path: Path) -> None:
    cloud = cu.gaussian_cumulus(n=6, seed=1)
    if loader == "particles":
        cu.particle_cumulus(n_particles=20, seed=1).save(path)
    elif loader == "cloud":
        cloud.save(path)
    elif loader == "grid":
        cu.light_grid(cloud, cu.Sun(), cu.Noise(seed=1, size=8), resolution=4).save(path)
    elif loader == "billboards":
        cu.seed_box_cloud(presets.cirrus(), seed=1).save(path)
    else:
        cu.weather_presets.three_layers(seed=1).save(path)


LOADERS = {
    "particles": cu.load_particles,
    "cloud": cu.load_cloud,
    "grid": cu.load_light_grid,
    "billboards": cu.load_billboards,
    "weather": load_weather,
}


def _headers(data: bytearray, offset: int, value: int) -> None:
    """Set a 16-bit field of every local (PK\\3\\4) and central (PK\\1\\2) zip header."""
    for sig, field in ((b"PK\x03\x04", offset), (b"PK\x01\x02", offset + 2)):
        start = 0
        while (at := data.find(sig, start)) >= 0:
            struct.pack_into("<H", data, at + field, value)
            start = at + 4


def _garble_streams(data: bytearray) -> None:
    """Overwrite the start of every member's deflate stream (a zlib.error or a CRC error)."""
    start = 0
    while (at := data.find(b"PK\x03\x04", start)) >= 0:
        name_len, extra_len = struct.unpack_from("<HH", data, at + 26)
        body = at + 30 + name_len + extra_len
        data[body : body + 8] = b"\xff" * 8
        start = at + 4


@pytest.mark.parametrize("corrupt", ["method", "encrypted", "stream"])
@pytest.mark.parametrize("loader", sorted(LOADERS))
def test_corrupt_archives_raise_value_error_naming_the_file(
    tmp_path: Path, loader: str, corrupt: str
) -> None:
    path = tmp_path / f"bad-{loader}-{corrupt}.npz"
    _save(loader, path)
    data = bytearray(path.read_bytes())
    if corrupt == "method":
        _headers(data, 8, 97)  # an unknown compression method: NotImplementedError
    elif corrupt == "encrypted":
        _headers(data, 6, 1)  # the encryption flag: RuntimeError
    else:
        _garble_streams(data)  # zlib.error
    path.write_bytes(bytes(data))
    with pytest.raises(ValueError, match=path.name):
        LOADERS[loader](path)


# --- fBm overflow: every fBm refuses what Noise.fbm refuses -------------------------------------
def test_particle_fill_refuses_the_fbm_that_noise_fbm_refuses() -> None:
    cloud, noise = cu.gaussian_cumulus(n=4, seed=1), cu.Noise(seed=1, size=16)
    with pytest.raises(ValueError, match="gain") as by_noise:
        noise.fbm(np.zeros((1, 3)), octaves=16, gain=1e3)
    with pytest.raises(ValueError, match="gain") as by_fill:
        cu.particle_fill(cloud, 50, noise, gain=1e3, octaves=16)
    assert str(by_fill.value) == str(by_noise.value)
    with pytest.raises(ValueError, match="lacunarity"):
        cu.particle_fill(cloud, 50, noise, lacunarity=1e3, octaves=16)
    with pytest.raises(ValueError, match="gain"):  # the sibling: a cloud's density
        cloud.density(np.zeros((1, 3)), noise, octaves=16, gain=1e3)
    filled = cu.particle_fill(cloud, 50, noise)  # the defaults still fill with varied tau
    assert filled.tau.std() > 0


# --- float32 overflow refused at construction, naming the field ---------------------------------
@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: cu.SpriteSettings(ambient=(1e39, 0, 0)), "ambient"),
        (lambda: cu.SpriteSettings(ambient=(1e13, 0, 0)), "ambient"),
        (lambda: cu.BillboardShading(ambient=(1e39, 0, 0)), "ambient"),
        (lambda: cu.BillboardShading(k_amb=1e39), "k_amb"),
        (lambda: cu.Solid((0, 0, 0), 1.0, colour=(1e39, 0, 0)), "colour"),
        (lambda: cu.Solid((0, 0, 0), 1.0, ambient=(0, 1e13, 0)), "ambient"),
        (lambda: cu.VolumeCloud(np.ones((2, 2, 2)), BOX, sigma_t=1e38), "sigma_t"),
        (lambda: cu.VolumeCloud(np.full((2, 2, 2), 1e30), BOX, sigma_t=1e3), "sigma_t"),
        (lambda: cu.CloudDeck(sigma_t=1e38), "sigma_t"),
    ],
)
def test_float32_overflow_is_refused_when_made(make, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        make()


def test_the_largest_accepted_values_still_make_objects() -> None:
    cu.SpriteSettings(ambient=(1e12, 0, 0))
    cu.Solid((0, 0, 0), 1.0, colour=(1e12, 1, 1))
    cu.VolumeCloud(np.ones((2, 2, 2)), BOX, sigma_t=1e12)


# --- what the GPU is given is checked, not only what the API made ------------------------------
def _grid_flipped_to_nan(cloud: cu.Cloud) -> cu.LightGrid:
    lo, hi = cloud.layer_box()
    grid = cu.LightGrid(np.full((6, 6, 6), 0.5, np.float32), (tuple(lo), tuple(hi)))
    grid.setflags(write=True)  # what a hostile caller can do to a read-only array
    grid[2:4, 2:4, 2:4] = np.nan
    return grid


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_nan_in_a_light_grid_is_refused_by_both_backends(backend: str) -> None:
    cloud = cu.gaussian_cumulus(n=6, seed=1)
    # A LightGrid is the paper mode's light (the physical mode's is a PhysicalLight).
    paper = cu.RenderSettings(lighting="paper")
    scene = cu.Scene([cloud], noise=cu.Noise(seed=2, size=16), settings=paper)
    lit = cu.prepare_light(scene, lights=[_grid_flipped_to_nan(cloud)])
    with pytest.raises(ValueError, match="light grid contains NaN"):
        cu.render(lit, scene.default_camera(), 16, 12, backend=backend)


def test_the_gl_packing_refuses_what_the_cpu_twin_refuses() -> None:
    from cumuli.rendering.marcher import pack_clouds

    cloud = cu.gaussian_cumulus(n=6, seed=1)
    with pytest.raises(ValueError, match=r"clouds\[0\].light grid contains NaN"):
        pack_clouds([cloud], [_grid_flipped_to_nan(cloud)], None)
    lo, hi = cloud.layer_box()
    big = cu.LightGrid(np.ones((2, 2, 2), np.float32), (tuple(lo), tuple(hi)))
    big.setflags(write=True)
    big[0, 0, 0] = 1e30
    with pytest.raises(ValueError, match="beyond"):
        pack_clouds([cloud], [big], None)


# --- billboard dicts: unknown keys, fractional and huge integers --------------------------------
@pytest.fixture(scope="module")
def billboard_dicts() -> tuple[dict, dict]:
    cloud = cu.seed_box_cloud(presets.cirrus(), seed=1)
    field = cu.BillboardField([cloud], [[0, 0, 0], [5, 0, 0]])
    return cloud.to_dict(), field.to_dict()


@pytest.mark.parametrize(
    ("which", "key", "value", "match"),
    [
        ("cloud", "bogus", 1, "unknown keys"),
        ("cloud", "texture", 1.7, "integers"),
        ("cloud", "texture", 2**40, "outside"),
        ("cloud", "texture", 2**70, "numbers"),
        ("cloud", "box_level", 2**40, "outside"),
        ("field", "bogus", 1, "unknown keys"),
        ("field", "variant", 1.7, "integers"),
        ("field", "state", 2**40, "outside"),
        ("field", "ids", 2**70, "int64"),
    ],
)
def test_billboard_dicts_refuse_unknown_keys_and_bad_integers(
    billboard_dicts, which: str, key: str, value, match: str
) -> None:
    data = copy.deepcopy(billboard_dicts[0] if which == "cloud" else billboard_dicts[1])
    if key == "bogus":
        data[key] = value
    else:
        data[key] = [*data[key][:-1], value]
    cls = cu.BillboardCloud if which == "cloud" else cu.BillboardField
    with pytest.raises(ValueError, match=match) as err:
        cls.from_dict(data, "scene.clouds[3]")
    assert "scene.clouds[3]" in str(err.value)


def test_the_constructor_refuses_wrapping_integers() -> None:
    cloud = cu.seed_box_cloud(presets.cirrus(), seed=1)
    texture = np.array(cloud.texture, np.int64)
    texture[0] = 2**32  # as int32 it would wrap to 0, a valid index
    fields = {k: getattr(cloud, k) for k in ("boxes", "box_level", "box_seed", "box_direction",
                                             "centres", "sizes", "box", "rotation")}  # fmt: skip
    with pytest.raises(ValueError, match="texture holds integers outside"):
        cu.BillboardCloud(**fields, texture=texture, atlas=cloud.atlas)


# --- unclear errors made clear ------------------------------------------------------------------
def _scene_text_with_long_int(field: str) -> str:
    scene = cu.Scene([cu.gaussian_cumulus(n=6, seed=1)], noise=cu.Noise(seed=2, size=16))
    data = scene.to_dict()
    data["noise"][field] = 0
    return json.dumps(data).replace(f'"{field}": 0', f'"{field}": {"7" * 5000}', 1)


@pytest.mark.parametrize("field", ["seed", "size"])
def test_a_5000_digit_integer_names_the_file_and_the_field(tmp_path: Path, field: str) -> None:
    path = tmp_path / "long.json"
    path.write_text(_scene_text_with_long_int(field))
    with pytest.raises((ValueError, TypeError)) as err:
        cu.load_scene(path)
    assert str(path) in str(err.value) and field in str(err.value)
    assert "4300" not in str(err.value)  # not Python's int-limit message


def test_a_5000_digit_integer_names_the_file_from_the_cli(tmp_path: Path) -> None:
    path = tmp_path / "long.json"
    path.write_text(_scene_text_with_long_int("seed"))
    done = subprocess.run(
        [sys.executable, "-m", "cumuli", "render", str(path), "-o", str(tmp_path / "x.png"),
         "--size", "8x8", "--backend", "cpu"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "long.json" in done.stderr and "seed" in done.stderr
    assert not (tmp_path / "x.png").exists()


def test_long_integers_in_every_loader_name_the_file(tmp_path: Path) -> None:
    path = tmp_path / "long.json"
    cu.particle_cumulus(n_particles=5, seed=1).save(path)
    data = json.loads(path.read_text())
    text = json.dumps(data).replace('"version": 1', '"version": ' + "9" * 5000, 1)
    path.write_text(text)
    with pytest.raises(ValueError, match="long.json"):
        cu.load_particles(path)


def test_load_weather_blames_threads_not_the_file(tmp_path: Path) -> None:
    path = tmp_path / "w.npz"
    cu.weather_presets.three_layers(seed=1).save(path)
    with pytest.raises(TypeError, match="threads") as err:
        load_weather(path, threads="abc")
    assert "w.npz" not in str(err.value)


def test_a_schedule_too_long_says_how_long_it_may_be() -> None:
    keys = [(float(t), 0.5) for t in range(100_001)]
    with pytest.raises(ValueError, match="100001 keyframes.*MAX_KEYFRAMES"):
        Schedule(keys)
    assert Schedule(keys[:100_000])(5.0) == 0.5
    assert Schedule(np.array([(0.0, 0.2), (1.0, 0.4)]))(0.5) == pytest.approx(0.3)
    with pytest.raises(TypeError, match="got dict"):
        Schedule({0.0: 0.5})


def test_wrong_objects_are_named_as_what_they_should_be() -> None:
    with pytest.raises(TypeError, match="lighting must be a cumuli.VolumeLighting"):
        cu.VolumeCloud.from_frame("x", 0)
    with pytest.raises(TypeError, match="renderer must be a cumuli.Renderer"):
        cu.ImpostorCache(renderer="abc")
    cloud = cu.particle_cumulus(n_particles=10, seed=1)
    with pytest.raises(TypeError, match="context must be a cumuli.gl.GLContext"):
        cu.particle_light(cloud, cu.Sun(), context="abc")  # the CPU path checks it too
    assert cu.particle_light(cloud, cu.Sun(), context=None) is not None
    from cumuli.light.particles import phase_values

    with pytest.raises(TypeError, match="context must be"):  # the siblings with a CPU path
        phase_values("hg", [0.1], context="abc")
    vol, camera = np.ones((2, 2, 2), np.float32), cu.Camera((0.5, 0.5, -3), (0.5, 0.5, 0.5))
    with pytest.raises(TypeError, match="context must be"):
        cu.render_volume(vol, np.ones((2, 2, 2, 4)), BOX, camera, 4, 4, backend="cpu",
                         context="abc")  # fmt: skip


@pytest.mark.parametrize(
    ("require", "error", "match"),
    [("430", TypeError, "as an int"), (990, ValueError, "one of the OpenGL versions"),
     (True, TypeError, "as an int")],
)  # fmt: skip
def test_gl_context_require_is_checked_before_egl(require, error, match: str) -> None:
    with pytest.raises(error, match=match) as err:
        GLContext(require=require)
    assert "EGL" not in str(err.value)


# --- sweep checks the extension up front, as render_frames does ---------------------------------
def test_sweep_refuses_the_extension_before_any_task(tmp_path: Path, monkeypatch) -> None:
    def never(*args, **kwargs):
        raise AssertionError("a task ran")

    monkeypatch.setattr(cluster, "run", never)
    scene_fn = lambda seed: cu.Scene([cu.gaussian_cumulus(n=4, seed=seed)])  # noqa: E731
    with pytest.raises(ValueError, match="extension"):
        cu.sweep(scene_fn, [{"seed": 1}, {"seed": 2}], out_dir=tmp_path / "o", pattern="{}.jpg")
    assert cluster.MAX_SWEEP == cu.frames.MAX_FRAMES
    with pytest.raises(ValueError, match="MAX_SWEEP"):
        cu.sweep(scene_fn, [{"seed": 1}] * 100_001)
    with pytest.raises(ValueError, match="extension"):  # the same message as render_frames
        cu.render_frames(scene_fn(1), [cu.Camera((0, 0, -9), (0, 0, 0))], tmp_path / "f", 8, 8,
                         pattern="{}.jpg")  # fmt: skip
