"""Mesh → ellipsoids (§3.6.4, eqs. 22–30): geometry against a numpy reference, files, bad input."""

from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np
import pytest

import cumuli
from cumuli.io import meshes


def _reference(v: np.ndarray, f: np.ndarray, scale: float):
    """Slow numpy reference of eqs. (22)–(24) and the farthest scaled vertex."""
    p = v[f].astype(np.float64)  # (F, 3, 3): face, vertex, xyz
    b = p.mean(axis=1)
    scaled = (p - b[:, None]) * scale + b[:, None]
    d = scaled - b[:, None]
    radii = np.linalg.norm(d, axis=2)
    far = d[np.arange(len(f)), radii.argmax(axis=1)]
    return b, radii, far


@pytest.mark.parametrize("scale", [0.3, 1.0, 1.7, 2.0])
def test_one_ellipsoid_per_face_matching_the_reference(scale: float) -> None:
    v, f = meshes.bunny_like(subdivisions=1)
    c, r, rot = cumuli.ellipsoids_from_mesh(v, f, scale=scale)
    assert c.shape == (len(f), 3) and r.shape == (len(f), 3) and rot.shape == (len(f), 3, 3)
    b, radii, far = _reference(v, f, scale)
    np.testing.assert_allclose(c, b, atol=1e-5)
    np.testing.assert_allclose(r, np.maximum(radii, r.min()), rtol=1e-5, atol=1e-6)
    # Rotations are proper and orthonormal.
    np.testing.assert_allclose(
        rot @ rot.transpose(0, 2, 1), np.eye(3)[None].repeat(len(f), 0), atol=1e-5
    )
    np.testing.assert_allclose(np.linalg.det(rot), 1.0, atol=1e-5)
    # The longest axis (a rotation column) points at the farthest scaled vertex. Faces whose two
    # largest radii tie (within rounding) may pick either vertex: they are left out.
    k = radii.argmax(axis=1)
    top2 = np.sort(radii, axis=1)[:, -2:]
    clear = (top2[:, 1] - top2[:, 0]) > 1e-6 * top2[:, 1]
    assert clear.mean() > 0.5
    axis = rot[np.arange(len(f)), :, k]
    unit = far / np.linalg.norm(far, axis=1, keepdims=True)
    np.testing.assert_allclose((axis * unit).sum(axis=1)[clear], 1.0, atol=1e-5)
    # ... so that vertex lies on the ellipsoid's surface.
    q = np.einsum("nji,nj->ni", rot, far) / r
    np.testing.assert_allclose(np.linalg.norm(q, axis=1)[clear], 1.0, atol=1e-4)


def test_without_rotation_the_axes_stay_aligned() -> None:
    v, f = meshes.icosphere(1)
    _, r, rot = cumuli.ellipsoids_from_mesh(v, f, scale=1.0, rotate=False)
    assert np.array_equal(rot, np.repeat(np.eye(3, dtype=np.float32)[None], len(f), 0))
    _, radii, _ = _reference(v, f, 1.0)
    np.testing.assert_allclose(r, radii, rtol=1e-5)


def test_degenerate_faces_give_no_nan() -> None:
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 0, 0], [5, 5, 5]], np.float32)
    f = np.array(
        [[0, 1, 2], [0, 0, 0], [0, 3, 0], [4, 4, 1], [2, 1, 0], [0, 1, 4]], np.int64
    )  # collinear, a point, coincident vertices, two equal, reversed, a fine one
    c, r, rot = cumuli.ellipsoids_from_mesh(v, f, scale=1.0)
    for a in (c, r, rot):
        assert np.isfinite(a).all()
    assert (r > 0).all()
    np.testing.assert_allclose(np.linalg.det(rot), 1.0, atol=1e-5)
    cloud = cumuli.mesh_cloud((v, f))
    assert cloud.n == 6 and cloud.stats["floored_faces"] >= 3


def test_antiparallel_farthest_vertex() -> None:
    # Farthest scaled vertex straight along −x from the barycentre: a half turn, not NaN.
    v = np.array([[-2.0, 0, 0], [1.0, 0.1, 0], [1.0, -0.1, 0]], np.float32)
    _, r, rot = cumuli.ellipsoids_from_mesh(v, np.array([[0, 1, 2]]))
    assert r[0].argmax() == 0
    np.testing.assert_allclose(rot[0][:, 0], [-1, 0, 0], atol=1e-6)
    np.testing.assert_allclose(np.linalg.det(rot[0]), 1.0, atol=1e-6)


def test_mesh_cloud_sources_and_decimation(tmp_path: Path) -> None:
    import trimesh

    v, f = meshes.bunny_like()
    assert len(f) == 2240
    cloud = cumuli.mesh_cloud((v, f), scale=1.2, target_faces=400)
    assert 300 <= cloud.n <= 420 and cloud.stats["faces_in"] == 2240
    assert cloud.params["args"]["source"]["faces"] == 2240
    tm = trimesh.Trimesh(vertices=v, faces=f, process=False)
    assert cumuli.mesh_cloud(tm).n == 2240
    for ext in (".obj", ".ply", ".stl", ".glb"):
        path = tmp_path / f"torus{ext}"
        tv, tf = meshes.torus(sections=12)
        trimesh.Trimesh(vertices=tv, faces=tf, process=False).export(path)
        c = cumuli.mesh_cloud(path, scale=0.8)
        assert c.n == len(tf), ext
        assert c.params["args"]["source"] == str(path)
    small = cumuli.mesh_cloud(meshes.icosphere(1), target_faces=1000)
    assert small.n == 80  # already below the target: kept


def test_mesh_cloud_is_a_cloud_that_saves(tmp_path: Path) -> None:
    c = cumuli.mesh_cloud(meshes.torus(sections=8), scale=1.5)
    d = cumuli.load_cloud(c.save(tmp_path / "torus.npz"))
    assert np.array_equal(d.rotations, c.rotations) and d.params == c.params


@pytest.mark.parametrize(
    "vertices,faces,kwargs,exc,word",
    [
        (np.zeros((0, 3)), np.zeros((0, 3), int), {}, ValueError, "vertices"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.zeros((0, 3), int), {}, ValueError, "faces"),
        ([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], {}, ValueError, "vertices"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]], {}, ValueError, "faces"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, -1, 2]], {}, ValueError, "faces"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0.0, 1.0, 2.0]], {}, TypeError, "faces"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1]], {}, ValueError, "faces"),
        ([[0, 0], [1, 0]], [[0, 1, 1]], {}, ValueError, "vertices"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], {"scale": 0}, ValueError, "scale"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], {"scale": 2.5}, ValueError, "scale"),
        ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], {"scale": -1}, ValueError, "scale"),
        (
            [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
            [[0, 1, 2]],
            {"min_radius": 0},
            ValueError,
            "min_radius",
        ),
    ],
)
def test_bad_arrays(vertices, faces, kwargs, exc, word) -> None:
    with pytest.raises(exc, match=word):
        cumuli.ellipsoids_from_mesh(vertices, faces, **kwargs)


def test_core_checks_its_own_input() -> None:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    with pytest.raises(ValueError, match="faces"):
        cumuli._core.ellipsoids_from_mesh(v, np.array([[0, 1, 7]]), 1.0, True, 1e-4)
    with pytest.raises(TypeError, match="integer"):
        cumuli._core.ellipsoids_from_mesh(v, np.array([[0.0, 1, 2]]), 1.0, True, 1e-4)
    with pytest.raises(ValueError, match="scale"):
        cumuli._core.ellipsoids_from_mesh(v, np.array([[0, 1, 2]]), 3.0, True, 1e-4)


def test_bad_sources(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        cumuli.mesh_cloud(tmp_path / "missing.obj")
    with pytest.raises(TypeError, match="source"):
        cumuli.mesh_cloud(42)
    with pytest.raises(ValueError, match="format"):
        cumuli.mesh_cloud(tmp_path / "x.fbx")
    with pytest.raises(ValueError, match="target_faces"):
        cumuli.mesh_cloud(meshes.icosphere(1), target_faces=0)
    cases = {
        "empty.obj": b"",
        "empty.ply": b"",
        "garbage.obj": b"hello\nthis is not an obj file\n\x00\x01",
        "garbage.ply": bytes(range(256)) * 2,
        "truncated.obj": b"v 0 0 0\nv 1 0 0\nf 1 2 3\n",
        "noend.ply": b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n",
        "truncated.ply": (
            b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
            b"property float y\nproperty float z\nelement face 1\n"
            b"property list uchar int vertex_indices\nend_header\n" + struct.pack("<3f", 0, 0, 0)
        ),
        "huge.ply": (
            b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
            b"property float x\nproperty float y\nproperty float z\nend_header\n" + b"\0" * 24
        ),
        "bigger.ply": (
            b"ply\nformat ascii 1.0\nelement vertex 10000000\n"
            b"property float x\nproperty float y\nproperty float z\nelement face 1\n"
            b"property list uchar int vertex_indices\nend_header\n0 0 0\n"
        ),
    }
    for name, data in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(ValueError, match=name.replace(".", r"\.")):
            cumuli.mesh_cloud(path)


def _parallel_face_threshold() -> int:
    """Faces below which the core runs on one thread whatever ``threads`` says."""
    src = (Path(__file__).resolve().parents[2] / "cpp/src/model/mesh.cpp").read_text()
    per_thread = int(re.search(r"kFacesPerThread = (\d+);", src).group(1))
    assert re.search(r"face_count < 2 \* kFacesPerThread \? 1 : threads", src)
    return 2 * per_thread


def test_thread_count_does_not_change_the_result() -> None:
    # Large enough that the core really splits the faces (1, 2, 3 threads chunk them
    # differently): a smaller mesh would run on one thread every time.
    v, f = meshes.icosphere(5)
    assert len(f) == 20480 and len(f) >= _parallel_face_threshold()
    # Jittered, so that the faces differ from one another.
    v = v + np.random.default_rng(5).normal(0.0, 0.01, v.shape).astype(np.float32)
    one = cumuli.ellipsoids_from_mesh(v, f, scale=1.3, threads=1)
    for threads in (2, 3, 0):
        many = cumuli.ellipsoids_from_mesh(v, f, scale=1.3, threads=threads)
        for a, b in zip(one, many, strict=True):
            assert a.tobytes() == b.tobytes(), threads
    cloud = cumuli.mesh_cloud((v, f), scale=1.3, threads=2)
    assert cloud.centres.tobytes() == one[0].tobytes()
    assert cloud.rotations.tobytes() == one[2].tobytes()
