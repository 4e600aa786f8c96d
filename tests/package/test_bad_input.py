"""Bad input found by the review: each case raises a clear ValueError/TypeError/OSError naming the
parameter (never a crash, a huge allocation or a partial file)."""

from __future__ import annotations

import io
import json
import os
import stat
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import cumuli as cu
from cumuli import _core
from cumuli.model.cloud import MAX_PRIMITIVES
from cumuli.rendering import compositor as renderer_mod


def small_cloud() -> cu.Cloud:
    return cu.Cloud(np.array([[0.0, 0.0, 0.0], [1.5, 0.0, 0.0]]), np.array([1.0, 1.2]))


def _npz_member(zf: zipfile.ZipFile, name: str, array: np.ndarray) -> None:
    buf = io.BytesIO()
    np.save(buf, array)
    zf.writestr(name + ".npy", buf.getvalue())


def _meta(cloud: cu.Cloud) -> np.ndarray:
    return np.frombuffer(json.dumps(cloud._meta()).encode(), np.uint8)


# --- L-system: max_length is capped before the core reserves memory -------------------------
def test_lsystem_max_length_is_capped_before_allocating() -> None:
    # 2**45 symbols: without the cap the core would reserve ~32 TB (MemoryError or the OOM killer).
    with pytest.raises(ValueError, match="max_length"):
        cu.lsystem_expand("X", {"X": "XX"}, 45, max_length=2**62)
    with pytest.raises(ValueError, match="max_length"):
        cu.lsystem_cloud(iterations=3, max_length=2**40)
    with pytest.raises(ValueError, match="max_length"):
        _core.lsystem_expand("X", {"X": "XX"}, 45, 2**64 - 1)
    # The cap itself is fine and below it everything works as before.
    cap = int(_core.LSYSTEM_MAX_LENGTH)
    assert cu.lsystem_expand("X", {"X": "XX"}, 3, max_length=cap) == "X" * 8


# --- Cloud files ------------------------------------------------------------------------------
def test_npz_member_declaring_too_many_primitives_is_refused_before_inflating(
    tmp_path: Path,
) -> None:
    good = small_cloud()
    rows = 2 * MAX_PRIMITIVES  # 24 MiB of zeros, a few KiB compressed
    path = tmp_path / "bomb.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        _npz_member(zf, "centres", np.zeros((rows, 3), np.float32))
        _npz_member(zf, "radii", good.radii)
        _npz_member(zf, "rotations", good.rotations)
        _npz_member(zf, "meta", _meta(good))
    assert path.stat().st_size < 1 << 20
    with pytest.raises(ValueError, match="'centres' has unacceptable shape"):
        cu.load_cloud(path)


def test_npz_fortran_order_arrays_are_read_in_their_order(tmp_path: Path) -> None:
    good = cu.Cloud(np.arange(9, dtype=np.float32).reshape(3, 3), np.ones(3))
    path = tmp_path / "f.npz"
    np.savez(
        path,
        centres=np.asfortranarray(good.centres),
        radii=np.asfortranarray(good.radii),
        rotations=good.rotations,
        meta=_meta(good),
    )
    loaded = cu.load_cloud(path)
    np.testing.assert_array_equal(loaded.centres, good.centres)


def test_inverted_light_box_in_a_file_is_refused(tmp_path: Path) -> None:
    # Light grids live in their own files now (cu.LightGrid.save); a cloud file holds no light.
    grid = cu.LightGrid(np.ones((2, 2, 2), np.float32), ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)))
    path = grid.save(tmp_path / "g.npz")
    with np.load(path) as z:
        meta = json.loads(z["meta"].tobytes())
        values = z["values"]
    meta["box"] = [[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]
    np.savez(path, values=values, meta=np.frombuffer(json.dumps(meta).encode(), np.uint8))
    with pytest.raises(ValueError, match="box"):
        cu.load_light_grid(path)
    # A version-1 cloud file that still carries a light grid loads (the grid is ignored).
    c = small_cloud()
    meta = dict(c._meta(), version=1, light_box=[[0.0] * 3, [1.0] * 3])
    np.savez(
        tmp_path / "c.npz",
        centres=c.centres,
        radii=c.radii,
        rotations=c.rotations,
        light=np.ones((2, 2, 2), np.float32),
        meta=np.frombuffer(json.dumps(meta).encode(), np.uint8),
    )
    back = cu.load_cloud(tmp_path / "c.npz")
    np.testing.assert_array_equal(back.centres, c.centres)
    with pytest.raises(AttributeError, match="prepare_light"):
        c.light = np.ones((2, 2, 2), np.float32)


@pytest.mark.parametrize(
    ("light", "box", "exc", "match"),
    [
        (np.ones((2, 2)), ((0, 0, 0), (1, 1, 1)), ValueError, r"\(D, H, W\)"),
        (np.full((2, 2, 2), np.nan), ((0, 0, 0), (1, 1, 1)), ValueError, "NaN"),
        (np.ones((2, 2, 2), object), ((0, 0, 0), (1, 1, 1)), TypeError, "real numbers"),
        (np.ones((2, 2, 2)), None, ValueError, "box"),
        (np.ones((2, 2, 2)), ((1, 1, 1), (0, 0, 0)), ValueError, "box"),
    ],
)
def test_a_light_grid_that_load_would_refuse_cannot_be_made(
    tmp_path: Path, light: np.ndarray, box: object, exc: type, match: str
) -> None:
    # Before: saved without complaint, and load_cloud then refused its own file. Grids are
    # values now (cu.LightGrid), checked when made, so no such grid reaches a file.
    with pytest.raises(exc, match=match):
        cu.LightGrid(light, box)
    assert list(tmp_path.iterdir()) == []


def test_deeply_nested_json_is_a_value_error(tmp_path: Path) -> None:
    text = "[" * 100_000 + "]" * 100_000
    (tmp_path / "deep.json").write_text(text)
    with pytest.raises(ValueError, match="deep.json"):
        cu.load_cloud(tmp_path / "deep.json")
    with pytest.raises(ValueError, match="not valid JSON"):
        cu.load_scene(tmp_path / "deep.json")


def test_oversized_scene_file_is_refused_before_reading(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = cu.Scene(
        [small_cloud()], noise=cu.Noise(0, 4), settings=cu.RenderSettings(lighting="paper")
    ).save(tmp_path / "s.json")
    monkeypatch.setattr("cumuli.scene.MAX_SCENE_BYTES", 100)
    with pytest.raises(ValueError, match="more than 100"):
        cu.load_scene(path)


# --- Images: declared sizes are checked before decoding ---------------------------------------
def _png(path: Path, width: int, height: int, rows: bytes) -> Path:
    import struct
    import zlib

    def chunk(tag: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(tag + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", crc)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    body = chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b"")
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + body)
    return path


def test_read_image_refuses_declared_sizes_beyond_the_limit(tmp_path: Path) -> None:
    # A few hundred bytes declaring a 70000-pixel-wide image: decoded before, refused now.
    width = 70_000
    path = _png(tmp_path / "wide.png", width, 1, b"\0" + bytes(4 * width))
    assert path.stat().st_size < 2000
    with pytest.raises(ValueError, match="each side must be 1 to 65536"):
        cu.read_image(path)
    ok = _png(tmp_path / "ok.png", 3, 1, b"\0" + bytes(range(12)))
    assert cu.read_image(ok).shape == (1, 3, 4)


# --- Atomic writes share one helper: same permissions, nothing left on failure ----------------
def test_scene_cloud_and_image_files_get_the_same_permissions(tmp_path: Path) -> None:
    scene_path = cu.Scene(
        [small_cloud()], noise=cu.Noise(0, 4), settings=cu.RenderSettings(lighting="paper")
    ).save(tmp_path / "s.json")
    cloud_path = small_cloud().save(tmp_path / "c.npz")
    image_path = cu.write_image(
        tmp_path / "i.png", np.zeros((2, 3, 4), np.float32), exposure=1.0, tonemap="none"
    )
    umask = os.umask(0)
    os.umask(umask)
    want = 0o666 & ~umask
    for p in (scene_path, cloud_path, image_path):
        assert stat.S_IMODE(p.stat().st_mode) == want, p.name


def test_failed_saves_leave_no_temporary(tmp_path: Path) -> None:
    (tmp_path / "taken.json").mkdir()
    (tmp_path / "taken.npz").mkdir()
    with pytest.raises(OSError):
        cu.Scene(
            [small_cloud()], noise=cu.Noise(0, 4), settings=cu.RenderSettings(lighting="paper")
        ).save(tmp_path / "taken.json")
    with pytest.raises(OSError):
        small_cloud().save(tmp_path / "taken.npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken.json", "taken.npz"]


# --- Light grids set by hand ------------------------------------------------------------------
def _cpu_scene(cloud: cu.Cloud) -> cu.Scene:
    return cu.Scene(
        [cloud],
        noise=cu.Noise(0, 4),
        settings=cu.RenderSettings(light_resolution=4, lighting="paper"),
    )


@pytest.mark.parametrize("dtype", [object, complex])
def test_hand_made_light_grid_of_wrong_dtype_names_the_grid(dtype: type) -> None:
    with pytest.raises(TypeError, match=r"light grid values must be real numbers"):
        cu.LightGrid(np.zeros((2, 2, 2), dtype), ((-2.0, -2.0, -2.0), (3.0, 2.0, 2.0)))
    # Anything but a LightGrid given as a cloud's light is refused, naming the cloud.
    cam = cu.Camera((0, 0, -10), (0, 0, 0))
    with pytest.raises(TypeError, match=r"clouds\[0\].*LightGrid"):
        cu.render(
            cu.prepare_light(_cpu_scene(small_cloud()), lights=[np.zeros((2, 2, 2), dtype)]),
            cam,
            4,
            3,
            backend="cpu",
        )


@pytest.mark.parametrize(
    "box", ["ab", ((0, 0, 0),), ((0, 0, 0), (1, 1, np.inf)), (("a", 0, 0), (1, 1, 1)), 5]
)
def test_hand_made_light_box_that_is_not_two_vectors_names_the_box(box: object) -> None:
    with pytest.raises(ValueError, match=r"light grid box must be \(lo, hi\)"):
        cu.LightGrid(np.zeros((2, 2, 2), np.float32), box)


def test_cpu_backend_checks_the_image_size_before_the_light_pass() -> None:
    # Before: render_cpu ran the light pass, then the core refused 16384² pixels; render(...,
    # backend="cpu") blamed GL_MAX_TEXTURE_SIZE for a CPU render.
    scene = _cpu_scene(small_cloud())
    cam = cu.Camera((0, 0, -10), (0, 0, 0))
    cu.light.prepare.clear_memo()
    with pytest.raises(ValueError, match="larger than the limit"):
        cu.render_cpu(scene, cam, 1 << 14, 1 << 14)
    assert not cu.light.memo.store and not cu.light.memo.media_store  # no light pass ran
    with pytest.raises(ValueError, match=r"width must be <= 16384, got 20000$"):
        cu.render(scene, cam, 20000, 2, backend="cpu")
    assert not cu.light.memo.store and not cu.light.memo.media_store


# --- Renderer arguments are checked before a GL context is made -------------------------------
def test_renderer_checks_arguments_before_making_a_context(monkeypatch: pytest.MonkeyPatch) -> None:
    made: list[object] = []

    class FakeContext:
        closed = False

        def __init__(self) -> None:
            made.append(self)
            raise AssertionError("no context should be made for bad arguments")

    monkeypatch.setattr(renderer_mod, "GLContext", FakeContext)
    with pytest.raises(TypeError, match="tile"):
        cu.Renderer(tile="big")
    with pytest.raises(ValueError, match="tile"):
        cu.Renderer(tile=1)
    with pytest.raises(TypeError, match="context must be a cumuli.gl.GLContext"):
        cu.Renderer(context="egl")
    assert made == []


@pytest.mark.gl
def test_renderer_refuses_primitives_beyond_the_storage_block_limit() -> None:
    # Before: a buffer beyond GL_MAX_SHADER_STORAGE_BLOCK_SIZE (128 MiB on llvmpipe, ~1.6 M
    # primitives) was bound anyway and the primitives past the limit silently read as nothing.
    c = small_cloud()
    grid = cu.LightGrid(np.ones((2, 2, 2), np.float32), ((-2.0, -2.0, -2.0), (3.0, 2.0, 2.0)))
    scene = cu.prepare_light(
        cu.Scene([c], noise=cu.Noise(0, 4), settings=cu.RenderSettings(lighting="paper")),
        lights=[grid],
    )
    cam = cu.Camera((0, 0, -10), (0, 0, 0))
    with cu.Renderer() as r:
        marcher = r.drawer("cloud")
        marcher.max_storage_block_size = 80  # one primitive's 80 bytes; the cloud has two
        with pytest.raises(ValueError, match="GL_MAX_SHADER_STORAGE_BLOCK_SIZE"):
            r.render(scene, cam, 4, 3)
        marcher.max_storage_block_size = 160
        assert r.render(scene, cam, 4, 3).shape == (3, 4, 4)


# --- The core's containment filter refuses what eq. (17) cannot compare ------------------------
@pytest.mark.parametrize(
    ("centres", "radii", "name"),
    [
        (np.full((2, 3), np.nan), np.ones(2), "centres"),
        (np.zeros((2, 3)), np.array([1.0, np.nan]), "radii"),
        (np.zeros((2, 3)), np.array([1.0, -1.0]), "radii"),
        (np.zeros((2, 3)), np.array([1.0, 0.0]), "radii"),
    ],
)
def test_remove_contained_spheres_refuses_non_finite_or_non_positive(
    centres: np.ndarray, radii: np.ndarray, name: str
) -> None:
    with pytest.raises(ValueError, match=name):
        _core.remove_contained_spheres(centres.astype(np.float32), radii.astype(np.float32))


# --- Primitives whose float32 bounds overflow are refused --------------------------------------
@pytest.mark.parametrize(
    ("centres", "radii"),
    [([[3e38, 0.0, 0.0]], [1e38]), ([[0.0, 0.0, 0.0]], [3e38]), ([[-2e38, 0.0, 0.0]], [2e38])],
)
def test_cloud_whose_bounds_overflow_float32_is_refused(centres: list, radii: list) -> None:
    # Before: accepted with bbox = NaN, failing later with "cloud box is not finite".
    with pytest.raises(ValueError, match="float32 range"):
        cu.Cloud(centres, radii)


# --- Rotations: columns are unit, orthogonal axes ---------------------------------------------
@pytest.mark.parametrize(
    "rotation",
    [np.zeros((3, 3)), np.diag([2.0, 1.0, 1.0]), [[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]],
)
def test_non_orthonormal_rotations_are_refused(rotation: object) -> None:
    # Before: accepted; the core's bounds (from R's columns) and unit frame (Rᵀ as inverse)
    # disagreed, so a zero matrix gave a point-sized box and a scaled one a clipped primitive.
    rot = np.asarray(rotation, dtype=np.float32)[None]
    with pytest.raises(ValueError, match=r"rotations\[0\] is not orthonormal"):
        cu.Cloud(np.zeros((1, 3)), np.ones(1), rot)
    with pytest.raises(ValueError, match="orthonormal"):
        _core.light_grid(
            _core.CloudShape(
                np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32), rot, "spheroid", 0.5,
                0.6,
            ),
            None, (0, 1, 0), (4, 4, 4), "ndt", 0.1, 0.3, 1e-4, _core.FbmParams(5, 0.5, 2.0, 1.0),
            0.5, 1,
        )  # fmt: skip


def test_proper_rotations_and_reflections_are_accepted() -> None:
    c, s = np.cos(0.7), np.sin(0.7)
    rot = np.array([[[c, -s, 0], [s, c, 0], [0, 0, 1]], np.diag([1.0, -1.0, 1.0])], np.float32)
    cloud = cu.Cloud(np.zeros((2, 3)), np.ones((2, 3)), rot)
    np.testing.assert_array_equal(cloud.rotations, rot)


# --- render_frames --------------------------------------------------------------------------
def test_render_frames_pattern_must_be_a_str(tmp_path: Path) -> None:
    from cumuli.anim import frames

    scene = cu.Scene(
        [small_cloud()], noise=cu.Noise(0, 4), settings=cu.RenderSettings(lighting="paper")
    )
    cams = frames.orbit((0, 0, 0), 10.0, 2)
    with pytest.raises(TypeError, match="pattern must be a str"):  # was AttributeError
        frames.render_frames(scene, cams, tmp_path / "out", 4, 3, backend="cpu", pattern=5)
    assert not (tmp_path / "out").exists()


# --- Threads the system refuses --------------------------------------------------------------
def test_threads_the_system_refuses_do_not_abort_the_interpreter() -> None:
    # 1024 threads under an address-space limit: thread creation fails part way. Before, the
    # std::system_error escaped while other threads ran and std::terminate aborted Python.
    code = textwrap.dedent(
        """
        import os, resource
        import numpy as np
        import cumuli as cu
        noise = cu.Noise(1, 8)
        pts = np.random.default_rng(0).random((4096, 3)).astype(np.float32)
        ref = noise.fbm(pts, threads=1)
        vm = int(open("/proc/self/statm").read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        resource.setrlimit(resource.RLIMIT_AS, (vm + (300 << 20), hard))
        print(np.array_equal(noise.fbm(pts, threads=1024), ref))
        """
    )
    env = {**os.environ, "PYTHONPATH": str(Path(cu.__file__).parents[1])}
    run = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip() == "True"


# --- Property: any float array reaching Cloud either builds a usable cloud or is refused ------
_floats = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    centres=hnp.arrays(
        np.float64, st.tuples(st.integers(0, 3), st.integers(2, 4)), elements=_floats
    ),
    radii=hnp.arrays(np.float64, st.integers(0, 4), elements=_floats),
)
def test_cloud_from_arbitrary_floats_builds_or_raises(
    centres: np.ndarray, radii: np.ndarray
) -> None:
    try:
        with np.errstate(all="ignore"):
            cloud = cu.Cloud(centres, radii)
    except (ValueError, TypeError):
        return
    # A cloud that was accepted works in the core: finite bounds and a density at its centres.
    lo, hi = cloud.bbox
    assert np.isfinite(lo).all() and np.isfinite(hi).all()
    rho, gamma = cloud.density(cloud.centres, constant=0.25, threads=1)
    assert rho.shape == gamma.shape == (cloud.n,)
