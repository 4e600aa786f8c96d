"""The shared sprite pipeline: view-plane-parallel sprites into a premultiplied layer.

Serves Harris 2002 particle splats (analytic kernel, one colour per sprite,
alpha ``1 − e^{−τ}``) and Torchelsen & Musse 2005 billboards (rotated
w×h quads, straight-alpha atlas cells sampled bilinearly, per-vertex colours, alpha multiplier).
:class:`Sprites` holds a batch; :class:`SpriteLayerRenderer` draws it with GL
(``shaders/sprites/sprites.{vert,frag}.glsl``), :func:`draw_sprites_cpu` with the C++ twin
(``render/sprite_raster.hpp``). Both return the layer ``(H, W, 4)`` float32, row 0 on top:
``rgb = C`` (premultiplied radiance), ``alpha = A``, **without sky** — a compositor makes
``rgb = C + (1 − A)·sky``. Sprites are drawn in the given order (back to front) with
(ONE, ONE_MINUS_SRC_ALPHA) blending; see ``cpp/include/cumuli/rendering/sprites.hpp`` for the
exact per-pixel formulas.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from typing import Any

import moderngl
import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli._util.structs import core_struct
from cumuli.camera import Camera
from cumuli.gl.context import GLContext, _resolve_context
from cumuli.gl.sprite_shading import _SHADE_ATTRS, _SHADE_FORMAT, FragmentShading

KERNELS = ("gaussian", "hermite")
#: Largest tile drawn per GL draw (like the marcher) and most sprites per draw call.
TILE = 1024
MAX_SPRITES_PER_DRAW = 1 << 20
#: Most sprites in one batch.
MAX_SPRITES = 1 << 24
MAX_IMAGE = 1 << 14
# Per-instance vertex layout: centre 3f, half 2f, rotation f, alpha f, texture i, 4 colours 3f.
_FORMAT = "3f 2f 1f 1f 1i 3f 3f 3f 3f/i"
_ATTRS = (
    "in_centre",
    "in_half",
    "in_rotation",
    "in_alpha",
    "in_texture",
    "in_c0",
    "in_c1",
    "in_c2",
    "in_c3",
)
_RECORD = np.dtype(
    [
        ("centre", "<f4", 3),
        ("half", "<f4", 2),
        ("rotation", "<f4"),
        ("alpha", "<f4"),
        ("texture", "<i4"),
        ("colour", "<f4", (4, 3)),
    ]
)


@dataclass(frozen=True, eq=False)
class Sprites:
    """A batch of sprites, drawn in order (back to front). Arrays are float32 / int32.

    ``centres`` ``(N, 3)`` world; ``half_sizes`` ``(N, 2)`` world half width/height (or ``(N,)``
    for squares); ``colours`` ``(N, 3)`` one colour per sprite or ``(N, 4, 3)`` per vertex
    v0..v3 (bottom-left, bottom-right, top-right, top-left); ``alpha`` ``(N,)`` (Harris: 1 − e^{−τ};
    billboards: opacity·fade); ``rotation`` ``(N,)`` degrees about the view axis,
    counter-clockwise on screen (default 0); ``texture`` ``(N,)`` atlas cell, −1 for the analytic
    splat kernel (default −1).
    """

    centres: np.ndarray
    half_sizes: np.ndarray
    colours: np.ndarray
    alpha: np.ndarray
    rotation: np.ndarray | None = None
    texture: np.ndarray | None = None

    def __post_init__(self) -> None:
        centres = check.points3(self.centres, "centres", bound=check.MAX_COORD)
        n = centres.shape[0]
        if n > MAX_SPRITES:
            raise ValueError(f"at most {MAX_SPRITES} sprites per batch, got {n}")
        half = np.asarray(self.half_sizes)
        if half.ndim == 1:
            half = np.repeat(half.reshape(-1, 1), 2, axis=1)
        half = check.float_array(half, "half_sizes", (n, 2))
        if (half <= 0).any():
            raise ValueError("half_sizes must be positive")
        colours = np.asarray(self.colours)
        if colours.shape == (n, 3):  # one colour per sprite
            colours = np.repeat(colours[:, None, :], 4, axis=1)
        colours = check.float_array(colours, "colours", (n, 4, 3))
        alpha = check.float_array(self.alpha, "alpha", (n,))
        if (alpha < 0).any() or (alpha > 1).any():
            raise ValueError("alpha must lie in [0, 1]")
        rotation = np.zeros(n, np.float32) if self.rotation is None else self.rotation
        rotation = check.float_array(rotation, "rotation", (n,))
        texture = np.full(n, -1, np.int32) if self.texture is None else np.asarray(self.texture)
        if texture.dtype.kind not in "iu" or texture.shape != (n,):
            raise TypeError(f"texture must be an integer array of shape ({n},)")
        if (texture < -1).any():
            raise ValueError("texture must be -1 (splat kernel) or an atlas cell index >= 0")
        texture = np.ascontiguousarray(texture, dtype=np.int32)
        for name, arr in (
            ("centres", centres),
            ("half_sizes", half),
            ("colours", colours),
            ("alpha", alpha),
            ("rotation", rotation),
            ("texture", texture),
        ):
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return int(self.centres.shape[0])

    def radians(self) -> np.ndarray:
        """Rotation in radians, float32 (the value both twins use)."""
        assert self.rotation is not None
        return (self.rotation * np.float32(math.pi / 180.0)).astype(np.float32)

    def corners(self, camera: Camera) -> np.ndarray:
        """World positions ``(N, 4, 3)`` of the corners v0..v3 (bottom-left, bottom-right,
        top-right, top-left) as ``camera`` sees the sprites: ``centre ± half_w·r' ± half_h·u'``
        with ``r' = cos ψ·r + sin ψ·u``, ``u' = −sin ψ·r + cos ψ·u`` (the camera's right and up
        turned by the rotation ψ) — where per-vertex colours (e.g. billboard shading from the
        corner's position relative to the cloud) are evaluated. float64."""
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
        _, r, u = (v.astype(np.float64) for v in camera.basis())
        psi = self.radians().astype(np.float64)[:, None]
        right = np.cos(psi) * r + np.sin(psi) * u
        up = -np.sin(psi) * r + np.cos(psi) * u
        st = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], dtype=np.float64)
        half = self.half_sizes.astype(np.float64)
        offsets = (st[None, :, 0:1] * half[:, None, 0:1]) * right[:, None, :] + (
            st[None, :, 1:2] * half[:, None, 1:2]
        ) * up[:, None, :]
        return self.centres.astype(np.float64)[:, None, :] + offsets

    def records(self) -> np.ndarray:
        """The per-instance vertex records of the GL draw."""
        rec = np.empty(len(self), dtype=_RECORD)
        rec["centre"], rec["half"], rec["rotation"] = self.centres, self.half_sizes, self.radians()
        rec["alpha"], rec["texture"], rec["colour"] = self.alpha, self.texture, self.colours
        return rec


def camera_dict(camera: Camera, width: int, height: int, near: float = 1e-3) -> dict[str, Any]:
    """The camera as both twins take it: float32 basis of :meth:`Camera.basis`,
    ``tan_half = float32(tan(fov/2))``, image size and near distance."""
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
    width = check.integer(width, "width", 1, MAX_IMAGE)
    height = check.integer(height, "height", 1, MAX_IMAGE)
    near = check.real(near, "near", 0.0, 1e6, lo_open=True)
    f, r, u = camera.basis()
    return {
        "position": tuple(float(v) for v in np.asarray(camera.position, dtype=np.float32)),
        "forward": tuple(float(v) for v in f),
        "right": tuple(float(v) for v in r),
        "up": tuple(float(v) for v in u),
        "tan_half": float(np.float32(math.tan(math.radians(camera.fov) / 2))),
        "width": width,
        "height": height,
        "near": float(np.float32(near)),
    }


def _atlas_args(atlas: Any, grid: Any, sprites: Sprites) -> tuple[np.ndarray | None, tuple]:
    if atlas is None:
        if (sprites.texture >= 0).any():
            raise ValueError("sprites use atlas cells (texture >= 0) but no atlas was given")
        return None, (1, 1)
    arr = np.asarray(atlas)
    if arr.dtype.kind not in "fiu" or arr.ndim != 3 or arr.shape[2] != 4 or arr.size == 0:
        raise ValueError(f"atlas must be a non-empty (H, W, 4) RGBA image, got {arr.shape}")
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    if not np.isfinite(arr).all():
        raise ValueError("atlas contains NaN or infinite values")
    if not isinstance(grid, (tuple, list)) or len(grid) != 2:
        raise TypeError(f"atlas_grid must be (cells across, cells down), got {grid!r}")
    nx, ny = (check.integer(g, "atlas_grid", 1, 4096) for g in grid)
    if arr.shape[1] % nx or arr.shape[0] % ny:
        raise ValueError(
            f"atlas_grid {grid} must divide the atlas {arr.shape[:2]} into equal cells"
        )
    if (sprites.texture >= nx * ny).any():
        raise ValueError(f"sprite texture index beyond the atlas's {nx * ny} cells")
    return arr, (nx, ny)


def _depth_arg(depth: Any, width: int, height: int) -> np.ndarray | None:
    if depth is None:
        return None
    arr = np.asarray(depth)
    if arr.dtype.kind not in "fiu" or arr.shape != (height, width):
        raise ValueError(f"depth must be a ({height}, {width}) array of view depths")
    arr = np.ascontiguousarray(arr, dtype=np.float32)
    if np.isnan(arr).any():
        raise ValueError("depth contains NaN")
    return arr


def draw_sprites_cpu(
    sprites: Sprites,
    camera: Camera,
    width: int,
    height: int,
    *,
    kernel: str = "gaussian",
    peak: float = 1.0,
    atlas: Any = None,
    atlas_grid: tuple[int, int] = (1, 1),
    near: float = 1e-3,
    threads: int = 0,
    shading: FragmentShading | None = None,
    depth: Any = None,
) -> np.ndarray:
    """The C++ twin: the premultiplied layer ``(height, width, 4)`` (no sky) of ``sprites``;
    ``shading`` switches to per-pixel billboard shading (:class:`FragmentShading`). ``depth``
    ``(height, width)``: per-pixel view depths (e.g. of opaque solids, +∞ where none); a sprite
    then covers only the pixels where its view depth is smaller (a depth test)."""
    if not isinstance(sprites, Sprites):
        raise TypeError(f"sprites must be a Sprites batch, got {type(sprites).__name__}")
    if kernel not in KERNELS:
        raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
    peak = check.real(peak, "peak", 0.0, 1.0, lo_open=True)
    cam = camera_dict(camera, width, height, near)
    depth = _depth_arg(depth, cam["width"], cam["height"])
    arr, grid = _atlas_args(atlas, atlas_grid, sprites)
    _check_shading(shading, sprites)
    return _core.rasterise_sprites(
        sprites.centres,
        sprites.half_sizes,
        sprites.radians(),
        sprites.colours,
        sprites.alpha,
        sprites.texture,
        cam,
        core_struct(_core.SpriteRasterSettings, kernel=kernel, peak=peak),
        None if arr is None else (arr, grid),
        check.threads(threads),
        None if shading is None else shading.core_dict(),
        depth,
    )


def _check_shading(shading: Any, sprites: Sprites) -> None:
    if shading is None:
        return
    if not isinstance(shading, FragmentShading):
        raise TypeError(f"shading must be a FragmentShading, got {type(shading).__name__}")
    if len(shading) != len(sprites):
        raise ValueError(f"shading has {len(shading)} rows, the batch {len(sprites)} sprites")


def _mip_levels(arr: np.ndarray, grid: tuple[int, int]) -> int:
    """Mipmap levels of an atlas in fast mode: cells keep at least 8 texels a side, so that a
    level's texels never average two cells (cells are aligned to 2^level)."""
    cell = min(arr.shape[1] // grid[0], arr.shape[0] // grid[1])
    return max(0, int(math.floor(math.log2(max(cell, 1)))) - 3)


class SpriteLayerRenderer:
    """The GL sprite pipeline, compiled once; :meth:`draw` makes premultiplied layers.

    Images larger than ``tile`` pixels per edge are drawn in tiles (each fragment computes its
    whole-image pixel, so tiling changes nothing). Release with :meth:`release` or ``with``.
    """

    def __init__(self, context: GLContext | None = None, tile: int = TILE) -> None:
        self.context = _resolve_context(context)
        self.tile = check.integer(tile, "tile", 16, 4096)
        self.program: moderngl.Program | None = self.context.program(
            "sprites/sprites.vert.glsl", "sprites/sprites.frag.glsl"
        )
        self.gpu_time_ns: int | None = None
        self.sprites_drawn = 0
        # Atlas textures of read-only float32 arrays, by id (dropped when the array dies).
        self._atlases: dict[int, tuple[Any, Any, int]] = {}

    def _check_open(self) -> None:
        if self.program is None or self.context.closed:
            raise ValueError("this SpriteLayerRenderer has been released")

    def _set(self, name: str, value: Any) -> None:
        assert self.program is not None
        if name in self.program:
            self.program[name].value = value

    def _instances(
        self, sprites: Sprites, made: list[Any], shading: FragmentShading | None = None
    ) -> list[tuple[Any, int]]:
        """A buffer and a VAO per chunk of at most MAX_SPRITES_PER_DRAW sprites (appended to
        ``made`` for release); returns ``[(vao, count), ...]`` in drawing order."""
        ctx = self.context.ctx
        rec = sprites.records()
        shade = None
        if shading is not None:
            shade = np.empty(len(rec), dtype=[("frame", "<f4", 4), ("y", "<f4", 2), ("row", "<i4")])
            shade["frame"], shade["y"] = shading.frame, shading.yrange
            shade["row"] = np.arange(len(rec), dtype=np.int32)
        chunks = []
        for start in range(0, max(len(rec), 1), MAX_SPRITES_PER_DRAW):
            part = rec[start : start + MAX_SPRITES_PER_DRAW]
            buf = ctx.buffer(part.tobytes() if len(part) else bytes(_RECORD.itemsize))
            made.append(buf)
            content = [(buf, _FORMAT, *_ATTRS)]
            if shade is not None:
                sp = shade[start : start + MAX_SPRITES_PER_DRAW]
                sbuf = ctx.buffer(sp.tobytes() if len(sp) else bytes(shade.itemsize))
                made.append(sbuf)
                content.append((sbuf, _SHADE_FORMAT, *_SHADE_ATTRS))
            vao = ctx.vertex_array(self.program, content)
            made.append(vao)
            chunks.append((vao, len(part)))
        return chunks

    def _atlas_texture(self, arr: np.ndarray | None, source: Any, levels: int, made: list[Any]):
        """The atlas texture (a 1×1 dummy without atlas): cached for a read-only float32 array
        passed as it is (its id, while it lives), else made for this draw. ``levels`` > 0 builds
        mipmaps up to that level (fast mode)."""
        ctx = self.context.ctx
        for key in [k for k, (ref, _, _) in self._atlases.items() if ref() is None]:
            self._atlases.pop(key)[1].release()
        cacheable = arr is not None and arr is source and not arr.flags.writeable
        if cacheable and id(arr) in self._atlases:
            ref, tex, built = self._atlases[id(arr)]
            if ref() is arr:
                if levels > built:
                    tex.build_mipmaps(0, levels)
                    self._atlases[id(arr)] = (ref, tex, levels)
                return tex
        size = (arr.shape[1], arr.shape[0]) if arr is not None else (1, 1)
        data = arr.tobytes() if arr is not None else np.zeros(4, np.float32).tobytes()
        tex = ctx.texture(size, 4, data=data, dtype="f4")
        if levels > 0:
            tex.build_mipmaps(0, levels)
        if cacheable:
            self._atlases[id(arr)] = (weakref.ref(arr), tex, levels)
        else:
            made.append(tex)
        return tex

    def _bind_camera(self, cam: dict[str, Any] | None, width: int, height: int) -> None:
        self._set("u_screen_space", cam is None)
        self._set("u_image_size", (width, height))
        if cam is not None:
            self._set("u_cam_pos", cam["position"])
            self._set("u_cam_f", cam["forward"])
            self._set("u_cam_r", cam["right"])
            self._set("u_cam_u", cam["up"])
            self._set("u_th", cam["tan_half"])
            self._set("u_near", cam["near"])

    def draw(
        self,
        sprites: Sprites,
        camera: Camera,
        width: int,
        height: int,
        *,
        kernel: str = "gaussian",
        peak: float = 1.0,
        atlas: Any = None,
        atlas_grid: tuple[int, int] = (1, 1),
        exact: bool = True,
        near: float = 1e-3,
        shading: FragmentShading | None = None,
        depth: Any = None,
    ) -> np.ndarray:
        """The premultiplied layer ``(height, width, 4)`` of ``sprites`` (no sky).

        ``exact=True`` samples atlas cells with texelFetch blends (the C++ twin's arithmetic);
        ``False`` uses the hardware filter, trilinear over mipmaps whose coarsest level keeps 8
        texels per cell (faster, smoother when sprites are small; looser parity). ``shading``:
        per-pixel billboard shading (:class:`FragmentShading`) in place of the vertex colours.
        ``depth``: as :func:`draw_sprites_cpu` (a per-pixel depth test).
        """
        self._check_open()
        if not isinstance(sprites, Sprites):
            raise TypeError(f"sprites must be a Sprites batch, got {type(sprites).__name__}")
        if kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}, got {kernel!r}")
        peak = check.real(peak, "peak", 0.0, 1.0, lo_open=True)
        cam = camera_dict(camera, width, height, near)
        arr, grid = _atlas_args(atlas, atlas_grid, sprites)
        _check_shading(shading, sprites)
        depth = _depth_arg(depth, cam["width"], cam["height"])
        # GL calls go to the current context: make this renderer's current (its program and
        # cached textures live there; a context made since, even if closed, may be current).
        with self.context.activate("this SpriteLayerRenderer's GL context"):
            return self._draw(sprites, width, height, cam, (arr, atlas, grid), kernel, peak,
                              exact, shading, depth)  # fmt: skip

    def _draw(self, sprites: Sprites, width: int, height: int, cam: dict[str, Any],
              atlas_args: tuple[Any, Any, tuple[int, int]], kernel: str, peak: float,
              exact: bool, shading: FragmentShading | None,
              depth: np.ndarray | None) -> np.ndarray:  # fmt: skip
        arr, atlas, grid = atlas_args
        ctx = self.context.ctx
        made: list[Any] = []
        try:
            depth_tex = ctx.texture(
                (width, height) if depth is not None else (1, 1),
                1,
                data=(depth if depth is not None else np.zeros(1, np.float32)).tobytes(),
                dtype="f4",
            )
            made.append(depth_tex)
            depth_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            depth_tex.use(location=1)
            self._set("u_depth", 1)
            self._set("u_depth_test", depth is not None)
            levels = 0 if exact or arr is None else _mip_levels(arr, grid)
            tex = self._atlas_texture(arr, atlas, levels, made)
            tex.filter = (
                (moderngl.LINEAR_MIPMAP_LINEAR if levels else moderngl.LINEAR),
                moderngl.LINEAR,
            )
            tex.repeat_x = tex.repeat_y = False
            chunks = self._instances(sprites, made, shading)
            self._bind_camera(cam, width, height)
            self._set("u_fragment_shading", shading is not None)
            if shading is not None:
                for name, value in shading.uniforms().items():
                    self._set(name, value)
                caf = shading.caf if shading.caf.size else np.zeros(1, np.float32)
                ssbo = ctx.buffer(np.ascontiguousarray(caf, np.float32).tobytes())
                made.append(ssbo)
                ssbo.bind_to_storage_buffer(0)
            self._set("u_kernel", KERNELS.index(kernel))
            self._set("u_peak", peak)
            self._set("u_atlas", 0)
            self._set("u_atlas_grid", grid)
            self._set("u_exact", bool(exact))
            tex.use(location=0)
            return self._draw_tiles(chunks, width, height, made)
        finally:
            for obj in made:
                obj.release()

    def _draw_tiles(
        self, chunks: list[tuple[Any, int]], width: int, height: int, made: list[Any]
    ) -> np.ndarray:
        ctx = self.context.ctx
        tw, th = min(self.tile, width), min(self.tile, height)
        colour = ctx.texture((tw, th), 4, dtype="f4")
        made.append(colour)
        fbo = ctx.framebuffer(color_attachments=[colour])
        made.append(fbo)
        out = np.empty((height, width, 4), dtype=np.float32)
        query = self.context.timer_query()
        self.gpu_time_ns = 0
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)
        ctx.blend_equation = moderngl.FUNC_ADD
        try:
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
                        for vao, count in chunks:
                            if count:
                                vao.render(moderngl.TRIANGLES, vertices=6, instances=count)
                    ctx.finish()
                    self.gpu_time_ns += int(query.elapsed)
                    data = fbo.read(viewport=(0, 0, w, h), components=4, dtype="f4")
                    tile = np.frombuffer(data, np.float32).reshape(h, w, 4)
                    out[y0 : y0 + h, x0 : x0 + w] = tile[::-1]
        finally:
            ctx.disable(moderngl.BLEND)
        self.sprites_drawn = sum(count for _, count in chunks)
        return out

    def target(self, width: int, height: int, clear: float = 0.0, bits: int = 32) -> SpriteTarget:
        """A persistent framebuffer to blend screen-space sprites into one draw at a time."""
        self._check_open()
        return SpriteTarget(self, width, height, clear, bits)

    def release(self) -> None:
        """Release the program and the cached atlas textures (idempotent)."""
        if self.program is not None and not self.context.closed:
            self.program.release()
            for _, tex, _ in self._atlases.values():
                tex.release()
        self._atlases.clear()
        self.program = None

    def __enter__(self) -> SpriteLayerRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


class SpriteTarget:
    """A ``width × height`` framebuffer (RGBA32F, or RGBA8 with ``bits=8``) cleared to ``clear``,
    into which screen-space sprites — centres' x, y and half sizes in pixels, row 0 on top — are
    blended (ONE, ONE_MINUS_SRC_ALPHA) and from which regions are read back: the 2002 read-back
    light pass of :mod:`cumuli.light.particles_gl`."""

    def __init__(
        self, renderer: SpriteLayerRenderer, width: int, height: int, clear: float, bits: int
    ) -> None:
        self.renderer = renderer
        self.width = check.integer(width, "width", 1, 4096)
        self.height = check.integer(height, "height", 1, 4096)
        if bits not in (8, 32):
            raise ValueError(f"bits must be 8 or 32, got {bits}")
        renderer.context.make_current()
        ctx = renderer.context.ctx
        self._objects: list[Any] = []
        self.colour = ctx.texture((self.width, self.height), 4, dtype="f1" if bits == 8 else "f4")
        self._objects.append(self.colour)
        self.fbo = ctx.framebuffer(color_attachments=[self.colour])
        self._objects.append(self.fbo)
        self.buffer = ctx.buffer(reserve=_RECORD.itemsize)
        self._objects.append(self.buffer)
        self.vao = ctx.vertex_array(renderer.program, [(self.buffer, _FORMAT, *_ATTRS)])
        self._objects.append(self.vao)
        self.fbo.clear(clear, clear, clear, clear)

    def draw_one(self, record: np.ndarray, kernel: str, peak: float) -> None:
        """Blend one screen-space sprite (a record of :meth:`Sprites.records`)."""
        r = self.renderer
        ctx = r.context.ctx
        self.buffer.write(record.tobytes())
        self.fbo.use()
        ctx.viewport = (0, 0, self.width, self.height)
        r._bind_camera(None, self.width, self.height)
        r._set("u_kernel", KERNELS.index(kernel))
        r._set("u_peak", float(peak))
        r._set("u_depth_test", False)
        r._set("u_tile_origin", (0, 0))
        r._set("u_tile_size", (self.width, self.height))
        r._set("u_tile_height", self.height)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = (moderngl.ONE, moderngl.ONE_MINUS_SRC_ALPHA)
        ctx.blend_equation = moderngl.FUNC_ADD
        try:
            self.vao.render(moderngl.TRIANGLES, vertices=6, instances=1)
        finally:
            ctx.disable(moderngl.BLEND)

    def read(self, x: int, y: int, w: int, h: int) -> np.ndarray:
        """Red channel of the ``w × h`` region at GL pixel ``(x, y)`` (rows bottom-up), float32."""
        data = self.fbo.read(
            viewport=(x, y, w, h), components=1, dtype="f4" if self.colour.dtype == "f4" else "f1"
        )
        arr = np.frombuffer(data, np.float32 if self.colour.dtype == "f4" else np.uint8)
        arr = arr.reshape(h, w)
        return arr if arr.dtype == np.float32 else (arr.astype(np.float32) / np.float32(255))

    def image(self) -> np.ndarray:
        """The whole red channel, ``(height, width)``, rows bottom-up."""
        return self.read(0, 0, self.width, self.height)

    def release(self) -> None:
        if not self.renderer.context.closed:
            for obj in self._objects:
                obj.release()
        self._objects.clear()

    def __enter__(self) -> SpriteTarget:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()
