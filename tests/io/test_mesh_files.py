"""Mesh files (`cumuli.io.meshes.load_mesh`): OBJ face indices are checked before trimesh reads
the file, and files that are no mesh at all say so.

trimesh accepts ``f 0 1 2`` (0 is not a valid 1-based index) and silently builds a wrong
triangle from it; it fails on indices past the vertices without saying where. `load_mesh`
refuses both with a ValueError naming the file and the line. Garbage (binary or text) with a
mesh extension is "not a mesh", naming the file; binary STL and OFF still load.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cumuli
from cumuli.io import meshes

TRIANGLE = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"


def _obj(tmp_path: Path, text: str, name: str = "mesh.obj") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("body", "line", "what"),
    [
        ("f 0 1 2\n", 4, "index 0"),
        ("f 1 2 3\nf 1 2 0\n", 5, "index 0"),
        ("f 1/1 0/1 2/1\n", 4, "index 0"),
        ("f 0//1 2//1 3//1\n", 4, "index 0"),
        ("f 1 2 4\n", 4, "index 4 is out of range: the file has 3 vertices"),
        ("f 1/1/1 2/1/1 9/1/1\n", 4, "index 9 is out of range"),
        ("f -1 -2 -4\n", 4, "relative face index -4"),
        ("f 1 2\n", 4, "at least 3 vertices"),
        ("f 1 2 x\n", 4, "bad face vertex 'x'"),
        ("f 1/1 2/1 3/a\n", 4, "bad face vertex '3/a'"),
        ("f 1/1/1/1 2 3\n", 4, "bad face vertex"),
        ("f 1/1/1 2//1 3/1\n", 4, "mixes the forms"),
    ],
)
def test_bad_face_indices_name_the_file_and_line(
    tmp_path: Path, body: str, line: int, what: str
) -> None:
    path = _obj(tmp_path, TRIANGLE + body, "broken.obj")
    with pytest.raises(ValueError, match=rf"broken\.obj, line {line}: .*{what}"):
        meshes.load_mesh(path)
    with pytest.raises(ValueError, match=r"broken\.obj"):
        cumuli.mesh_cloud(path)


def test_relative_index_counts_only_the_vertices_defined_before_it(tmp_path: Path) -> None:
    # -3 is fine after three vertices, but not in a face written before the third.
    text = "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n"
    with pytest.raises(ValueError, match=r"line 3: relative face index -3 but only 2"):
        meshes.load_mesh(_obj(tmp_path, text))


def test_index_zero_would_have_been_a_wrong_triangle(tmp_path: Path) -> None:
    # What the check prevents: trimesh reads index 0 as a vertex and keeps the face.
    import trimesh

    path = _obj(tmp_path, TRIANGLE + "v 0 0 1\nf 0 1 2\n")
    mesh = trimesh.load(str(path), force="mesh", process=False)
    assert len(mesh.faces) == 1  # accepted by trimesh...
    with pytest.raises(ValueError, match="index 0"):
        meshes.load_mesh(path)  # ...refused here


@pytest.mark.parametrize(
    ("body", "faces"),
    [
        ("f 1 2 3\n", [[0, 1, 2]]),
        ("f -3 -2 -1\n", [[0, 1, 2]]),
        ("f 1 2 -1\n", [[0, 1, 2]]),
        ("vn 0 0 1\nf 1//1 2//1 3//1\n", [[0, 1, 2]]),
        ("vt 0 0\nf 1/1 2/1 3/1\n", [[0, 1, 2]]),
        ("vt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\n", None),
        ("f 1 2 \\\n 3\n", [[0, 1, 2]]),  # a statement continued on the next line
        ("# f 0 0 0\nf 1 2 3\n", [[0, 1, 2]]),  # comments are not faces
    ],
)
def test_valid_faces_load(tmp_path: Path, body: str, faces: list | None) -> None:
    v, f = meshes.load_mesh(_obj(tmp_path, TRIANGLE + body))
    assert f.shape == (1, 3) and v.shape == (3, 3)
    # The triangle is the one the file wrote, whatever order trimesh stores vertices in.
    assert sorted(map(tuple, v[f[0]].tolist())) == [(0, 0, 0), (0, 1, 0), (1, 0, 0)]
    if faces is not None:
        assert f.tolist() == faces


def test_forward_references_and_polygons_load(tmp_path: Path) -> None:
    # A face may come before the vertices it uses; quads are split into two triangles.
    text = "f 1 2 3 4\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    v, f = meshes.load_mesh(_obj(tmp_path, text))
    assert v.shape == (4, 3) and f.shape == (2, 3)


def test_exported_meshes_still_load(tmp_path: Path) -> None:
    import trimesh

    tv, tf = meshes.bunny_like(subdivisions=1)
    path = tmp_path / "bunny.obj"
    trimesh.Trimesh(vertices=tv, faces=tf, process=False).export(path)
    v, f = meshes.load_mesh(path)
    assert f.shape == tf.shape
    np.testing.assert_allclose(v[f], tv[tf], atol=1e-5)


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
        cumuli.mesh_cloud(path)
    assert path.name in str(err.value) and "charset" not in str(err.value)


def test_a_binary_stl_still_loads(tmp_path: Path) -> None:
    import trimesh

    v, f = cumuli.meshes.icosphere(1)
    path = tmp_path / "ball.stl"
    trimesh.Trimesh(v, f).export(path)
    assert cumuli.mesh_cloud(path).n == len(f)
    off = tmp_path / "ball.off"
    trimesh.Trimesh(v, f).export(off)
    assert cumuli.mesh_cloud(off).n == len(f)
