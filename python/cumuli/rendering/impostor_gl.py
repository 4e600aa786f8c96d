"""GL display of impostors (Harris 2002 §3): textures from a pool, one quad
per impostor drawn back to front (``shaders/impostors/impostor.{vert,frag}.glsl``).

Each impostor's image is uploaded once when it is (re)generated into an RGBA32F texture taken
from a :class:`TexturePool` of textures by size (SkyWorks keeps power-of-two textures and returns
them when a cloud has been culled for 100 frames; :class:`~cumuli.rendering.impostor_cache.
ImpostorCache` decides when). A frame's impostors are drawn in order into a premultiplied layer
with (ONE, ONE_MINUS_SRC_ALPHA) blending: hardware bilinear sampling by default, or texelFetch
blends with the C++ arithmetic (``exact``) — the twin of ``_core.display_impostors``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import moderngl
import numpy as np

from cumuli import _core
from cumuli.camera import Camera
from cumuli.gl import GLContext

#: Free textures kept per size (beyond that a returned texture is released).
POOL_FREE = 32


def quad_planes(quads: Sequence[Any]) -> tuple[np.ndarray, np.ndarray]:
    """``(planes (n, 14), clamp (n,))`` of impostor quads (objects with ``plane`` and ``clamp``):
    centre, forward, right, up, half width, half height."""
    planes = np.array([q.plane for q in quads], np.float32).reshape(-1, 14)
    clamp = np.array([q.clamp for q in quads], bool)
    return planes, clamp


class TexturePool:
    """RGBA32F textures by size, reused across impostors."""

    def __init__(self, gl: GLContext) -> None:
        self.gl = gl
        self._free: dict[tuple[int, int], list[Any]] = {}
        #: Textures made and released since the pool was created.
        self.made = 0
        self.released = 0

    def acquire(self, width: int, height: int) -> Any:
        free = self._free.get((width, height))
        if free:
            return free.pop()
        tex = self.gl.ctx.texture((width, height), 4, dtype="f4")
        tex.repeat_x = tex.repeat_y = False  # clamp to edge
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.made += 1
        return tex

    def give_back(self, tex: Any) -> None:
        free = self._free.setdefault(tex.size, [])
        if len(free) < POOL_FREE:
            free.append(tex)
        else:
            tex.release()
            self.released += 1

    @property
    def free(self) -> int:
        return sum(len(v) for v in self._free.values())

    def release(self) -> None:
        if not self.gl.closed:
            for textures in self._free.values():
                for tex in textures:
                    tex.release()
        self._free.clear()


class ImpostorDisplayGL:
    """Draws impostor quads (objects with ``image``, ``plane``, ``clamp``, ``version`` and a
    ``gl_texture`` slot) into a premultiplied layer."""

    def __init__(self, gl: GLContext, tiles: Any) -> None:
        self.gl = gl
        self.tile = tiles.tile
        self.program = gl.program("impostors/impostor.vert.glsl", "impostors/impostor.frag.glsl")
        try:
            self.vao = gl.ctx.vertex_array(self.program, [])
        except Exception:
            self.program.release()
            raise
        self.pool = TexturePool(gl)
        self.gpu_time_ns: int | None = None
        # Uniforms looked up once (a name lookup walks the program's members).
        self._uniforms = {name: self.program[name] for name in self.program}

    def _set(self, name: str, value: Any) -> None:
        uniform = self._uniforms.get(name)
        if uniform is not None:
            uniform.value = value

    def _texture(self, quad: Any) -> Any:
        """The quad's texture, (re)uploaded when its image changed."""
        h, w = quad.image.shape[:2]
        tex, version = getattr(quad, "gl_texture", None) or (None, -1)
        if tex is not None and tex.size != (w, h):
            self.pool.give_back(tex)
            tex = None
        if tex is None:
            tex = self.pool.acquire(w, h)
        if tex is not None and version != quad.version:
            tex.write(np.ascontiguousarray(quad.image, np.float32).tobytes())
        quad.gl_texture = (tex, quad.version)
        return tex

    def forget(self, quad: Any) -> None:
        """Return the quad's texture to the pool."""
        slot = getattr(quad, "gl_texture", None)
        if slot is not None and slot[0] is not None and not self.gl.closed:
            self.pool.give_back(slot[0])
        quad.gl_texture = None

    def draw(
        self, quads: Sequence[Any], camera: Camera, width: int, height: int, exact: bool = False
    ) -> np.ndarray:
        """The premultiplied layer ``(height, width, 4)`` of ``quads`` drawn in order."""
        ctx = self.gl.ctx
        textures = [self._texture(q) for q in quads]
        planes, clamp = quad_planes(quads)
        rects = _core.impostor_rects(
            planes, clamp, camera.position, camera.target, camera.up, float(camera.fov), width,
            height,
        )  # fmt: skip
        for name, value in camera.uniforms(width, height).items():
            self._set(name, value)
        self._set("u_exact", bool(exact))
        self._set("u_image", 0)
        # Per impostor: (centre, hw), (forward, hh), (right, clamp), (up, 0) as the shader reads.
        quad = np.zeros((len(quads), 4, 4), np.float32)
        for a in range(4):
            quad[:, a, :3] = planes[:, 3 * a : 3 * a + 3]
        quad[:, 0, 3], quad[:, 1, 3], quad[:, 2, 3] = planes[:, 12], planes[:, 13], clamp
        blocks = [q.tobytes() for q in quad]
        u_rect, u_quad = self._uniforms["u_rect"], self._uniforms["u_quad"]
        made: list[Any] = []
        tw, th = min(self.tile, width), min(self.tile, height)
        out = np.empty((height, width, 4), np.float32)
        query = self.gl.timer_query()
        self.gpu_time_ns = 0
        try:
            colour = ctx.texture((tw, th), 4, dtype="f4")
            made.append(colour)
            fbo = ctx.framebuffer(color_attachments=[colour])
            made.append(fbo)
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)
            ctx.blend_equation = moderngl.FUNC_ADD
            for y0 in range(0, height, th):
                for x0 in range(0, width, tw):
                    w, h = min(tw, width - x0), min(th, height - y0)
                    fbo.use()
                    ctx.viewport = (0, 0, w, h)
                    fbo.clear(0.0, 0.0, 0.0, 0.0, viewport=(0, 0, w, h))
                    self._set("u_tile_origin", (x0, y0))
                    self._set("u_tile_size", (w, h))
                    self._set("u_tile_height", h)
                    with query:
                        for tex, block, rect in zip(textures, blocks, rects, strict=True):
                            j0, j1, i0, i1 = (int(v) for v in rect)
                            # The part of the rectangle inside this tile.
                            j0, j1 = max(j0, x0), min(j1, x0 + w - 1)
                            i0, i1 = max(i0, y0), min(i1, y0 + h - 1)
                            if j0 > j1 or i0 > i1:
                                continue
                            tex.use(location=0)
                            u_rect.value = (j0, i0, j1, i1)
                            u_quad.write(block)
                            self.vao.render(moderngl.TRIANGLES, vertices=6)
                        ctx.finish()
                    self.gpu_time_ns += int(query.elapsed)
                    data = fbo.read(viewport=(0, 0, w, h), components=4, dtype="f4")
                    out[y0 : y0 + h, x0 : x0 + w] = np.frombuffer(data, np.float32).reshape(
                        h, w, 4
                    )[::-1]
        finally:
            ctx.disable(moderngl.BLEND)
            for obj in made:
                obj.release()
        return out

    def release(self) -> None:
        self.pool.release()
        if not self.gl.closed:
            for obj in (self.vao, self.program):
                try:
                    obj.release()
                except Exception:
                    pass
