"""The GL volumetric renderer: the paper's GLSL ray marcher in a headless moderngl context.

:class:`Renderer` owns one :class:`cumuli.gl.GLContext`, compiles ``shaders/march.frag.glsl``
once, and for each :meth:`Renderer.render` uploads the scene (primitives and clouds as storage
buffers, light grids packed into one 3D atlas, the noise lattice as a REPEAT/LINEAR 3D texture),
draws a full-screen triangle per tile into an RGBA32F framebuffer and reads it back with row 0 at
the top. The maths is RENDER_CONTRACT.md; the C++ reference marcher (``backend="cpu"``) follows
the same contract.

Light grids are computed on demand with :func:`cumuli.light_grid` for clouds that have none, or
whose recorded sun or parameters differ from the scene's (see :func:`prepare_light`).
"""

from __future__ import annotations

import dataclasses
import math
import threading
from typing import Any

import numpy as np

from cumuli import _validate as check
from cumuli.camera import Camera
from cumuli.gl import GLContext
from cumuli.model.cloud import Cloud
from cumuli.scene import Scene
from cumuli.settings import CANDIDATE_SORTS, MAX_CANDIDATES, MAX_CLOUDS

#: Largest tile drawn in one call (keeps each draw short on software GL and under driver timeouts).
TILE = 1024
#: Largest image accepted, in pixels (2²⁶ RGBA32F pixels = 1 GiB of output).
MAX_PIXELS = 1 << 26
BACKENDS = ("gl", "cpu")
#: Most primitives per cloud the GL marcher accepts, by density model. Every loop of the shader
#: is bounded, but not by a constant: per pixel, candidate collection tests all N primitives of
#: each cloud the ray's box test hits, and a metaball sample sums the field over all N
#: primitives (up to max_steps samples), so one fragment costs O(N) resp. O(N·max_steps). A
#: draw that runs for seconds trips GPU watchdogs (Windows TDR ≈ 2 s, Linux drivers' hang
#: checks) and loses the context. Up to these sizes a tile stays far below that on a desktop GPU
#: (512-primitive clouds are benchmarked); larger clouds go to backend="cpu", which has no
#: watchdog, or must be split.
MAX_GL_PRIMITIVES = {"spheroid": 65536, "metaball": 1024}


# --------------------------------------------------------------------------------------------
# Light grids on demand
def expected_light_params(cloud: Cloud, scene: Scene) -> dict[str, Any]:
    """The ``light_params`` record of the grid ``scene``'s settings make for ``cloud``."""
    from cumuli.light.ndt import DEFAULT_SOLID_ANGLE, light_params

    return light_params(
        cloud,
        scene.noise,
        solid_angle=DEFAULT_SOLID_ANGLE,
        kappa=scene.settings.kappa,
        **scene.settings.light_grid_kwargs(),
    )


def _check_light(cloud: Cloud, index: int) -> None:
    grid = cloud.light
    if not isinstance(grid, np.ndarray) or grid.ndim != 3 or min(grid.shape) < 1:
        raise ValueError(f"scene.clouds[{index}].light must be a (D, H, W) array")
    if grid.dtype.kind not in "fiu":
        raise TypeError(
            f"scene.clouds[{index}].light must be a real numeric array, got dtype {grid.dtype}"
        )
    if not np.isfinite(grid).all():
        raise ValueError(f"scene.clouds[{index}].light contains NaN or infinite values")
    box = cloud.light_box
    if box is None:
        raise ValueError(f"scene.clouds[{index}].light_box is missing (the light grid's box)")
    bad_box = f"scene.clouds[{index}].light_box must be (lo, hi), two finite 3-vectors with hi > lo"
    try:
        lo = np.asarray(box[0], dtype=np.float64)
        hi = np.asarray(box[1], dtype=np.float64)
    except (TypeError, ValueError, IndexError, KeyError):
        raise ValueError(f"{bad_box}, got {box!r}") from None
    if len(box) != 2 or lo.shape != (3,) or hi.shape != (3,) or not (hi > lo).all():
        raise ValueError(bad_box)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        raise ValueError(bad_box)


def prepare_light(scene: Scene) -> None:
    """Make sure every cloud of ``scene`` has a current light grid for the scene's sun and noise.

    A cloud gets a grid from :func:`cumuli.light_grid` (``settings.light_*``, the settings' fBm
    and κ, the default solid angle) when it has none; when its grid was made for another sun
    direction (``cloud.light_sun``); or when the parameters ``light_grid`` recorded with it
    (``cloud.light_params``: noise, fBm, extinction, step, method, resolution, solid angle,
    density model and κ, density override, primitives) differ from those the settings give
    (:func:`expected_light_params`). A grid set by hand has no record and is trusted as it is
    (stale only if its ``light_sun`` is set and differs from the sun).
    """
    for k, cloud in enumerate(scene.clouds):
        if cloud.light is None or _stale(cloud, scene):
            _compute_light(cloud, scene)
        _check_light(cloud, k)


def _stale(cloud: Cloud, scene: Scene) -> bool:
    sun = cloud.light_sun
    if sun is not None and not np.allclose(sun, scene.sun.direction, rtol=0, atol=1e-6):
        return True
    params = cloud.light_params
    return params is not None and params != expected_light_params(cloud, scene)


def _compute_light(cloud: Cloud, scene: Scene) -> None:
    from cumuli.light.ndt import DEFAULT_SOLID_ANGLE, light_grid

    s = scene.settings
    target = cloud
    if s.kappa is not None and s.kappa != cloud.kappa:
        # The grid must see the density the marcher sees: κ overridden by the settings.
        target = dataclasses.replace(cloud, kappa=s.kappa, light=None, light_box=None)
    light_grid(
        target,
        scene.sun,
        scene.noise,
        solid_angle=DEFAULT_SOLID_ANGLE,
        **s.light_grid_kwargs(),
    )
    if target is not cloud:
        cloud.light, cloud.light_box = target.light, target.light_box
        cloud.light_sun = target.light_sun
        cloud.light_params = target.light_params  # after light / light_box, which clear it


# --------------------------------------------------------------------------------------------
def _check_size(width: Any, height: Any, max_texture: int) -> tuple[int, int]:
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise TypeError(f"{name} must be an integer, got {type(v).__name__}")
        if v < 1:
            raise ValueError(f"{name} must be >= 1, got {v}")
        if v > max_texture:
            raise ValueError(f"{name} must be <= {max_texture} (GL_MAX_TEXTURE_SIZE), got {v}")
    if int(width) * int(height) > MAX_PIXELS:
        raise ValueError(
            f"image of {width}x{height} pixels is larger than the limit of {MAX_PIXELS} pixels"
        )
    return int(width), int(height)


def check_gl_limits(scene: Scene) -> None:
    """Refuse clouds too large for one GL draw (:data:`MAX_GL_PRIMITIVES`) with a clear error."""
    for k, cloud in enumerate(scene.clouds):
        limit = MAX_GL_PRIMITIVES[cloud.model]
        if cloud.n > limit:
            raise ValueError(
                f"scene.clouds[{k}] has {cloud.n} primitives; the GL renderer takes at most "
                f"{limit} per {cloud.model} cloud (per-pixel work grows with the primitive count "
                "and a long draw can trip the GPU watchdog): use backend='cpu' or fewer "
                "primitives (split the cloud)"
            )


def _candidate_scale(cloud: Cloud) -> float:
    # Metaball iso-surfaces reach beyond the primitives: grown by √N they bound it (candidates.hpp).
    return math.sqrt(max(cloud.n, 1)) if cloud.model == "metaball" else 1.0


def pack_scene(scene: Scene) -> tuple[bytes, bytes, np.ndarray]:
    """Storage-buffer bytes for primitives and clouds and the light atlas ``[z, y, x]``.

    Layout: see shaders/scene_data.glsl. Light grids are stacked along z; each cloud records
    its first slice.
    """
    prims: list[np.ndarray] = []
    floats = np.zeros((max(len(scene.clouds), 1), 24), np.float32)
    ints = np.zeros((max(len(scene.clouds), 1), 8), np.int32)
    first = 0
    z0 = 0
    grids = [c.light for c in scene.clouds]
    atlas_w = max((g.shape[2] for g in grids), default=1)
    atlas_h = max((g.shape[1] for g in grids), default=1)
    atlas_d = max(sum(g.shape[0] for g in grids), 1)
    atlas = np.zeros((atlas_d, atlas_h, atlas_w), np.float32)
    kappa_override = scene.settings.kappa
    for k, cloud in enumerate(scene.clouds):
        n = cloud.n
        p = np.zeros((n, 20), np.float32)
        p[:, 0:3] = cloud.centres
        p[:, 4:7] = cloud.radii
        for a in range(3):  # rotation columns = the ellipsoid's axes
            p[:, 8 + 4 * a : 11 + 4 * a] = cloud.rotations[:, :, a]
        prims.append(p)
        scale = _candidate_scale(cloud)
        lo, hi = cloud.bounds(scale)
        grid = np.ascontiguousarray(cloud.light, dtype=np.float32)
        d, h, w = grid.shape
        llo, lhi = cloud.light_box  # type: ignore[misc]
        floats[k, 0:3], floats[k, 3] = lo, scale
        floats[k, 4:7] = hi
        floats[k, 8:11] = cloud.centre  # the LOD distance
        floats[k, 12:15] = llo
        floats[k, 16:19] = lhi
        kappa = cloud.kappa if kappa_override is None else kappa_override
        floats[k, 20] = kappa
        # Kept apart, so the shader computes (fbm·r̄²)·φ in the C++ order.
        floats[k, 21] = cloud.mean_r2
        floats[k, 22] = cloud.phi
        ints[k, 0:4] = (first, n, 1 if cloud.model == "metaball" else 0, 0)
        ints[k, 4:8] = (w, h, d, z0)
        atlas[z0 : z0 + d, :h, :w] = grid
        first += n
        z0 += d
    prim_bytes = (np.concatenate(prims) if prims else np.zeros((1, 20), np.float32)).tobytes()
    cloud_bytes = np.concatenate([floats.view(np.uint32), ints.view(np.uint32)], axis=1).tobytes()
    return prim_bytes, cloud_bytes, atlas


class Renderer:
    """A GL volumetric renderer; use as a context manager or call :meth:`close`.

    Parameters
    ----------
    context:
        An existing :class:`cumuli.gl.GLContext` to draw with (not closed by :meth:`close`);
        by default the renderer creates and owns one.
    tile:
        Largest tile edge drawn per draw call (images larger than this are rendered in tiles).
    """

    def __init__(self, context: GLContext | None = None, tile: int = TILE) -> None:
        self.closed = False
        self._objects: list[Any] = []
        self._owns_context = False
        # Arguments first: a bad one must not leave a context behind.
        self.tile = check.integer(tile, "tile", 16, 4096)
        if context is not None:
            if not isinstance(context, GLContext):
                raise TypeError(
                    f"context must be a cumuli.gl.GLContext or None, got {type(context).__name__}"
                )
            if context.closed:
                raise ValueError("context is closed")
        self._owns_context = context is None
        self.gl = GLContext() if context is None else context
        ctx = self.gl.ctx
        #: Compiled marcher variants by candidate sort: (program, vertex array).
        self._variants: dict[str, tuple[Any, Any]] = {}
        try:
            self._use_variant("insertion")
            # moderngl cannot release a query on its own: share the context's one.
            self._query = self.gl.timer_query()
        except Exception:
            self.close()
            raise
        self.max_texture_size = int(ctx.info["GL_MAX_TEXTURE_SIZE"])
        self.max_3d_texture_size = int(ctx.info["GL_MAX_3D_TEXTURE_SIZE"])
        #: Largest storage buffer the shader may index (the primitives of all clouds share one).
        self.max_storage_block_size = int(ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27))
        self._fbo: Any = None
        self._fbo_tex: Any = None
        self._fbo_size: tuple[int, int] = (0, 0)
        self._noise_tex: Any = None
        self._noise_key: tuple[int, int] | None = None
        #: GPU time of the last render's draws in nanoseconds (GL timer queries, all tiles);
        #: None when the driver could not time a draw.
        self.last_gpu_ns: int | None = None

    @property
    def renderer_string(self) -> str:
        """The GL_RENDERER string of the context (e.g. ``llvmpipe (LLVM 15.0.6, 256 bits)``)."""
        return self.gl.renderer

    # --- GL resources -----------------------------------------------------------------------
    def _framebuffer(self, w: int, h: int) -> Any:
        if self._fbo_size != (w, h):
            for obj in (self._fbo, self._fbo_tex):
                if obj is not None:
                    obj.release()
            ctx = self.gl.ctx
            self._fbo_tex = ctx.texture((w, h), 4, dtype="f4")
            self._fbo = ctx.framebuffer(color_attachments=[self._fbo_tex])
            self._fbo_size = (w, h)
        return self._fbo

    def _noise_texture(self, scene: Scene) -> Any:
        key = (scene.noise.seed, scene.noise.size)
        if self._noise_key != key:
            if self._noise_tex is not None:
                self._noise_tex.release()
                self._noise_tex = None
            n = scene.noise.size
            tex = self.gl.ctx.texture3d((n, n, n), 1, scene.noise.lattice.tobytes(), dtype="f4")
            import moderngl

            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            tex.repeat_x = tex.repeat_y = tex.repeat_z = True
            self._noise_tex, self._noise_key = tex, key
        return self._noise_tex

    def _use_variant(self, candidate_sort: str) -> None:
        """Make the marcher compiled for ``candidate_sort`` current (compiled on first use)."""
        if candidate_sort not in self._variants:
            program = self.gl.program(
                "common/fullscreen.vert.glsl",
                "march/march.frag.glsl",
                defines={"CANDIDATE_SORT": CANDIDATE_SORTS.index(candidate_sort)},
            )
            self._objects.append(program)
            vao = self.gl.ctx.vertex_array(program, [])
            self._objects.append(vao)
            self._variants[candidate_sort] = (program, vao)
        self.program, self.vao = self._variants[candidate_sort]

    def _set(self, name: str, value: Any) -> None:
        # Uniforms the compiler optimised away are simply absent.
        if name in self.program:
            self.program[name].value = value

    # --- rendering --------------------------------------------------------------------------
    def render(self, scene: Scene, camera: Camera, width: int, height: int) -> np.ndarray:
        """Render ``scene`` seen by ``camera``: ``(height, width, 4)`` float32 linear RGBA,
        row 0 at the top, alpha = 1 − transmittance.

        Clouds without a (current) light grid get one first (:func:`prepare_light`).
        """
        if self.closed:
            raise RuntimeError("this Renderer is closed")
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a cumuli.Scene, got {type(scene).__name__}")
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
        width, height = _check_size(width, height, self.max_texture_size)
        if len(scene.clouds) > MAX_CLOUDS:
            raise ValueError(f"the GL renderer draws at most {MAX_CLOUDS} clouds")
        check_gl_limits(scene)  # before the light pass, which such a cloud would make long
        prepare_light(scene)
        prim_bytes, cloud_bytes, atlas = pack_scene(scene)
        if len(prim_bytes) > self.max_storage_block_size:
            # Beyond it the driver clamps or drops the reads: primitives would silently vanish.
            raise ValueError(
                f"the scene's {sum(c.n for c in scene.clouds)} primitives need "
                f"{len(prim_bytes)} bytes of storage buffer, more than this GL's "
                f"GL_MAX_SHADER_STORAGE_BLOCK_SIZE={self.max_storage_block_size}; use fewer "
                "primitives or backend='cpu'"
            )
        if max(atlas.shape) > self.max_3d_texture_size:
            raise ValueError(
                f"the light grids need a {atlas.shape[::-1]} atlas, larger than "
                f"GL_MAX_3D_TEXTURE_SIZE={self.max_3d_texture_size}; use fewer clouds or a "
                "smaller settings.light_resolution"
            )
        import moderngl

        ctx = self.gl.ctx
        scratch: list[Any] = []
        try:
            prim_buf = ctx.buffer(prim_bytes)
            scratch.append(prim_buf)
            cloud_buf = ctx.buffer(cloud_bytes)
            scratch.append(cloud_buf)
            d, h, w = atlas.shape
            light_tex = ctx.texture3d((w, h, d), 1, atlas.tobytes(), dtype="f4")
            scratch.append(light_tex)
            light_tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            light_tex.repeat_x = light_tex.repeat_y = light_tex.repeat_z = False
            prim_buf.bind_to_storage_buffer(0)
            cloud_buf.bind_to_storage_buffer(1)
            self._use_variant(scene.settings.candidate_sort)
            self._noise_texture(scene).use(location=0)
            light_tex.use(location=1)
            self._set_uniforms(scene, camera, width, height)
            return self._draw_tiles(width, height)
        finally:
            for obj in scratch:
                obj.release()

    def _set_uniforms(self, scene: Scene, camera: Camera, width: int, height: int) -> None:
        s = scene.settings
        f, r, u = camera.basis()
        set_ = self._set
        set_("u_lattice", 0)
        set_("u_light_atlas", 1)
        set_("u_cam_pos", tuple(np.float32(camera.position).tolist()))
        set_("u_cam_f", tuple(f.tolist()))
        set_("u_cam_r", tuple(r.tolist()))
        set_("u_cam_u", tuple(u.tolist()))
        set_("u_th", math.tan(math.radians(camera.fov) / 2))
        set_("u_aspect", width / height)
        set_("u_image_size", (width, height))
        set_("u_sun_dir", scene.sun.direction)
        set_("u_sun_radiance", scene.sun.radiance)
        sky = scene.sky
        set_("u_sky_zenith", sky.zenith)
        set_("u_sky_horizon", sky.horizon)
        set_("u_sky_ground", sky.ground)
        set_("u_sky_exponent", sky.exponent)
        rad = math.radians(sky.sun_disc_radius)
        set_("u_sun_disc", (math.cos(1.5 * rad), math.cos(rad)))
        set_("u_sun_disc_intensity", sky.sun_disc_intensity)
        set_("u_cloud_count", len(scene.clouds))
        set_("u_absorption", s.absorption)
        set_("u_step_ref", s.step_ref)
        set_("u_lod_a", s.lod_a)
        set_("u_lod_delta", s.lod_delta)
        set_("u_step_min", s.step_min)
        set_("u_step_max", s.step_max)
        set_("u_fixed_step", s.fixed_step)
        set_("u_g", s.hg_g)
        set_("u_max_steps", s.max_steps)
        set_("u_max_candidates", min(s.max_candidates, MAX_CANDIDATES))
        set_("u_union", s.march == "union")
        set_("u_exact", s.exact_noise)
        set_("u_octaves", s.octaves)
        set_("u_gain", s.gain)
        set_("u_lacunarity", s.lacunarity)
        set_("u_frequency", s.frequency)

    def _draw_tiles(self, width: int, height: int) -> np.ndarray:
        import moderngl

        out = np.empty((height, width, 4), np.float32)
        tw, th = min(self.tile, width), min(self.tile, height)
        fbo = self._framebuffer(tw, th)
        fbo.use()
        total: int | None = 0
        for y0 in range(0, height, th):  # y0: top row of the tile
            h = min(th, height - y0)
            for x0 in range(0, width, tw):
                w = min(tw, width - x0)
                fbo.viewport = (0, 0, w, h)
                self._set("u_tile_origin", (x0, y0))
                self._set("u_tile_height", h)
                with self._query:
                    self.vao.render(mode=moderngl.TRIANGLES, vertices=3)
                    # Software rasterisers (llvmpipe) defer the draw until a flush, so without
                    # this the query would time the submission, not the work.
                    self.gl.ctx.finish()
                elapsed = int(self._query.elapsed)
                # llvmpipe answers 2³²−1 for a query it could not time (seen on the first draw).
                if total is not None and 0 <= elapsed < 0xFFFFFFFF:
                    total += elapsed
                else:
                    total = None
                data = fbo.read(viewport=(0, 0, w, h), components=4, dtype="f4")
                tile = np.frombuffer(data, np.float32).reshape(h, w, 4)
                out[y0 : y0 + h, x0 : x0 + w] = tile[::-1]
        self.last_gpu_ns = total
        return out

    # --- lifetime ---------------------------------------------------------------------------
    def close(self) -> None:
        """Release every GL object (and the context when this renderer created it)."""
        if self.closed:
            return
        self.closed = True
        extra = [self._fbo, self._fbo_tex, self._noise_tex] if hasattr(self, "_fbo") else []
        # Objects of a context that is already gone were released with it.
        live = not getattr(self, "gl", None) or not self.gl.closed
        for obj in [*extra, *reversed(self._objects)] if live else []:
            if obj is not None:
                try:
                    obj.release()
                except Exception:
                    pass
        self._objects.clear()
        self._fbo = self._fbo_tex = self._noise_tex = None
        if self._owns_context and hasattr(self, "gl"):
            self.gl.close()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:  # best effort; close() is the contract
        try:
            self.close()
        except Exception:
            pass


# --------------------------------------------------------------------------------------------
_shared: Renderer | None = None
_shared_lock = threading.Lock()


def shared_renderer() -> Renderer:
    """The process-wide renderer used by :func:`render` (created on first use)."""
    global _shared
    with _shared_lock:
        if _shared is None or _shared.closed or _shared.gl.closed:
            from cumuli.gl import default_context

            # Shares the process-wide context with the other GL conveniences (one EGL context).
            _shared = Renderer(context=default_context())
        return _shared


def render(
    scene: Scene,
    camera: Camera | None = None,
    width: int = 640,
    height: int = 480,
    backend: str = "gl",
) -> np.ndarray:
    """Render ``scene`` to an ``(height, width, 4)`` float32 linear RGBA image, row 0 on top.

    ``backend="gl"`` runs the GLSL marcher in a process-wide headless context; ``"cpu"`` runs the
    C++ reference marcher (same contract, for parity and for machines without EGL). ``camera``
    defaults to :meth:`Scene.default_camera`.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a cumuli.Scene, got {type(scene).__name__}")
    if camera is None:
        camera = scene.default_camera()
    if backend == "gl":
        return shared_renderer().render(scene, camera, width, height)
    from cumuli.rendering.cpu import render_cpu

    return render_cpu(scene, camera, width, height)
