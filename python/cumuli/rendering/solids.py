"""Opaque solids drawn per pixel (Harris 2002 §3.1.1).

The solid image of a scene's :class:`cumuli.Solid` spheres — ``(H, W, 4)`` float32, row 0 on
top, rgb shaded Lambert by the sun plus ambient, alpha the **view depth** of the nearest solid
(+∞ where none) — made by the GLSL ``shaders/solids/solid.frag.glsl`` (:class:`SolidsGL`) or its
C++ twin ``_core.draw_solids`` (:func:`draw_solids_cpu`). The compositor lets a solid hide the
layers entered behind it; the marchers stop their rays at it (``common/solid.glsl``); particle
sprites are depth-tested against the view depth; :func:`composite_split` puts solids between the
layers of a split impostor ([H]: "layer m, object m, layer m−1, …, object 1, layer 0").
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli.camera import Camera
from cumuli.gl import GLContext
from cumuli.model.solid import MAX_SOLIDS, Solid, solid_arrays
from cumuli.sky import Sun


def set_solid_uniforms(program: Any, solids: Sequence[Solid], colours: bool = False) -> None:
    """Set ``u_solid_count`` and ``u_solid_sphere`` (and, with ``colours``, the shading arrays)
    of a program that includes ``common/solid.glsl``."""
    spheres, colour, ambient = solid_arrays(solids)
    n = len(solids)
    if "u_solid_count" in program:
        program["u_solid_count"].value = n
    for name, values, width in (
        ("u_solid_sphere", spheres, 4),
        ("u_solid_colour", colour, 3),
        ("u_solid_ambient", ambient, 3),
    ):
        if name == "u_solid_sphere" or colours:
            if name in program:
                full = np.zeros((MAX_SOLIDS, width), np.float32)
                full[:n] = values
                uniform = program[name]
                size = uniform.array_length
                uniform.write(full[:size].tobytes())


def draw_solids_cpu(
    solids: Sequence[Solid], sun: Sun, camera: Camera, width: int, height: int, threads: int = 0
) -> np.ndarray:
    """The solid image by the C++ twin (``_core.draw_solids``)."""
    spheres, colours, ambient = solid_arrays(solids)
    return _core.draw_solids(
        spheres, colours, ambient, camera.position, camera.target, camera.up, float(camera.fov),
        width, height, sun.direction, sun.radiance, check.threads(threads),
    )  # fmt: skip


def solid_depth(image: np.ndarray) -> np.ndarray:
    """The view depths ``(H, W)`` of a solid image (what particle sprites are depth-tested
    against)."""
    return np.ascontiguousarray(image[..., 3])


class SolidsGL:
    """The GL solid image: ``shaders/solids/solid.frag.glsl`` drawn tile by tile."""

    def __init__(self, gl: GLContext, tiles: Any) -> None:
        self.gl = gl
        self.tiles = tiles
        self.program = gl.program("common/fullscreen.vert.glsl", "solids/solid.frag.glsl")
        try:
            self.vao = gl.ctx.vertex_array(self.program, [])
        except Exception:
            self.program.release()
            raise

    def _set(self, name: str, value: Any) -> None:
        if name in self.program:
            self.program[name].value = value

    def draw(
        self, solids: Sequence[Solid], sun: Sun, camera: Camera, width: int, height: int
    ) -> np.ndarray:
        """The solid image ``(height, width, 4)`` (rgb, view depth; +∞ where none)."""
        for name, value in camera.uniforms(width, height).items():
            self._set(name, value)
        self._set("u_sun_dir", sun.direction)
        self._set("u_sun_radiance", sun.radiance)
        set_solid_uniforms(self.program, solids, colours=True)
        return self.tiles.draw(self.vao, self._set, width, height)

    def release(self) -> None:
        if not self.gl.closed:
            for obj in (self.vao, self.program):
                try:
                    obj.release()
                except Exception:
                    pass


def solids_inside(solids: Sequence[Solid], centre: Sequence[float], radius: float) -> list[int]:
    """Indices of the solids whose centre lies inside the sphere ``(centre, radius)`` — the
    objects a cloud's impostor is split around ([H] §3.1.1: "objects whose reference point lies
    inside the cloud's bounding volume")."""
    c = np.asarray(centre, dtype=np.float64)
    return [
        k for k, s in enumerate(solids) if float(np.linalg.norm(np.subtract(s.centre, c))) < radius
    ]


def composite_split(layers: np.ndarray, solids: np.ndarray, threads: int = 0) -> np.ndarray:
    """[H] §3.1.1's split composite (C++): ``layers`` ``(m + 1, H, W, 4)`` premultiplied, farthest
    first; ``solids`` ``(m, H, W, 4)`` solid images, ``solids[j]`` between ``layers[j]`` and
    ``layers[j + 1]``; solids depth-tested among themselves, layers blended over. One layer."""
    return _core.composite_split(
        np.ascontiguousarray(layers, np.float32),
        np.ascontiguousarray(solids, np.float32),
        check.threads(threads),
    )
