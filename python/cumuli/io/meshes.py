"""Triangle meshes for the mesh → ellipsoid generator (§3.6.4): safe loading and test shapes.

`load_mesh` reads OBJ, PLY, STL, OFF, GLB/GLTF through trimesh after checks of its own (missing,
empty or oversized files; PLY headers that declare more data than the file holds are refused
before trimesh allocates; OBJ face indices that are 0 or point past the vertices are refused
with the line, where trimesh would build a wrong triangle or fail without saying where). The
procedural shapes (`icosphere`, `torus`, `bunny_like`) are made by code, so the tests and
notebooks need no downloaded models.
"""

from __future__ import annotations

import codecs
import os
import re
import struct
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from cumuli._util import validate as check

#: Extensions `load_mesh` accepts.
MESH_FORMATS = (".obj", ".ply", ".stl", ".off", ".glb", ".gltf")
#: Largest mesh file read (bytes).
MAX_MESH_BYTES = 1 << 30
#: Most vertices / faces a mesh may declare or hold.
MAX_MESH_ELEMENTS = 1 << 24

_PLY_SIZES = {
    "char": 1, "uchar": 1, "int8": 1, "uint8": 1,
    "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
    "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4,
    "double": 8, "float64": 8,
}  # fmt: skip


def _mesh_arrays(vertices: Any, faces: Any) -> tuple[np.ndarray, np.ndarray]:
    """Validate ``(V, 3)`` vertices and ``(F, 3)`` integer faces; return float32 / int64 arrays."""
    # Bounded so that barycentres, scaled vertices and squared distances stay finite in float32.
    verts = check.points3(vertices, "vertices", allow_empty=False, bound=check.MAX_COORD)
    if verts.shape[0] > MAX_MESH_ELEMENTS:
        raise ValueError(f"vertices: {verts.shape[0]} rows, more than {MAX_MESH_ELEMENTS}")
    f = np.asarray(faces)
    if f.dtype.kind not in "iu":
        raise TypeError(f"faces must be an integer array, got dtype {f.dtype}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces must have shape (F, 3), got {f.shape}")
    if f.shape[0] == 0:
        raise ValueError("faces must not be empty")
    if f.shape[0] > MAX_MESH_ELEMENTS:
        raise ValueError(f"faces: {f.shape[0]} rows, more than {MAX_MESH_ELEMENTS}")
    if f.dtype.kind == "u" and f.max() > np.iinfo(np.int64).max:
        raise ValueError("faces: index out of range")
    f = np.ascontiguousarray(f, dtype=np.int64)
    lo, hi = int(f.min()), int(f.max())
    if lo < 0:
        raise ValueError(f"faces: negative vertex index {lo}")
    if hi >= verts.shape[0]:
        raise ValueError(f"faces: vertex index {hi} out of range for {verts.shape[0]} vertices")
    return verts, f


def _check_ply_header(path: Path, size: int) -> None:
    """Refuse a PLY whose header declares more elements than its bytes could hold."""
    with open(path, "rb") as fh:
        head = fh.read(65536)
    if not head.startswith(b"ply"):
        raise ValueError(f"{path.name}: not a PLY file (no 'ply' magic)")
    end = head.find(b"end_header")
    if end < 0:
        raise ValueError(f"{path.name}: PLY header has no end_header (truncated or not PLY)")
    nl = head.find(b"\n", end)
    body = size - (nl + 1 if nl >= 0 else end + len(b"end_header"))
    text = head[:end].decode("ascii", errors="replace")
    fmt = re.search(r"^format\s+(\S+)", text, re.M)
    if fmt is None:
        raise ValueError(f"{path.name}: PLY header has no format line")
    binary = fmt.group(1) != "ascii"
    need = 0
    element: str | None = None
    count = 0
    row = 0
    for line in text.splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "element" and len(parts) == 3:
            need += count * row
            element = parts[1]
            try:
                count = int(parts[2])
            except ValueError:
                raise ValueError(f"{path.name}: bad PLY element count {parts[2]!r}") from None
            if count < 0 or count > MAX_MESH_ELEMENTS:
                raise ValueError(
                    f"{path.name}: PLY declares {count} {element} elements "
                    f"(limit {MAX_MESH_ELEMENTS})"
                )
            row = 0
        elif parts[0] == "property" and element is not None:
            if binary:
                if parts[1] == "list" and len(parts) >= 5:
                    # Smallest possible row: the count plus three indices for a triangle.
                    row += _PLY_SIZES.get(parts[2], 1) + 3 * _PLY_SIZES.get(parts[3], 1)
                else:
                    row += _PLY_SIZES.get(parts[1], 1)
            else:
                row += 2 if parts[1] != "list" else 8  # "v " per value, "3 a b c " per list
    need += count * row
    if need > body:
        raise ValueError(
            f"{path.name}: PLY header declares at least {need} bytes of data but the file holds "
            f"{body} (truncated or corrupt)"
        )


def _obj_face_fault(where: str, parts: list[bytes], vertices: int) -> str | None:
    """What is wrong with one OBJ face line split into ``parts`` (None: nothing)."""
    if len(parts) < 4:
        return f"{where}: a face needs at least 3 vertices"
    forms = set()
    for token in parts[1:]:
        fields = token.split(b"/")
        bad = f"{where}: bad face vertex {token.decode(errors='replace')!r}"
        if len(fields) > 3:
            return bad
        # a, a/b, a//c or a/b/c: trimesh turns a face mixing them into garbage.
        forms.add((len(fields), len(fields) > 1 and fields[1] != b""))
        if len(forms) > 1:
            return f"{where}: a face mixes the forms a, a/b, a//c, a/b/c"
        try:
            index = int(fields[0])
            for extra in fields[1:]:
                if extra:
                    int(extra)
        except ValueError:
            return bad
        if index == 0:
            return f"{where}: face index 0 (OBJ indices start at 1)"
        if index < 0 and -index > vertices:
            return (
                f"{where}: relative face index {index} but only {vertices} vertices are "
                "defined before it"
            )
    return None


def _obj_statements(lines: Iterable[bytes]) -> Iterator[tuple[int, bytes, list[bytes]]]:
    """``(line, text, tokens)`` of each ``v`` and ``f`` statement of an OBJ file, comments removed
    and continued lines (ending in a backslash) joined; ``line`` is where the statement starts."""
    pending = b""
    start = 0
    for lineno, raw in enumerate(lines, 1):
        head = raw[:2]
        # Plain vertex and face lines (nearly all of a file) take no further work.
        if (head == b"v " or head == b"f ") and not pending and b"#" not in raw:
            if not raw.rstrip().endswith(b"\\"):
                yield lineno, raw, raw.split()
                continue
        if not pending:
            start = lineno
        if b"#" in raw:
            raw = raw.split(b"#", 1)[0]
        line = pending + raw.rstrip()
        if line.endswith(b"\\"):
            pending = line[:-1] + b" "
            continue
        pending = b""
        parts = line.split()
        if parts and parts[0] in (b"v", b"f"):
            yield start, line, parts


def _obj_faces_plainly_valid(lines: Iterable[bytes]) -> bool:
    """True when no face of the file is at fault (False: `_scan_obj_faces` finds where).

    Faces ``f a b c`` (what exporters write) are checked in bulk, all their indices converted at
    once: a Python loop over tokens would cost several times trimesh's own parse.
    """
    vertices = 0
    tokens: list[bytes] = []
    for _, text, parts in _obj_statements(lines):
        if parts[0] == b"v":
            vertices += 1
        elif len(parts) >= 4 and b"/" not in text and b"-" not in text:
            tokens.extend(parts[1:])
        elif _obj_face_fault("", parts, vertices) is not None:
            return False
        else:
            tokens.extend(t.split(b"/", 1)[0] for t in parts[1:] if t[:1] != b"-")
    try:
        indices = list(map(int, tokens))
    except ValueError:
        return False
    return not indices or (min(indices) > 0 and max(indices) <= vertices)


def _scan_obj_faces(name: str, lines: Iterable[bytes]) -> None:
    """Check every face line by line; ``ValueError`` naming the file and line of the first fault."""
    vertices = 0
    farthest = (0, 0)  # (largest index, its line): forward references are allowed
    for line, _, parts in _obj_statements(lines):
        if parts[0] == b"v":
            vertices += 1
            continue
        fault = _obj_face_fault(f"{name}, line {line}", parts, vertices)
        if fault is not None:
            raise ValueError(fault)
        for token in parts[1:]:
            index = int(token.split(b"/", 1)[0])
            if index > farthest[0]:
                farthest = (index, line)
    if farthest[0] > vertices:
        raise ValueError(
            f"{name}, line {farthest[1]}: face index {farthest[0]} is out of range: the file "
            f"has {vertices} vertices"
        )


def _check_obj_faces(path: Path) -> None:
    """Refuse OBJ faces whose vertex indices trimesh would misread, naming the file and line.

    OBJ indices are 1-based (``f a``, ``f a/b``, ``f a//c``, ``f a/b/c``; negative ones count back
    from the last vertex defined so far). trimesh takes an index 0 as a valid vertex (a wrong
    triangle, silently), fails on indices past the end without saying where, and scrambles a
    face that mixes the forms. Only the vertex index ``a`` decides the geometry, so texture and
    normal indices are only checked to be integers.
    """
    with open(path, "rb") as fh:
        if _obj_faces_plainly_valid(fh):
            return
    with open(path, "rb") as fh:  # something is wrong: find the line
        _scan_obj_faces(path.name, fh)


def _check_kind(path: Path, ext: str, size: int) -> None:
    """Refuse what is not a mesh of its extension before trimesh reads it (trimesh reports a
    binary .obj / .off / .stl as "No module named charset_normalizer", a text .off as an
    unpacking error)."""
    if ext == ".stl":
        with open(path, "rb") as fh:
            head = fh.read(84)
        if len(head) == 84 and 84 + 50 * struct.unpack("<I", head[80:84])[0] == size:
            return  # a binary STL: header, count and 50 bytes per triangle
        if not head.lstrip().lower().startswith(b"solid"):
            raise ValueError(
                f"{path.name}: not a mesh (neither a binary STL of consistent size nor an ASCII "
                "STL starting with 'solid')"
            )
    if ext in (".obj", ".off", ".stl"):  # text formats (and ASCII STL): UTF-8 text
        decoder = codecs.getincrementaldecoder("utf-8")()
        try:
            with open(path, "rb") as fh:
                while block := fh.read(1 << 20):
                    if b"\0" in block:
                        raise UnicodeDecodeError("utf-8", block, 0, 1, "NUL byte")
                    decoder.decode(block)
            decoder.decode(b"", final=True)
        except UnicodeDecodeError:
            raise ValueError(
                f"{path.name}: not a mesh (a {ext} file is text, and this one is not UTF-8 text)"
            ) from None
    if ext == ".off":
        with open(path, "rb") as fh:
            words = [line.split(b"#", 1)[0].strip() for line in fh.readlines(4096)]
        first = next((w for w in words if w), b"")
        if not first.upper().endswith(b"OFF"):  # OFF, COFF, NOFF, STOFF...
            raise ValueError(f"{path.name}: not a mesh (an OFF file starts with 'OFF')")


def load_mesh(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh file; returns ``(vertices (V, 3) float32, faces (F, 3) int64)``.

    Scenes (GLB/GLTF, multi-object OBJ) are flattened into one mesh. Raises
    ``FileNotFoundError`` for a missing file and ``ValueError`` naming the file for an empty,
    oversized, truncated or unreadable one, or one without triangles; for an OBJ face index
    that is 0 or out of range, the message names the line too.
    """
    import trimesh

    p = Path(os.fspath(path))
    ext = p.suffix.lower()
    if ext not in MESH_FORMATS:
        raise ValueError(f"unsupported mesh format {ext!r}; use one of {MESH_FORMATS}")
    if not p.exists():
        raise FileNotFoundError(f"no such mesh file: {str(p)!r}")
    if not p.is_file():
        raise OSError(f"not a file: {str(p)!r}")
    size = p.stat().st_size
    if size == 0:
        raise ValueError(f"{p.name}: empty file")
    if size > MAX_MESH_BYTES:
        raise ValueError(f"{p.name}: {size} bytes, more than the limit {MAX_MESH_BYTES}")
    _check_kind(p, ext, size)
    if ext == ".ply":
        _check_ply_header(p, size)
    elif ext == ".obj":
        _check_obj_faces(p)
    try:
        mesh = trimesh.load(str(p), force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types for corrupt files
        raise ValueError(
            f"{p.name}: not a mesh, or a corrupt one (trimesh: {type(exc).__name__}: {exc})"
        ) from None
    faces = getattr(mesh, "faces", None)
    vertices = getattr(mesh, "vertices", None)
    if faces is None or vertices is None or len(faces) == 0:
        raise ValueError(f"{p.name}: no triangles found (empty, truncated or not a mesh)")
    try:
        return _mesh_arrays(np.asarray(vertices), np.asarray(faces))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{p.name}: invalid mesh data: {exc}") from None


def icosphere(subdivisions: int = 2, radius: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A geodesic sphere: ``20 · 4^subdivisions`` triangles."""
    import trimesh

    subdivisions = check.integer(subdivisions, "subdivisions", 0, 6)
    radius = check.real(radius, "radius", 0.0, lo_open=True)
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return m.vertices.astype(np.float32), m.faces.astype(np.int64)


def torus(
    major_radius: float = 2.0, minor_radius: float = 0.7, sections: int = 24
) -> tuple[np.ndarray, np.ndarray]:
    """A torus around the y axis: ``2 · sections · sections // 2`` triangles."""
    import trimesh

    major = check.real(major_radius, "major_radius", 0.0, lo_open=True)
    minor = check.real(minor_radius, "minor_radius", 0.0, lo_open=True)
    sections = check.integer(sections, "sections", 3, 512)
    m = trimesh.creation.torus(major, minor, major_sections=sections,
                               minor_sections=max(3, sections // 2))  # fmt: skip
    # trimesh builds it around z; rotate (x, y, z) → (x, z, −y), a proper rotation, so that it
    # lies flat around +y with its winding unchanged.
    v = m.vertices[:, [0, 2, 1]] * np.array([1.0, 1.0, -1.0])
    return v.astype(np.float32), m.faces.astype(np.int64)


def bunny_like(subdivisions: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """A blobby rabbit made of overlapping stretched spheres (body, head, ears, tail, feet).

    Facing +x, sitting on y = 0, about 3 units long; ``7 · 20 · 4^subdivisions`` triangles
    (2240 at the default, like the paper's rabbit before its 80 % decimation). The parts are
    separate shells, which is all the mesh → ellipsoid method needs.
    """
    import trimesh

    subdivisions = check.integer(subdivisions, "subdivisions", 0, 5)
    # (centre, radii, tilt about z in degrees) of each part.
    parts = [
        ((0.0, 0.75, 0.0), (1.1, 0.75, 0.7), 10.0),  # body
        ((1.05, 1.45, 0.0), (0.5, 0.42, 0.4), -10.0),  # head
        ((0.95, 2.15, 0.17), (0.13, 0.55, 0.08), -12.0),  # left ear
        ((0.95, 2.15, -0.17), (0.13, 0.55, 0.08), -18.0),  # right ear
        ((-1.1, 0.85, 0.0), (0.22, 0.22, 0.22), 0.0),  # tail
        ((0.65, 0.15, 0.35), (0.35, 0.15, 0.15), 0.0),  # front feet
        ((0.65, 0.15, -0.35), (0.35, 0.15, 0.15), 0.0),
    ]
    verts, faces = [], []
    offset = 0
    for centre, radii, tilt in parts:
        m = trimesh.creation.icosphere(subdivisions=subdivisions)
        t = np.radians(tilt)
        rot = np.array([[np.cos(t), -np.sin(t), 0], [np.sin(t), np.cos(t), 0], [0, 0, 1]])
        v = (m.vertices * np.array(radii)) @ rot.T + np.array(centre)
        verts.append(v)
        faces.append(m.faces + offset)
        offset += len(v)
    return np.concatenate(verts).astype(np.float32), np.concatenate(faces).astype(np.int64)
