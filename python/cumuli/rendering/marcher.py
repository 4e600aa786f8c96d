"""The 2018 paper's GLSL ray marcher (Jiménez de Parga & Gómez Palomo 2018, Algorithms 1 and 3).

:class:`MarcherGL` compiles ``shaders/marcher/march.frag.glsl`` (one variant per candidate sort,
on first use) on a :class:`cumuli.gl.GLContext` and draws a group of 2018 clouds of a lit scene:
primitives and clouds as storage buffers, light grids packed into one 3D atlas, the noise lattice
as a REPEAT/LINEAR 3D texture, a full-screen triangle per tile into an RGBA32F framebuffer read
back with row 0 at the top. The maths is RENDER_CONTRACT.md; the C++ twin is
``cumuli.rendering.marcher_cpu`` (``_core.render_cpu``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import moderngl
import numpy as np

from cumuli._util import validate as check
from cumuli.camera import Camera
from cumuli.gl import GLContext
from cumuli.light.ndt import LightGrid
from cumuli.light.prepare import LitScene
from cumuli.model.cloud import Cloud
from cumuli.rendering.marcher_cpu import OCCUPANCY_RESOLUTION, occupancy_grid
from cumuli.rendering.params import march_params, march_uniforms, sky_uniforms
from cumuli.rendering.physical_gl import bind_ground, bind_physical
from cumuli.rendering.solids import set_solid_uniforms
from cumuli.scene import Scene
from cumuli.settings import CANDIDATE_SORTS, MAX_CLOUDS

#: Most primitives per cloud the GL marcher accepts, by density model. Every loop of the shader
#: is bounded, but not by a constant: per pixel, candidate collection tests all N primitives of
#: each cloud the ray's box test hits, and a metaball sample sums the field over all N
#: primitives (up to max_steps samples), so one fragment costs O(N) resp. O(N·max_steps). A
#: draw that runs for seconds trips GPU watchdogs (Windows TDR ≈ 2 s, Linux drivers' hang
#: checks) and loses the context. Up to these sizes a tile stays far below that on a desktop GPU
#: (512-primitive clouds are benchmarked); larger clouds go to backend="cpu", which has no
#: watchdog, or must be split.
MAX_GL_PRIMITIVES = {"spheroid": 65536, "metaball": 1024}


def check_gl_limits(scene: Scene, indices: Sequence[int] | None = None) -> None:
    """Refuse clouds too large for one GL draw (:data:`MAX_GL_PRIMITIVES`) with a clear error."""
    for k in range(len(scene.clouds)) if indices is None else indices:
        cloud = scene.clouds[k]
        if not isinstance(cloud, Cloud):
            continue
        limit = MAX_GL_PRIMITIVES[cloud.model]
        if cloud.n > limit:
            raise ValueError(
                f"scene.clouds[{k}] has {cloud.n} primitives; the GL renderer takes at most "
                f"{limit} per {cloud.model} cloud (per-pixel work grows with the primitive count "
                "and a long draw can trip the GPU watchdog): use backend='cpu' or fewer "
                "primitives (split the cloud)"
            )


def pack_clouds(
    clouds: Sequence[Cloud], grids: Sequence[Any], kappa_override: float | None
) -> tuple[bytes, bytes, np.ndarray]:
    """Storage-buffer bytes for primitives and clouds and the light atlas ``[z, y, x]``.

    Layout: see shaders/marcher/scene_data.glsl. Light grids are stacked along z; each cloud
    records its first slice. Boxes, the LOD centre and r̄² come from the cloud in the core's
    float32 order (`Cloud.layer_box`, `Cloud.centre`, `Cloud.mean_r2`).
    """
    prims: list[np.ndarray] = []
    floats = np.zeros((max(len(clouds), 1), 28), np.float32)
    ints = np.zeros((max(len(clouds), 1), 8), np.int32)
    first = 0
    z0 = 0
    atlas_w = max((g.shape[2] for g in grids), default=1)
    atlas_h = max((g.shape[1] for g in grids), default=1)
    atlas_d = max(sum(g.shape[0] for g in grids), 1)
    atlas = np.zeros((atlas_d, atlas_h, atlas_w), np.float32)
    for k, (cloud, grid) in enumerate(zip(clouds, grids, strict=True)):
        n = cloud.n
        p = np.zeros((n, 20), np.float32)
        p[:, 0:3] = cloud.placed_centres
        p[:, 4:7] = cloud.radii
        for a in range(3):  # rotation columns = the ellipsoid's axes
            p[:, 8 + 4 * a : 11 + 4 * a] = cloud.rotations[:, :, a]
        prims.append(p)
        lo, hi = cloud.layer_box()
        values = np.ascontiguousarray(grid, dtype=np.float32)
        # What the GPU is given, as the C++ twin checks it (a grid may have been changed since).
        check.uploadable(values, f"clouds[{k}].light grid", check.MAX_RADIANCE)
        d, h, w = values.shape
        llo, lhi = grid.box
        floats[k, 0:3], floats[k, 3] = lo, cloud.candidate_scale
        floats[k, 4:7] = hi
        floats[k, 8:11] = cloud.centre  # the LOD distance
        floats[k, 12:15] = llo
        floats[k, 16:19] = lhi
        floats[k, 20] = cloud.kappa if kappa_override is None else kappa_override
        # Kept apart, so the shader computes (fbm·r̄²)·φ in the C++ order.
        floats[k, 21] = cloud.mean_r2
        floats[k, 22] = cloud.phi
        floats[k, 24:27] = cloud.offset  # the noise the wind carries: fbm(p − offset)
        # w: the cloud's first z slice in the occupancy atlas (occupancy_atlas)
        ints[k, 0:4] = (first, n, 1 if cloud.model == "metaball" else 0, k * OCCUPANCY_RESOLUTION)
        ints[k, 4:8] = (w, h, d, z0)
        atlas[z0 : z0 + d, :h, :w] = values
        first += n
        z0 += d
    prim_bytes = (np.concatenate(prims) if prims else np.zeros((1, 20), np.float32)).tobytes()
    cloud_bytes = np.concatenate([floats.view(np.uint32), ints.view(np.uint32)], axis=1).tobytes()
    return prim_bytes, cloud_bytes, atlas


def occupancy_atlas(clouds: Sequence[Cloud], skip: bool) -> np.ndarray:
    """The clouds' occupancy grids (`occupancy_grid`) stacked along z, uint8 ``[z, y, x]``
    (255 where occupied)
    (shaders/marcher/occupancy.glsl); one occupied texel when ``skip`` is off."""
    if not skip or not clouds:
        return np.full((1, 1, 1), 255, np.uint8)
    # R8 is normalised: 255 reads as 1.0 (occupied), 0 as 0.0 (empty).
    return np.concatenate([occupancy_grid(c)[0] for c in clouds]).astype(np.uint8) * np.uint8(255)


#: Width of the edge pass's pixel list (cumuli.rendering.edges): its draw is this wide.
LIST_WIDTH = 1024


def pixel_list(rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, int, int]:
    """The edge pass's pixels as a ``(list_h, list_w, 2)`` int32 texture of ``(row, col)``, in
    the order given, padded with ``(−1, −1)``; and its width and height."""
    n = len(rows)
    list_w = min(n, LIST_WIDTH)
    list_h = -(-n // list_w)
    listed = np.full((list_h * list_w, 2), -1, np.int32)
    listed[:n, 0] = rows
    listed[:n, 1] = cols
    return listed.reshape(list_h, list_w, 2), list_w, list_h


def checked_pixels(pixels: Any, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """The rows and columns of an ``(N, 2)`` integer array of pixels inside a ``(height,
    width)`` image (the CPU marcher's checks: ValueError, TypeError)."""
    p = np.asarray(pixels)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError("pixels must be an (N, 2) array of (row, column)")
    if p.dtype.kind not in "iu":
        raise TypeError("pixels must be an integer array")
    rows, cols = p[:, 0].astype(np.int64), p[:, 1].astype(np.int64)
    if len(p) and (rows.min() < 0 or rows.max() >= height or cols.min() < 0 or cols.max() >= width):
        raise ValueError("pixels must lie in the image: (row, column) in [0, H) x [0, W)")
    return rows, cols


class MarcherGL:
    """Draws 2018 clouds of a :class:`LitScene` with the GLSL marcher (a layer drawer, see
    :mod:`cumuli.rendering.kinds`). Several clouds are marched in one pass, front to back by
    their box entry, as the paper does."""

    #: Draws several clouds of its kind in one pass (the compositor's single-pass path).
    groups = True
    #: Stops every ray at the nearest of the scene's solids (the layer is what lies in front).
    clips_solids = True

    def __init__(self, gl: GLContext, tiles: Any) -> None:
        self.gl = gl
        self.tiles = tiles
        self._variants: dict[str, tuple[Any, Any]] = {}
        self._noise_tex: Any = None
        self._noise_key: tuple[int, int, int] | None = None
        self.program: Any = None
        self.vao: Any = None
        info = gl.ctx.info
        self.max_3d_texture_size = int(info["GL_MAX_3D_TEXTURE_SIZE"])
        #: Largest storage buffer the shader may index (the primitives of all clouds share one).
        self.max_storage_block_size = int(info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27))
        self._use_variant("insertion")

    def _use_variant(self, candidate_sort: str, physical: bool = False) -> None:
        """Make the marcher compiled for ``candidate_sort`` (and the lighting mode) current
        (compiled on first use)."""
        key = (candidate_sort, physical)
        if key not in self._variants:
            defines = {"CANDIDATE_SORT": CANDIDATE_SORTS.index(candidate_sort)}
            if physical:
                defines["PHYSICAL"] = 1
            program = self.gl.program(
                "common/fullscreen.vert.glsl", "marcher/march.frag.glsl", defines=defines
            )
            try:
                vao = self.gl.ctx.vertex_array(program, [])
            except Exception:
                program.release()
                raise
            self._variants[key] = (program, vao)
        self.program, self.vao = self._variants[key]

    def _noise_texture(self, scene: Scene) -> Any:
        key = scene.noise.identity
        if self._noise_key != key:
            if self._noise_tex is not None:
                self._noise_tex.release()
                self._noise_tex = None
            n = scene.noise.size
            tex = self.gl.ctx.texture3d((n, n, n), 1, scene.noise.lattice.tobytes(), dtype="f4")
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            tex.repeat_x = tex.repeat_y = tex.repeat_z = True
            self._noise_tex, self._noise_key = tex, key
        return self._noise_tex

    def _set(self, name: str, value: Any) -> None:
        # Uniforms the compiler optimised away are simply absent.
        if name in self.program:
            self.program[name].value = value

    @staticmethod
    def check(scene: Scene, indices: Sequence[int]) -> None:
        """Checks that need no light: cloud count and primitives per cloud."""
        if len(indices) > MAX_CLOUDS:
            raise ValueError(f"the GL renderer draws at most {MAX_CLOUDS} clouds")
        check_gl_limits(scene, indices)

    def check_light(self, scene: Scene, indices: Sequence[int]) -> None:
        """Limits of the light the light step will make for these clouds (a `Scene` not lit
        yet): the light atlas stacks one ``light_resolution``³ grid per cloud along z, and must
        fit ``GL_MAX_3D_TEXTURE_SIZE`` — checked here, before minutes of light passes."""
        clouds = [k for k in indices if isinstance(scene.clouds[k], Cloud)]
        r = scene.settings.light_resolution
        depth = r * len(clouds)
        if clouds and max(r, depth) > self.max_3d_texture_size:
            raise ValueError(
                f"the light grids of {len(clouds)} clouds at settings.light_resolution={r} need "
                f"a {r}×{r}×{depth} atlas, larger than GL_MAX_3D_TEXTURE_SIZE="
                f"{self.max_3d_texture_size}; use fewer clouds per scene, a smaller "
                "settings.light_resolution, or backend='cpu'"
            )

    def draw(
        self,
        lit: LitScene,
        indices: Sequence[int],
        camera: Camera,
        width: int,
        height: int,
        with_sky: bool,
        pixels: np.ndarray | None = None,
    ) -> np.ndarray:
        """The clouds ``indices`` of ``lit`` over the sky (``with_sky``) or as a premultiplied
        layer ``(colour, 1 − T)``: ``(height, width, 4)`` float32, row 0 on top. With
        ``pixels`` (an ``(N, 2)`` integer array of rows and columns) only those pixels, as
        ``(N, 4)`` values in their order."""
        scene = lit.scene
        physical = scene.settings.physical
        clouds = [scene.clouds[k] for k in indices]
        grids = [lit.lights[k] for k in indices]
        if physical:  # the paper's light atlas is not read: one texel
            nd = [
                LightGrid(np.zeros((1, 1, 1), np.float32), (c.bbox[0], c.bbox[1])) for c in clouds
            ]
            prim_bytes, cloud_bytes, atlas = pack_clouds(clouds, nd, scene.settings.kappa)
        else:
            prim_bytes, cloud_bytes, atlas = pack_clouds(clouds, grids, scene.settings.kappa)
        if len(prim_bytes) > self.max_storage_block_size:
            # Beyond it the driver clamps or drops the reads: primitives would silently vanish.
            raise ValueError(
                f"the scene's {sum(c.n for c in clouds)} primitives need "
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
            self._use_variant(scene.settings.candidate_sort, physical)
            self._noise_texture(scene).use(location=0)
            # Version 2's exact lookup hashes its corners (shaders/common/noise.glsl).
            self._set("u_noise_hash", scene.noise.version == 2)
            self._set("u_noise_key", scene.noise.key)
            light_tex.use(location=1)
            if physical:
                limit = self.max_3d_texture_size
                scratch += bind_physical(ctx, self._set, scene.settings, grids, limit)
            scratch += bind_ground(ctx, self._set, lit, location=4)
            skip = scene.settings.empty_space_skipping
            occ = occupancy_atlas(clouds, skip)
            d, h, w = occ.shape
            occ_tex = ctx.texture3d((w, h, d), 1, occ.tobytes(), dtype="f1")
            scratch.append(occ_tex)
            occ_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            occ_tex.use(location=5)
            self._set("u_occupancy", 5)
            self._set("u_listed", pixels is not None)
            # Always on its own unit: samplers of different types may not share one (unit 0
            # holds the lattice), even when the shader does not read this one.
            self._set("u_pixel_list", 6)
            self._set_uniforms(scene, len(clouds), camera, width, height, with_sky)
            if pixels is None:
                return self.tiles.draw(self.vao, self._set, width, height)
            rows, cols = checked_pixels(pixels, width, height)
            if len(rows) == 0:
                return np.zeros((0, 4), np.float32)
            listed, list_w, list_h = pixel_list(rows, cols)
            list_tex = ctx.texture((list_w, list_h), 2, listed.tobytes(), dtype="i4")
            scratch.append(list_tex)
            list_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            list_tex.use(location=6)
            values = self.tiles.draw(self.vao, self._set, list_w, list_h)
            return np.ascontiguousarray(values.reshape(-1, 4)[: len(rows)])
        finally:
            for obj in scratch:
                obj.release()

    def _set_uniforms(
        self, scene: Scene, count: int, camera: Camera, width: int, height: int, with_sky: bool
    ) -> None:
        s = scene.settings
        set_ = self._set
        set_("u_lattice", 0)
        set_("u_light_atlas", 1)
        for name, value in camera.uniforms(width, height).items():
            set_(name, value)
        # The same values the CPU twin takes (cumuli.rendering.params).
        uniforms = {
            **sky_uniforms(scene.sky, scene.sun),
            **march_uniforms(march_params(s), s.exact_noise),
        }
        for name, value in uniforms.items():
            set_(name, value)
        set_("u_with_sky", bool(with_sky))
        set_("u_cloud_count", count)
        # Opaque solids: each ray stops at the nearest (none: u_solid_count = 0).
        set_solid_uniforms(self.program, scene.solids)

    def release(self) -> None:
        """Release the programs and the noise texture (idempotent)."""
        if not self.gl.closed:
            for program, vao in self._variants.values():
                for obj in (vao, program):
                    try:
                        obj.release()
                    except Exception:
                        pass
            if self._noise_tex is not None:
                self._noise_tex.release()
        self._variants.clear()
        self._noise_tex = None
        self._noise_key = None
