"""GL twins of the particle light pass: compute shader and 2002 read-back.

``method="gl"`` runs ``shaders/particles/light.comp.glsl`` (one work group per light; the buffer
in an SSBO). ``method="readback"`` is [H]'s own algorithm: each particle drawn as a blended quad
(``shaders/sprites``, screen-space mode) into an ``N_L²`` RGBA32F framebuffer cleared to white,
with one ``glReadPixels`` of the pixel(s) under its centre before it is drawn — N pipeline
stalls per light, kept to reproduce [H]'s preprocess timings. Both take each particle's buffer
position, footprint, forward factor and alpha from the C++ core (``_core.particle_light_splats``),
so that every path reads back the same pixels; they agree with the C++ to ~1e−7.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from cumuli import _core
from cumuli.gl.context import GLContext, _resolve_context, load_shader, with_defines
from cumuli.light.sprite_settings import PHASES, SpriteSettings
from cumuli.model.particles import ParticleCloud

_SPLAT = np.dtype([("geom", "<f4", 5), ("index", "<i4"), ("patch", "<i4"), ("pad", "<i4")])
_LOCAL = 64  # local_size_x of phase_values.comp.glsl
_MAX_GROUPS = 65535
#: Loop iterations one invocation of light.comp.glsl may spend per dispatch. llvmpipe ends a shader
#: after 65535 loop iterations per invocation; the estimate below (per particle, of invocation 0,
#: the busiest) counts each loop iteration twice, so half that limit leaves a margin of ~4.
_ITERATION_BUDGET = 32768


def _local_size(resolution: int) -> int:
    """Work-group size of the light pass: 64, or 1024 above N_L = 1024 so that one particle's
    footprint (≤ N_L² pixels) never needs more than 16384 iterations per invocation."""
    return 64 if resolution <= 1024 else 1024


def _dispatch_ranges(geom: np.ndarray, patch: np.ndarray, nl: int, readback: str) -> list:
    """Split the processing order into [first, end) ranges within the iteration budget."""
    local = _local_size(nl)
    top = np.float32(nl - 1)
    x, y, r = geom[..., 0], geom[..., 1], geom[..., 2]
    x0, x1 = (np.clip(np.floor(v), 0, top) for v in (x - r, x + r))
    y0, y1 = (np.clip(np.floor(v), 0, top) for v in (y - r, y + r))
    count = (x1 - x0 + 1).astype(np.int64) * (y1 - y0 + 1).astype(np.int64)
    cost = 8 + 2 * -(-count // local)
    if readback == "solid_angle":
        side = patch.astype(np.int64)
        cost = cost + 2 * (-(-side // local) * side + side) + 4
    cumulative = np.cumsum(cost.max(axis=0))
    ranges, first, spent = [], 0, 0
    n = cumulative.size
    while first < n:
        end = int(np.searchsorted(cumulative, spent + _ITERATION_BUDGET, side="right"))
        end = max(end, first + 1)  # one particle always fits the real limit (see _local_size)
        ranges.append((first, end))
        spent = int(cumulative[end - 1])
        first = end
    return ranges


#: Wall seconds of the last light pass run here (dispatch/draw loop only, uploads excluded).
last_seconds: float | None = None


def light_pass(
    cloud: ParticleCloud,
    dirs: np.ndarray,
    settings: SpriteSettings,
    method: str,
    return_buffers: bool,
    context: GLContext | None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """``(light (N, L), buffers (L, N_L, N_L) | None)`` by ``method`` "gl" or "readback"."""
    if method == "readback" and settings.clamp and settings.allow_gain and not settings.quantize:
        raise ValueError(
            "clamp=True with allow_gain=True needs quantize=8 for method='readback': a float "
            "framebuffer cannot clamp blends (without gain the buffer never leaves [0, 1])"
        )
    ctx = _resolve_context(context)
    splats = _core.particle_light_splats(*cloud.core_args(), dirs, settings.light_dict())
    if method == "gl":
        return _compute(ctx, cloud.n, splats, settings, return_buffers)
    return _readback(ctx, cloud.n, splats, settings, return_buffers)


def _records(geom: np.ndarray, index: np.ndarray, patch: np.ndarray) -> np.ndarray:
    rec = np.zeros(index.shape, dtype=_SPLAT)
    rec["geom"], rec["index"], rec["patch"] = geom, index, patch
    return rec


def _compute(
    context: GLContext, n: int, splats: tuple, settings: SpriteSettings, return_buffers: bool
) -> tuple[np.ndarray, np.ndarray | None]:
    global last_seconds
    geom, index, patch, _frames, _radius = splats
    lights = geom.shape[0]
    nl = settings.light_resolution
    ctx = context.ctx
    block = int(context.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27))
    per_light = max(n * _SPLAT.itemsize, nl * nl * 4, n * 4)
    if per_light > block:
        raise ValueError(
            f"the light pass of {n} particles at light_resolution={nl} needs {per_light} bytes "
            f"per storage block, more than this GL's limit {block}: use method='cpu'"
        )
    group = max(1, min(lights, _MAX_GROUPS, block // per_light))
    light = np.empty((n, lights), dtype=np.float32)
    buffers = np.empty((lights, nl, nl), dtype=np.float32) if return_buffers else None
    local = _local_size(nl)
    source = with_defines(load_shader("particles/light.comp.glsl"), {"LOCAL_SIZE": local})
    program = ctx.compute_shader(source)
    made: list[Any] = [program]
    last_seconds = 0.0
    values = {
        "u_count": n,
        "u_res": nl,
        "u_kernel": ("gaussian", "hermite").index(settings.kernel),
        "u_peak": settings.peak,
        "u_readback": ("pixel", "bilinear", "solid_angle").index(settings.readback),
        "u_clamp": settings.clamp,
        "u_quantize": settings.quantize,
    }
    try:
        for name, value in values.items():
            if name in program:
                program[name].value = value
        for first in range(0, lights, group):
            count = min(group, lights - first)
            part = slice(first, first + count)
            rec = _records(geom[part], index[part], patch[part])
            ranges = _dispatch_ranges(geom[part], patch[part], nl, settings.readback)
            src = ctx.buffer(rec.tobytes())
            made.append(src)
            out = ctx.buffer(reserve=n * count * 4)
            made.append(out)
            buf = ctx.buffer(np.ones(count * nl * nl, np.float32).tobytes())  # cleared to white
            made.append(buf)
            src.bind_to_storage_buffer(0)
            out.bind_to_storage_buffer(1)
            buf.bind_to_storage_buffer(2)
            if "u_lights" in program:
                program["u_lights"].value = count
            ctx.finish()
            t0 = time.perf_counter()
            for lo, hi in ranges:
                program["u_first"].value = lo
                program["u_end"].value = hi
                program.run(count, 1, 1)
                ctx.memory_barrier()
            ctx.finish()
            last_seconds += time.perf_counter() - t0
            light[:, part] = np.frombuffer(out.read(), np.float32).reshape(n, count)
            if buffers is not None:
                buffers[part] = np.frombuffer(buf.read(), np.float32).reshape(count, nl, nl)
            for obj in (src, out, buf):
                obj.release()
                made.remove(obj)
    finally:
        for obj in made:
            obj.release()
    return light, buffers


def _lerp(a: np.float32, b: np.float32, t: np.float32) -> np.float32:
    return np.float32(a + t * (b - a))


def _read_back(target: Any, nl: int, x: np.float32, y: np.float32, side: int, mode: str) -> Any:
    """I_k from the framebuffer, with the C++ twin's float32 operations (light_read_back)."""
    f32 = np.float32
    top = f32(nl - 1)
    if mode == "pixel":
        ix = int(np.clip(np.floor(x), f32(0), top))
        iy = int(np.clip(np.floor(y), f32(0), top))
        return target.read(ix, iy, 1, 1)[0, 0]
    if mode == "bilinear":
        u, v = f32(x - f32(0.5)), f32(y - f32(0.5))
        fu, fv = np.floor(u), np.floor(v)
        wx, wy = f32(u - fu), f32(v - fv)
        x0, x1 = int(np.clip(fu, 0, top)), int(np.clip(fu + f32(1), 0, top))
        y0, y1 = int(np.clip(fv, 0, top)), int(np.clip(fv + f32(1), 0, top))
        px = target.read(x0, y0, x1 - x0 + 1, y1 - y0 + 1)
        b0 = _lerp(px[0, 0], px[0, x1 - x0], wx)
        b1 = _lerp(px[y1 - y0, 0], px[y1 - y0, x1 - x0], wx)
        return _lerp(b0, b1, wy)
    half = f32(0.5) * f32(side)
    last = f32(nl - side)
    ox = int(np.clip(np.floor(f32(x - half)), f32(0), last))
    oy = int(np.clip(np.floor(f32(y - half)), f32(0), last))
    patch = target.read(ox, oy, side, side)
    # Row sums in x order, then their sum in y order: the C++ twin's order (cumsum is sequential).
    rows = np.cumsum(patch, axis=1, dtype=np.float32)[:, -1]
    total = np.cumsum(rows, dtype=np.float32)[-1]
    return f32(total / f32(side * side))


def _readback(
    context: GLContext, n: int, splats: tuple, settings: SpriteSettings, return_buffers: bool
) -> tuple[np.ndarray, np.ndarray | None]:
    global last_seconds
    from cumuli.gl.sprites import SpriteLayerRenderer, Sprites

    geom, index, patch, _frames, _radius = splats
    lights = geom.shape[0]
    nl = settings.light_resolution
    light = np.empty((n, lights), dtype=np.float32)
    buffers = np.empty((lights, nl, nl), dtype=np.float32) if return_buffers else None
    bits = 8 if settings.quantize == 8 else 32
    last_seconds = 0.0
    with SpriteLayerRenderer(context) as renderer:
        for ell in range(lights):
            # Screen-space sprites: centre (x, N_L − y) with rows from the top, so that GL row iy
            # (from the bottom) is the light buffer's row y.
            g = geom[ell]
            sprites = Sprites(
                centres=np.stack([g[:, 0], np.float32(nl) - g[:, 1], np.zeros(n, np.float32)], 1),
                half_sizes=g[:, 2],
                colours=np.zeros((n, 3), np.float32),
                alpha=g[:, 4],
            )
            records = sprites.records()
            with renderer.target(nl, nl, clear=1.0, bits=bits) as target:
                t0 = time.perf_counter()
                for k in range(n):
                    x, y, fwd = g[k, 0], g[k, 1], g[k, 3]
                    intensity = np.float32(
                        _read_back(target, nl, x, y, int(patch[ell, k]), settings.readback)
                    )
                    light[index[ell, k], ell] = intensity
                    rec = records[k : k + 1].copy()
                    rec["colour"] = np.float32(fwd * intensity)
                    target.draw_one(rec, settings.kernel, settings.peak)
                context.ctx.finish()
                last_seconds += time.perf_counter() - t0
                if buffers is not None:
                    buffers[ell] = target.image()
    return light, buffers


def phase_values_gl(phase: str, g: float, cosines: np.ndarray, context: Any = None) -> np.ndarray:
    """``phase_4pi`` of ``shaders/common/phase.glsl`` at ``cosines`` (float32), on the GPU."""
    ctx = _resolve_context(context)
    flat = np.ascontiguousarray(cosines, dtype=np.float32).ravel()
    out = np.empty(flat.size, dtype=np.float32)
    if flat.size == 0:
        return out.reshape(cosines.shape)
    groups = -(-flat.size // _LOCAL)
    if groups > _MAX_GROUPS:
        raise ValueError(f"at most {_MAX_GROUPS * _LOCAL} cosines per call")
    program = ctx.compute("common/phase_values.comp.glsl")
    made: list[Any] = [program]
    try:
        src = ctx.ctx.buffer(flat.tobytes())
        made.append(src)
        dst = ctx.ctx.buffer(reserve=flat.size * 4)
        made.append(dst)
        src.bind_to_storage_buffer(0)
        dst.bind_to_storage_buffer(1)
        program["u_count"].value = flat.size
        program["u_kind"].value = PHASES.index(phase)
        if "u_g" in program:
            program["u_g"].value = float(g)
        program.run(groups, 1, 1)
        ctx.ctx.memory_barrier()
        out[:] = np.frombuffer(dst.read(), np.float32)
    finally:
        for obj in made:
            obj.release()
    return out.reshape(cosines.shape)
