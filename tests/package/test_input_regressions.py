"""The smaller defects of issue 15, item 8: each one's regression test."""

from __future__ import annotations

import json
import math
import os
import struct
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.anim import frames as cframes


def _scene() -> cu.Scene:
    return cu.Scene([cu.gaussian_cumulus(n=6, seed=1)], noise=cu.Noise(seed=2, size=16))


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
        (lambda: cu.RenderSettings(hg_g="0.5"), "settings.hg_g"),
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
        cu.RenderSettings(gain=1e3, octaves=16)
    with pytest.raises(ValueError, match="settings.*frequency"):
        cu.RenderSettings(frequency=1e30, lacunarity=10.0, octaves=16)


# --- cloud files ------------------------------------------------------------------------------
def _npz_with(tmp_path: Path, name: str, patch) -> Path:
    path = tmp_path / name
    cu.gaussian_cumulus(n=6, seed=1).save(path)
    data = bytearray(path.read_bytes())
    patch(data)
    path.write_bytes(bytes(data))
    return path


def _set_all_headers(data: bytearray, offset_in_header: int, value: int, fmt: str) -> None:
    """Patch a field of every local (PK\\3\\4) and central (PK\\1\\2) zip header."""
    for sig, field in ((b"PK\x03\x04", offset_in_header), (b"PK\x01\x02", offset_in_header + 2)):
        start = 0
        while (at := data.find(sig, start)) >= 0:
            struct.pack_into(fmt, data, at + field, value)
            start = at + 4


@pytest.mark.parametrize(
    "corrupt",
    [
        "method",  # an unsupported compression method: zipfile raises NotImplementedError
        "encrypted",  # the encryption flag: zipfile raises RuntimeError (password required)
        "magic",  # a member that is not .npy: numpy raises a ValueError without the file name
    ],
)
@pytest.mark.parametrize("loader", ["cloud", "grid"])
def test_corrupt_npz_files_raise_value_error_naming_the_file(
    tmp_path: Path, corrupt: str, loader: str
) -> None:
    path = tmp_path / f"bad-{corrupt}.npz"
    if loader == "cloud":
        cu.gaussian_cumulus(n=6, seed=1).save(path)
    else:
        cu.light_grid(cu.gaussian_cumulus(n=6, seed=1), cu.Sun(), cu.Noise(seed=1, size=8),
                      resolution=4).save(path)  # fmt: skip
    data = bytearray(path.read_bytes())
    if corrupt == "method":
        _set_all_headers(data, 8, 97, "<H")  # compression method field
    elif corrupt == "encrypted":
        _set_all_headers(data, 6, 1, "<H")  # general-purpose flags: bit 0 = encrypted
    else:
        with zipfile.ZipFile(path, "w") as zf:
            for member in ("centres", "radii", "rotations", "meta", "values"):
                zf.writestr(member + ".npy", b"NOTNUMPY" + b"\0" * 120)
        data = bytearray(path.read_bytes())
    path.write_bytes(bytes(data))
    load = cu.load_cloud if loader == "cloud" else cu.load_light_grid
    with pytest.raises(ValueError, match=path.name):
        load(path)


# --- animation frames -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def anim() -> cu.EndlessAnimation:
    vols = np.random.default_rng(0).uniform(0, 1, (6, 4, 4, 4)).astype(np.float32)
    return cu.EndlessAnimation(cu.VolumeDatabase(vols, (0, 0, 0), (1, 1, 1)), crossfade_frames=1)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"source": -1, "weight": 5.0}, "source"),
        ({"weight": 5.0}, "weight"),
        ({"weight": float("nan")}, "weight"),
        ({"target": -2}, "target"),
        ({"index": -1}, "index"),
        ({"crossfade": "yes"}, "crossfade"),
        ({"source": 1.5}, "source"),
    ],
)
def test_animation_frames_are_validated(kwargs: dict, name: str) -> None:
    args = {"index": 0, "source": 0, "target": 1, "weight": 0.5, "crossfade": True, **kwargs}
    with pytest.raises((ValueError, TypeError), match=name):
        cu.AnimationFrame(**args)


def test_a_frame_outside_the_database_is_refused(anim: cu.EndlessAnimation) -> None:
    frame = cu.AnimationFrame(0, 99, 0, 1.0, False)
    with pytest.raises(ValueError, match="source"):
        anim.density(frame)
    frame = cu.AnimationFrame(0, 0, 6, 0.5, True)
    with pytest.raises(ValueError, match="target"):
        anim.density(frame)
    d = anim.density(cu.AnimationFrame(0, 0, 1, 0.25, True))
    assert d.max() <= anim.database.volumes.max()


# --- lsystem_length ---------------------------------------------------------------------------
def test_lsystem_length_is_exact_beyond_two_to_the_64() -> None:
    rules = {"X": "X+Y", "Y": "X&Y"}  # length 2^(n+1) − 1 after n iterations
    for n in (2, 10, 62, 63, 64, 65, 200, 5000):
        assert cu.lsystem_length("X", rules, n) == 2 ** (n + 1) - 1, n
    odd = {"A": "AB[C]", "B": "A", "C": "CC-"}
    for n in range(8):
        assert cu.lsystem_length("AC", odd, n) == len(cu.lsystem_expand("AC", odd, n))
    assert math.log2(cu.lsystem_length("AC", odd, 100)) > 64


# --- arguments that are not iterable ----------------------------------------------------------
@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: cu.render_frames(_scene(), 5, "out", progress=False), "cameras"),
        (lambda: cu.merge(5), "clouds"),
        (lambda: cu.fly_towards((0, 0, -10), (0, 0, 0), 3, up=None), "up"),
        (lambda: cu.orbit(5, 10, 3), "centre"),
    ],
)
def test_non_iterable_arguments_are_named(call, name: str) -> None:
    with pytest.raises(TypeError, match=name):
        call()


def test_render_frames_checks_the_pattern_before_rendering(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from cumuli.rendering import compositor

    def never(*args: object, **kwargs: object) -> None:
        raise AssertionError("a frame was rendered")

    monkeypatch.setattr(compositor, "render", never)
    for pattern in ("{:04d}.jpg", "{:04d}", "f{:02d}.PNG.bak"):
        with pytest.raises(ValueError, match="extension"):
            cframes.render_frames(_scene(), cu.orbit((0, 0, 0), 30, 2), tmp_path, pattern=pattern,
                                  progress=False)  # fmt: skip
    assert list(tmp_path.iterdir()) == []


# --- garbage meshes ---------------------------------------------------------------------------
@pytest.mark.parametrize("ext", [".obj", ".stl", ".off"])
@pytest.mark.parametrize("content", ["binary", "text"])
def test_garbage_mesh_files_say_not_a_mesh(tmp_path: Path, ext: str, content: str) -> None:
    path = tmp_path / f"junk{ext}"
    if content == "binary":
        path.write_bytes(np.random.default_rng(0).integers(0, 256, 3000, np.uint8).tobytes())
    else:
        path.write_text("hello world\nthis is not a mesh\n")
    with pytest.raises(ValueError, match="not a mesh") as err:
        cu.mesh_cloud(path)
    assert path.name in str(err.value) and "charset" not in str(err.value)


def test_a_binary_stl_still_loads(tmp_path: Path) -> None:
    import trimesh

    v, f = cu.meshes.icosphere(1)
    path = tmp_path / "ball.stl"
    trimesh.Trimesh(v, f).export(path)
    assert cu.mesh_cloud(path).n == len(f)
    off = tmp_path / "ball.off"
    trimesh.Trimesh(v, f).export(off)
    assert cu.mesh_cloud(off).n == len(f)


# --- Ctrl-C in a long C++ call ----------------------------------------------------------------
_SIGINT_SCRIPT = """
import os, signal, sys, threading, time
import cumuli as cu
from cumuli.demo import default_scene

# Python's own Ctrl-C handler, whatever this process inherited: a shell that starts a job in the
# background (`cmd &` without job control) starts it with SIGINT ignored.
signal.signal(signal.SIGINT, signal.default_int_handler)
scene = default_scene()
lit = cu.prepare_light(scene)
camera = scene.default_camera()
start = time.perf_counter()
cu.render(lit, camera, 320, 240, backend="cpu")
full = (time.perf_counter() - start) * 16  # the interrupted render is 16 times larger
threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
start = time.perf_counter()
try:
    cu.render(lit, camera, 1280, 960, backend="cpu")
    print("FINISHED", time.perf_counter() - start, full)
except KeyboardInterrupt:
    print("INTERRUPTED", time.perf_counter() - start, full)
"""


def test_ctrl_c_stops_a_long_cpu_render_early(tmp_path: Path) -> None:
    script = tmp_path / "interrupt.py"
    script.write_text(textwrap.dedent(_SIGINT_SCRIPT))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    word, took, full = done.stdout.split()
    assert word == "INTERRUPTED"
    # Honoured between chunks of rows, not when the render ends: well before the estimate of
    # the whole render (measured in the same run on an image 16 times smaller).
    assert float(took) < 0.5 * float(full), (took, full)
