"""Mesh → ellipsoids (Jiménez de Parga & Gómez Palomo 2018, §3.6.4, eqs. 22–30).

`ellipsoids_from_mesh` places one ellipsoid per triangle at its barycentre (vertices scaled about
it, radii from the scaled vertex distances, the longest axis rotated onto the farthest vertex by
Rodrigues' formula) in the C++ core; `mesh_cloud` reads a mesh file (or takes arrays), decimates
it to a target face count and builds the cloud.
"""

from __future__ import annotations

import hashlib
import os
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli._util.validate import MAX_COORD
from cumuli.model.cloud import MAX_PRIMITIVES, Cloud


def _default_min_radius(vertices: np.ndarray) -> float:
    """1e-4 of the mesh's bounding-box diagonal (1e-6 for a single point), never below the
    smallest normal float32 (the core takes it as float32: a subnormal mesh must not floor its
    radii at 0)."""
    diag = float(np.linalg.norm(vertices.max(axis=0).astype(np.float64) - vertices.min(axis=0)))
    return max(1e-4 * diag, float(np.finfo(np.float32).tiny)) if diag > 0 else 1e-6


def ellipsoids_from_mesh(
    vertices: Any,
    faces: Any,
    scale: float = 1.0,
    rotate: bool = True,
    min_radius: float | None = None,
    threads: int = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One ellipsoid per triangle (§3.6.4, eqs. 22–30); returns ``(centres, radii, rotations)``.

    For a triangle ``(P1, P2, P3)`` with barycentre ``B`` (eq. 22), the vertices are scaled about
    ``B`` by ``scale`` ∈ (0, 2] (eq. 23), and the radii along the local x, y, z axes are the
    distances ``|B − P'i|`` (eq. 24). With ``rotate`` the longest local axis is turned onto the
    direction of the farthest scaled vertex by Rodrigues' formula (eqs. 25–30); otherwise the
    rotations are the identity. Radii are floored at ``min_radius`` (default 1e-4 of the mesh's
    bounding-box diagonal) so degenerate triangles give small valid ellipsoids, never NaN.

    ``vertices`` is ``(V, 3)`` real with components within ``±MAX_COORD`` (1e15), ``faces``
    ``(F, 3)`` integer indices into it. Arrays are
    float32 ``(F, 3)``, ``(F, 3)`` and ``(F, 3, 3)`` (rotation columns are the ellipsoid axes).
    """
    from cumuli.io.meshes import _mesh_arrays

    verts, f = _mesh_arrays(vertices, faces)
    rotate = check.flag(rotate, "rotate")
    if f.shape[0] > MAX_PRIMITIVES:
        raise ValueError(f"faces: {f.shape[0]} faces, more than a cloud holds ({MAX_PRIMITIVES})")
    scale = check.real(scale, "scale", 0.0, 2.0, lo_open=True)
    if min_radius is None:
        min_radius = _default_min_radius(verts)
    min_radius = check.real(min_radius, "min_radius", 0.0, MAX_COORD, lo_open=True)
    centres, radii, rotations, _ = _core.ellipsoids_from_mesh(
        verts, f, scale, bool(rotate), min_radius, check.threads(threads)
    )
    return centres, radii, rotations


def mesh_cloud(
    source: Any,
    scale: float = 1.0,
    target_faces: int | None = None,
    rotate: bool = True,
    min_radius: float | None = None,
    model: str = "spheroid",
    kappa: float = 0.5,
    phi: float = 0.6,
    threads: int = 0,
) -> Cloud:
    """A cloud of ellipsoids from a triangle mesh (§3.6.4, Figs. 14–15).

    ``source`` is a path (OBJ, PLY, STL, OFF, GLB/GLTF, read by `cumuli.io.meshes.load_mesh`), a
    ``trimesh.Trimesh`` or a ``(vertices, faces)`` pair. With ``target_faces`` the mesh is first
    decimated to about that many faces by trimesh's quadric decimation (the paper uses 300–700;
    needs the ``fast-simplification`` package); meshes already that small are kept. Then one
    ellipsoid per face, see `ellipsoids_from_mesh`.

    ``params`` records the source (path, or a SHA-256 of the arrays) and the arguments; ``stats``
    has ``faces_in``, ``faces`` (after decimation) and ``floored_faces`` (degenerate triangles).
    """
    from cumuli.io.meshes import _mesh_arrays, load_mesh

    rotate = check.flag(rotate, "rotate")
    if isinstance(source, (str, os.PathLike)):
        verts, f = load_mesh(source)
        origin: Any = os.fspath(source)
    else:
        if hasattr(source, "vertices") and hasattr(source, "faces"):
            pair = (source.vertices, source.faces)
        elif isinstance(source, (tuple, list)) and len(source) == 2:
            pair = (source[0], source[1])
        else:
            raise TypeError(
                "source must be a path, a trimesh.Trimesh or a (vertices, faces) pair, "
                f"got {type(source).__name__}"
            )
        verts, f = _mesh_arrays(*pair)
        digest = hashlib.sha256(verts.tobytes() + f.tobytes()).hexdigest()
        origin = {"sha256": digest, "vertices": int(verts.shape[0]), "faces": int(f.shape[0])}
    faces_in = int(f.shape[0])
    if target_faces is not None:
        target_faces = check.integer(target_faces, "target_faces", 4, MAX_PRIMITIVES)
        if target_faces < faces_in:
            verts, f = _decimate(verts, f, target_faces)
    if min_radius is None:
        min_radius = _default_min_radius(verts)
    scale = check.real(scale, "scale", 0.0, 2.0, lo_open=True)
    min_radius = check.real(min_radius, "min_radius", 0.0, MAX_COORD, lo_open=True)
    centres, radii, rotations, core_stats = _core.ellipsoids_from_mesh(
        verts, f, scale, bool(rotate), min_radius, check.threads(threads)
    )
    return Cloud(
        centres,
        radii,
        rotations,
        model=model,
        kappa=kappa,
        phi=phi,
        stats={
            "faces_in": faces_in,
            "faces": int(core_stats["faces"]),
            "floored_faces": int(core_stats["floored_faces"]),
        },
        params={
            "generator": "mesh_cloud",
            "args": {
                "source": origin,
                "scale": scale,
                "target_faces": target_faces,
                "rotate": bool(rotate),
                "min_radius": min_radius,
                "model": model,
                "kappa": kappa,
                "phi": phi,
            },
        },
    )


def _decimate(verts: np.ndarray, faces: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Quadric decimation to about ``target`` faces through trimesh (fast-simplification)."""
    import trimesh

    from cumuli.io.meshes import _mesh_arrays

    mesh = trimesh.Trimesh(vertices=verts, faces=faces, process=False)
    try:
        small = mesh.simplify_quadric_decimation(face_count=target)
    except ImportError as exc:
        raise ImportError(
            "target_faces needs the fast-simplification package (pip install fast-simplification)"
        ) from exc
    if len(small.faces) == 0:
        raise ValueError(f"decimation to {target} faces left no triangles")
    return _mesh_arrays(np.asarray(small.vertices), np.asarray(small.faces))
