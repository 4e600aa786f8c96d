"""GL pieces of the physical mode and the ground, shared by the GL drawers: atlases of the
drawables' physical light (``shaders/common/physical.glsl``) and the ground's uniforms and
shadow map (``shaders/common/ground.glsl``). RENDER_CONTRACT, "Physical lighting" and "Ground".
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Sequence
from typing import Any

import moderngl
import numpy as np

from cumuli._util import validate as check
from cumuli.gl.context import _resolve_context
from cumuli.ground import sky_irradiance
from cumuli.light.physical import PhysicalLight
from cumuli.rendering.params import physical_params, physical_uniforms

#: 32-bit words of one PhysicalCloud in the std430 storage buffer (ten vec4 / ivec4).
WORDS = 40


def shelf_pack(shapes: Sequence[tuple[int, int, int]], limit: int, what: str):
    """Offsets ``(x, y, z)`` placing lattices of ``(nx, ny, nz)`` texels side by side in an
    atlas no edge of which exceeds ``limit`` (rows along x, then along y, then layers along z),
    and the atlas size ``(W, H, D)``."""
    ox = oy = oz = row = layer = 0
    size = [1, 1, 1]
    offsets = []
    for nx, ny, nz in shapes:
        if max(nx, ny, nz) > limit:
            raise ValueError(f"a {what} lattice of {(nx, ny, nz)} exceeds GL_MAX_3D_TEXTURE_SIZE")
        if ox + nx > limit:
            ox, oy, row = 0, oy + row, 0
        if oy + ny > limit:
            ox, oy, oz, row, layer = 0, 0, oz + layer, 0, 0
        if oz + nz > limit:
            raise ValueError(
                f"the {what} lattices do not fit in one 3D texture of GL_MAX_3D_TEXTURE_SIZE="
                f"{limit}: use fewer clouds or a smaller settings.physical_resolution"
            )
        offsets.append((ox, oy, oz))
        ox += nx
        row, layer = max(row, ny), max(layer, nz)
        size = [max(size[0], ox), max(size[1], oy + ny), max(size[2], oz + nz)]
    return offsets, tuple(size)


def pack_physical(
    lights: Sequence[PhysicalLight], limit: int
) -> tuple[bytes, np.ndarray, np.ndarray]:
    """The PhysicalCloud buffer and the two atlases (τ_sun ``[z, y, x]``, light ``[z, y, x, 4]``)
    of the drawables' physical light."""
    dshapes = [tuple(int(v) for v in light.frame[5]) for light in lights]
    gshapes = [light.grid.shape[2::-1] for light in lights]
    doff, dsize = shelf_pack(dshapes, limit, "sun depth")
    goff, gsize = shelf_pack(gshapes, limit, "light")
    depth = np.zeros(dsize[::-1], np.float32)
    grid = np.zeros((*gsize[::-1], 4), np.float32)
    words = np.zeros((max(len(lights), 1), WORDS), np.uint32)
    for k, light in enumerate(lights):
        u, v, w, lo, hi, res = light.frame
        f = np.zeros(WORDS, np.float32)
        i = f.view(np.int32)
        f[0:3], f[3] = u, lo[0]
        f[4:7], f[7] = v, lo[1]
        f[8:11], f[11] = w, lo[2]
        f[12:15] = hi
        i[16:19] = res
        i[20:23] = doff[k]
        glo, ghi = light.box
        f[24:27], f[28:31] = glo, ghi
        i[32:35] = gshapes[k]
        i[36:39] = goff[k]
        words[k] = f.view(np.uint32)
        (x, y, z), (nx, ny, nz) = doff[k], dshapes[k]
        block = depth[z : z + nz, y : y + ny, x : x + nx]
        if light.upstream is None:
            block[...] = light.sun_depth
        else:  # the other media's shadow, per column, added as the atlas is filled
            np.add(light.sun_depth, light.upstream[None], out=block)
        (x, y, z), (nx, ny, nz) = goff[k], gshapes[k]
        grid[z : z + nz, y : y + ny, x : x + nx] = light.grid
    return words.tobytes(), depth, grid


#: The last packing (its lights, the limit, the bytes): a viewer or a camera path draws the
#: same light frame after frame, and packing and copying the atlases cost more than the draw.
#: PhysicalLight is frozen; the cache holds its lights, so their ids cannot be reused.
_last_pack: list[Any] = [None]


def _packed(lights: Sequence[PhysicalLight], limit: int) -> tuple[Any, ...]:
    """`pack_physical` as bytes and shapes, reused while the same light objects come back."""
    last = _last_pack[0]
    if (
        last is not None
        and last[1] == limit
        and len(last[0]) == len(lights)
        and all(a is b for a, b in zip(last[0], lights, strict=True))
    ):
        return last[2]
    words, depth, grid = pack_physical(lights, limit)
    # What the GPU is given is checked, not only what the API made (the CPU twin refuses the same).
    check.uploadable(depth, "the physical light's sun depth")
    check.uploadable(grid, "the physical light", check.MAX_RADIANCE)
    out = (words, depth.shape, depth.tobytes(), grid.shape, grid.tobytes())
    _last_pack[0] = (tuple(lights), limit, out)
    return out


#: Per GL context, the buffer and atlases of the last packing, kept for the next draw of the same
#: light (a viewer's or a camera path's frames): uploading them cost as much as the draw.
_uploaded: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _upload(ctx: Any, packed: tuple[Any, ...]) -> list[Any]:
    words, dshape, depth, gshape, grid = packed
    made: list[Any] = [ctx.buffer(words)]
    for shape, data, comps in ((dshape, depth, 1), (gshape, grid, 4)):
        d, h, w = shape[:3]
        tex = ctx.texture3d((w, h, d), comps, data, dtype="f4")
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        tex.repeat_x = tex.repeat_y = tex.repeat_z = False
        made.append(tex)
    return made


def bind_physical(
    ctx: Any,
    set_: Callable[[str, Any], None],
    settings: Any,
    lights: Sequence[PhysicalLight],
    limit: int,
) -> list:
    """Bind the drawables' physical light (the PhysicalCloud buffer on storage binding 2, the
    sun-depth and light atlases on texture units 2 and 3, filtered linearly, clamped) and set
    the physical uniforms. The GL objects are the context's, kept while the same light comes
    back and released when another replaces it; returns the objects the caller must release
    (none)."""
    packed = _packed(lights, limit)
    held = _uploaded.get(ctx)
    if held is None or held[0] is not packed:
        if held is not None:
            for obj in held[1]:
                obj.release()
            del _uploaded[ctx]
        _uploaded[ctx] = (packed, _upload(ctx, packed))
        held = _uploaded[ctx]
    buf, depth_tex, grid_tex = held[1]
    buf.bind_to_storage_buffer(2)
    depth_tex.use(location=2)
    grid_tex.use(location=3)
    set_physical_uniforms(set_, settings, lights)
    return []


def set_physical_uniforms(
    set_: Callable[[str, Any], None], settings: Any, lights: Sequence[PhysicalLight]
) -> None:
    """The physical shading uniforms (common/physical.glsl), atlases on units 2 and 3."""
    set_("u_depth_atlas", 2)
    set_("u_grid_atlas", 3)
    # The same values the CPU twin takes (cumuli.rendering.params).
    octaves = max((light.octaves for light in lights), default=1)
    for name, value in physical_uniforms(physical_params(settings, octaves)).items():
        set_(name, value)


def octave_sum_gl(
    settings: Any, tau: Any, cos_theta: float, octaves: int, context: Any = None
) -> np.ndarray:
    """``octave_sum`` of ``shaders/common/physical.glsl`` (float32) at optical depths ``tau``
    for one ``cos_theta``, on the GPU: the GLSL side of ``cumuli.light.physical.octave_sum``."""
    ctx = _resolve_context(context)
    flat = np.ascontiguousarray(tau, dtype=np.float32).ravel()
    out = np.empty(flat.size, dtype=np.float32)
    if flat.size == 0:
        return out.reshape(np.shape(tau))
    program = ctx.compute("common/octave_values.comp.glsl")
    made: list[Any] = [program]
    try:
        src = ctx.ctx.buffer(flat.tobytes())
        made.append(src)
        dst = ctx.ctx.buffer(reserve=flat.size * 4)
        made.append(dst)
        src.bind_to_storage_buffer(0)
        dst.bind_to_storage_buffer(1)

        def set_(name: str, value: Any) -> None:
            if name in program:
                program[name].value = value

        for name, value in physical_uniforms(physical_params(settings, octaves)).items():
            set_(name, value)
        set_("u_count", flat.size)
        set_("u_cos", float(cos_theta))
        program.run(-(-flat.size // 64), 1, 1)
        ctx.ctx.memory_barrier()
        out[:] = np.frombuffer(dst.read(), np.float32)
    finally:
        for obj in made:
            obj.release()
    return out.reshape(np.shape(tau))


def bind_ground(ctx: Any, set_: Callable[[str, Any], None], lit: Any, location: int) -> list:
    """The ground's uniforms and shadow map (common/ground.glsl) on texture unit ``location``;
    returns the GL objects made (the caller releases them)."""
    scene = lit.scene
    ground = scene.ground
    shadow = lit.shadow if ground is not None else None
    if shadow is not None:
        nz, nx = shadow.values.shape
        tex = ctx.texture((nx, nz), 1, np.ascontiguousarray(shadow.values).tobytes(), dtype="f4")
    else:  # a sampler2D must not share a unit with the 3D ones, even unused
        tex = ctx.texture((1, 1), 1, np.ones(1, np.float32).tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    tex.use(location=location)
    set_("u_shadow", location)
    set_("u_ground", ground is not None)
    set_("u_shadow_on", shadow is not None)
    if ground is not None:
        set_("u_ground_height", float(ground.height))
        set_("u_ground_albedo", tuple(float(a) for a in ground.albedo))
        set_("u_ground_sky", sky_irradiance(scene.sky))
    if shadow is not None:
        set_("u_shadow_extent", tuple(float(v) for v in shadow.extent))
    return [tex]
