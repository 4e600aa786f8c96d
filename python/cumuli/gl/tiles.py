"""Full-screen GL passes drawn tile by tile (the renderers' draws: each tile short on software
GL and under driver timeouts), read back with row 0 on top and timed by the context's query."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from cumuli._util import progress as _progress
from cumuli.gl.context import GLContext


class Tiles:
    """Draws a full-screen pass tile by tile into a reused RGBA32F framebuffer and reads it back
    with row 0 on top (each fragment computes its whole-image pixel from ``u_tile_origin`` and
    ``u_tile_height``, so tiling changes nothing). Times the draws with the context's query."""

    def __init__(self, gl: GLContext, tile: int) -> None:
        self.gl = gl
        self.tile = tile
        self._fbo: Any = None
        self._tex: Any = None
        self._size = (0, 0)
        #: GPU time of the last draw's tiles in nanoseconds; None when a draw could not be timed.
        self.last_gpu_ns: int | None = None
        #: The progress setting of the render in progress (a bar over the tiles).
        self.progress: bool | None = None

    def _framebuffer(self, w: int, h: int) -> Any:
        if self._size != (w, h):
            self.release()
            self._tex = self.gl.ctx.texture((w, h), 4, dtype="f4")
            self._fbo = self.gl.ctx.framebuffer(color_attachments=[self._tex])
            self._size = (w, h)
        return self._fbo

    def draw(self, vao: Any, set_uniform: Callable[[str, Any], None], width: int, height: int):
        import moderngl

        out = np.empty((height, width, 4), np.float32)
        tw, th = min(self.tile, width), min(self.tile, height)
        fbo = self._framebuffer(tw, th)
        fbo.use()
        query = self.gl.timer_query()
        total: int | None = 0
        tiles = [(y0, x0) for y0 in range(0, height, th) for x0 in range(0, width, tw)]
        steps = _progress.bar(
            tiles, desc="render (gl)", unit="tile",
            progress=self.progress if len(tiles) > 1 else False,
        )  # fmt: skip
        for y0, x0 in steps:  # y0: top row of the tile
            h = min(th, height - y0)
            w = min(tw, width - x0)
            fbo.viewport = (0, 0, w, h)
            set_uniform("u_tile_origin", (x0, y0))
            set_uniform("u_tile_height", h)
            with query:
                vao.render(mode=moderngl.TRIANGLES, vertices=3)
                # Software rasterisers (llvmpipe) defer the draw until a flush, so without
                # this the query would time the submission, not the work.
                self.gl.ctx.finish()
            elapsed = int(query.elapsed)
            # 2³²−1: a query that could not be timed (moderngl reads 32 bits: a tile longer
            # than 4.29 s; a context's first timed draw on llvmpipe, which GLContext warms up).
            if total is not None and 0 <= elapsed < 0xFFFFFFFF:
                total += elapsed
            else:
                total = None
            data = fbo.read(viewport=(0, 0, w, h), components=4, dtype="f4")
            tile = np.frombuffer(data, np.float32).reshape(h, w, 4)
            out[y0 : y0 + h, x0 : x0 + w] = tile[::-1]
        self.last_gpu_ns = total
        return out

    def release(self) -> None:
        if not self.gl.closed:
            for obj in (self._fbo, self._tex):
                if obj is not None:
                    obj.release()
        self._fbo = self._tex = None
        self._size = (0, 0)
