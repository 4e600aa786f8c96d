"""Drawers of billboard clouds and fields (Torchelsen & Musse 2005 §3.2, §5; spec §4.2, §5;
RENDER_CONTRACT "Billboards").

Both drawers share one frame builder, :func:`billboard_frame` (C++ ``billboard_sprites``): the
billboards of every cloud of the pass (a `BillboardCloud`, or each instance of a
`BillboardField`) are culled, faded (instance formation/dissipation alpha, optional near and far
fades), ordered back to front (clouds by the distance of their centre, then their billboards;
``global_sort``: all billboards together) and shaded — per quad corner ([TM]'s vertex shading,
with the CAF of `cumuli.light.billboards` and the scene's `BillboardShading`) or per pixel
(``shading="fragment"``). The atlases of the pass become one texture (:func:`combined_atlas`).
:class:`BillboardGL` draws the batch with the shared GL sprite pipeline
(:class:`cumuli.gl.sprites.SpriteLayerRenderer`), :func:`draw_billboards_cpu` with its C++ twin;
over the sky, the layer goes through the C++ compositor with the pass's box, so both backends
add the same sky. Billboard clouds and fields group (``groups = True``): a scene of only
billboards is one pass, one sort.

Solids (``Scene.solids``, Harris 2002 §3.1.1): drawn directly, every billboard is depth-tested
against the solids' view depth (``clips_solids``: the hard cuts of [H] Fig. 7 left);
:meth:`BillboardGL.draw_split` / :func:`split_billboards_cpu` cut a cloud's sorted billboards at
the solids' sort keys into ``m + 1`` layers for impostor splitting (Fig. 7 right).

Impostors (`cumuli.ImpostorCache`) keep one impostor per `BillboardCloud` and one per field
*instance* (`BillboardField.impostor_parts`, `BillboardField.part`): each is this drawer's image
of the cloud alone. :func:`cloud_spheres` gives every cloud's bounding sphere and
``billboard_frame(..., exclude=mask)`` leaves clouds out of a pass.
"""

from __future__ import annotations

import functools
import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli import _core
from cumuli.camera import Camera
from cumuli.gl.sprite_shading import MAX_SHADE_LIGHTS, FragmentShading
from cumuli.gl.sprites import (
    MAX_SPRITES,
    SpriteLayerRenderer,
    Sprites,
    camera_dict,
    draw_sprites_cpu,
)
from cumuli.light import sprite_physical
from cumuli.light.billboards import BillboardLighting
from cumuli.light.caf import default_max_distance
from cumuli.light.prepare import LitScene
from cumuli.model.atlas import SpriteAtlas
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BillboardCloud
from cumuli.rendering.params import camera_params
from cumuli.rendering.solids import SolidsGL, draw_solids_cpu, solid_depth
from cumuli.sky import sky_args

#: Largest combined atlas edge (texels) — the common GL_MAX_TEXTURE_SIZE floor.
MAX_ATLAS_EDGE = 16384
_spheres: weakref.WeakKeyDictionary[BillboardCloud, tuple[tuple[float, ...], float]] = (
    weakref.WeakKeyDictionary()
)


@dataclass(frozen=True, eq=False)
class BillboardFrame:
    """What one pass draws: ``sprites`` back to front, the combined ``atlas`` and its ``grid``,
    the per-pixel ``shading`` (fragment mode, else None), and each sprite's provenance:
    ``cloud`` (index in :func:`cloud_spheres` order) and ``billboard`` (index in its cloud)."""

    sprites: Sprites
    atlas: np.ndarray
    grid: tuple[int, int]
    shading: FragmentShading | None
    cloud: np.ndarray
    billboard: np.ndarray


# --- atlases -----------------------------------------------------------------------------------
def _resample(cell: np.ndarray, w: int, h: int) -> np.ndarray:
    """Bilinear resample of one cell to ``w × h`` texels (texel-centre convention, clamped)."""
    ch, cw = cell.shape[:2]
    ys = np.clip((np.arange(h) + 0.5) * ch / h - 0.5, 0, ch - 1)
    xs = np.clip((np.arange(w) + 0.5) * cw / w - 0.5, 0, cw - 1)
    y0, x0 = np.floor(ys).astype(int), np.floor(xs).astype(int)
    y1, x1 = np.minimum(y0 + 1, ch - 1), np.minimum(x0 + 1, cw - 1)
    fy, fx = (ys - y0)[:, None, None], (xs - x0)[None, :, None]
    top = cell[y0][:, x0] * (1 - fx) + cell[y0][:, x1] * fx
    bottom = cell[y1][:, x0] * (1 - fx) + cell[y1][:, x1] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)


@functools.lru_cache(maxsize=16)
def combined_atlas(atlases: tuple[SpriteAtlas, ...]) -> tuple[np.ndarray, tuple[int, int], tuple]:
    """One read-only atlas image holding the cells of ``atlases`` in order: ``(image, grid,
    bases)``, atlas ``a``'s cell ``i`` at cell ``bases[a] + i``. A single atlas is used as it
    is; cells of another size are resampled (bilinear) to the largest cell size."""
    if len(atlases) == 1:
        a = atlases[0]
        return a.image, a.grid, (0,)
    cw = max(a.sprite_size[0] for a in atlases)
    ch = max(a.sprite_size[1] for a in atlases)
    total = sum(a.count for a in atlases)
    nx = math.ceil(math.sqrt(total))
    ny = math.ceil(total / nx)
    if nx * cw > MAX_ATLAS_EDGE or ny * ch > MAX_ATLAS_EDGE:
        raise ValueError(
            f"the pass's {len(atlases)} atlases ({total} cells of {cw}×{ch}) do not fit one "
            f"{MAX_ATLAS_EDGE}² texture: use fewer atlases or smaller cells"
        )
    image = np.zeros((ny * ch, nx * cw, 4), np.float32)
    bases, cell = [], 0
    for a in atlases:
        bases.append(cell)
        for i in range(a.count):
            sprite = a.sprite(i)
            if sprite.shape[:2] != (ch, cw):
                sprite = _resample(sprite, cw, ch)
            r, c = divmod(cell, nx)
            image[r * ch : (r + 1) * ch, c * cw : (c + 1) * cw] = sprite
            cell += 1
    image.setflags(write=False)
    return image, (nx, ny), tuple(bases)


# --- the frame ----------------------------------------------------------------------------------
def _parts(lit: LitScene, indices: Sequence[int]) -> list[tuple[Any, BillboardLighting]]:
    out = []
    for k in indices:
        d = lit.scene.clouds[k]
        light = lit.lights[k]
        if not isinstance(d, (BillboardCloud, BillboardField)):
            raise TypeError(f"scene.clouds[{k}] is not a billboard cloud or field")
        if not isinstance(light, BillboardLighting):
            raise TypeError(f"the light of scene.clouds[{k}] is not a BillboardLighting")
        out.append((d, light))
    return out


def _variants(d: Any) -> tuple[BillboardCloud, ...]:
    return (d,) if isinstance(d, BillboardCloud) else d.variants


def _sphere(v: BillboardCloud) -> tuple[tuple[float, ...], float]:
    known = _spheres.get(v)
    if known is None:
        c, r = v.sphere()
        known = (tuple(float(x) for x in c), float(r))
        _spheres[v] = known
    return known


def cloud_spheres(lit: LitScene, indices: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """The bounding sphere ``(centres (N, 3), radii (N,))`` of every cloud of the pass (a cloud,
    or a field's instance, in scene order), world space, holding all its quads."""
    centres, radii = [], []
    for d, _ in _parts(lit, indices):
        if isinstance(d, BillboardCloud):
            c, r = _sphere(d)
            centres.append(np.array([c]))
            radii.append([r])
            continue
        c, r = d.instance_spheres()
        centres.append(c)
        radii.append(r)
    if not centres:
        return np.zeros((0, 3), np.float32), np.zeros(0, np.float32)
    return (np.concatenate(centres).astype(np.float32),
            np.concatenate(radii).astype(np.float32))  # fmt: skip


def billboard_frame(
    lit: LitScene,
    indices: Sequence[int],
    camera: Camera,
    width: int,
    height: int,
    threads: int = 0,
    exclude: Any = None,
) -> BillboardFrame:
    """The sprites one pass draws of the billboard clouds/fields ``indices`` of ``lit`` (see the
    module docstring). ``exclude``: a bool mask over :func:`cloud_spheres`' clouds to leave out
    (clouds left to another drawing, e.g. their impostors)."""
    parts = _parts(lit, indices)
    shading = lit.scene.billboard_shading
    atlases: list[SpriteAtlas] = []
    for d, _ in parts:
        for v in _variants(d):
            if v.atlas not in atlases:
                atlases.append(v.atlas)
    image, grid, bases = combined_atlas(tuple(atlases)) if atlases else (
        np.zeros((1, 1, 4), np.float32), (1, 1), ())  # fmt: skip
    variants: list[dict[str, Any]] = []
    cols: list[np.ndarray] = []
    inst: dict[str, list[np.ndarray]] = {k: [] for k in ("variant", "off", "yaw", "alpha", "first")}
    n_cols = 0
    suns = parts[0][1].lights if parts else (lit.scene.sun, *lit.scene.lights)
    for d, light in parts:
        base = len(variants)
        for v in _variants(d):
            c, r = _sphere(v)
            variants.append({
                "centres": v.centres, "sizes": v.sizes, "rotation": v.rotation,
                "texture": v.texture, "box": v.box, "boxes": v.boxes, "sphere_centre": c,
                "sphere_radius": r, "opacity": v.opacity,
                "texture_base": bases[atlases.index(v.atlas)],
            })  # fmt: skip
        caf = light.caf
        cols.append(caf)
        if isinstance(d, BillboardCloud):
            inst["variant"].append(np.array([base]))
            inst["off"].append(np.zeros((1, 3)))
            inst["yaw"].append(np.zeros(1))
            inst["alpha"].append(np.ones(1))
            inst["first"].append(np.array([n_cols]))
        else:
            inst["variant"].append(d.variant.astype(np.int64) + base)
            inst["off"].append(d.offsets)
            inst["yaw"].append(d.yaw)
            inst["alpha"].append(d.alpha)
            inst["first"].append(light.records[0].first[:-1] + n_cols)
        n_cols += caf.shape[1]
    n_lights = len(suns)
    caf = np.concatenate(cols, axis=1) if cols else np.zeros((n_lights, 0), np.float32)
    cat = {k: np.concatenate(v) if v else np.zeros(0) for k, v in inst.items()}
    alpha = cat["alpha"].astype(np.float32)
    if exclude is not None:
        mask = np.asarray(exclude)
        if mask.dtype != bool or mask.shape != alpha.shape:
            raise ValueError(f"exclude must be a bool mask of shape {alpha.shape}")
        alpha = np.where(mask, np.float32(0), alpha)
    shade = shading.shade_dict(lit.scene.sky)
    shade["light_dirs"] = np.array([s.direction for s in suns], np.float32).reshape(-1, 3)
    shade["light_radiance"] = np.array([s.radiance for s in suns], np.float32).reshape(-1, 3)
    cam = camera_dict(camera, width, height, shading.near)
    physical = lit.scene.settings.physical
    draw = shading.draw_dict()
    if physical:  # the physical mode shades the corners (below)
        draw["fragment"] = False
    args = (variants, cat["variant"].astype(np.int32),
            cat["off"].reshape(-1, 3).astype(np.float32), cat["yaw"].astype(np.float32), alpha,
            cat["first"].astype(np.int64), np.ascontiguousarray(caf, np.float32))  # fmt: skip
    out = _core.billboard_sprites(*args, shade, cam, draw, threads)
    if physical:
        out["colours"] = _physical_colours(lit, parts, args, shade, cam, draw, out, camera,
                                           threads)  # fmt: skip
    if out["centres"].shape[0] > MAX_SPRITES:
        raise ValueError(f"the pass draws {out['centres'].shape[0]} billboards (> {MAX_SPRITES})")
    sprites = Sprites(out["centres"], out["half_sizes"], out["colours"], out["alpha"],
                      out["rotation"], out["texture"])  # fmt: skip
    fragment = None
    if shading.shading == "fragment" and not physical:
        fragment = FragmentShading(out["frame"], out["yrange"], out["caf"], shade["light_dirs"],
                                   shade["light_radiance"], shade)  # fmt: skip
    return BillboardFrame(sprites, image, grid, fragment, out["instance"], out["billboard"])


def _physical_colours(
    lit: LitScene, parts: list, args: tuple, shade: dict, cam: dict, draw: dict, out: dict,
    camera: Camera, threads: int,
) -> np.ndarray:  # fmt: skip
    """The physical mode's corner colours of a pass
    (:func:`cumuli.light.sprite_physical.billboard_colours`): each cloud's proxy light at the
    corners; every light's ``H·CAF·D`` there from the paper's vertex shading with one light
    per colour channel and no ambient, and the scene's shadow on the cloud (the CAF through
    the scene over the cloud's own)."""
    scene = lit.scene
    n = out["centres"].shape[0]
    trans = _corner_light(args, args[6], shade, cam, draw, threads, n)
    shadow = np.ones((n, 4))
    if n and any(light.unshadowed is not None for _, light in parts):
        own = np.concatenate([(light.unshadowed or light).caf for _, light in parts], axis=1)
        mine = _corner_light(args, own.astype(np.float32), shade, cam, draw, threads, n)
        shadow = sprite_physical.shadow_factor(trans[..., 0], mine[..., 0])
    sprites = Sprites(out["centres"], out["half_sizes"], out["colours"], out["alpha"],
                      out["rotation"], out["texture"])  # fmt: skip
    points = sprite_physical.corners(sprites.centres, sprites.half_sizes, sprites.rotation, camera)
    lights = _proxy_lights(lit, parts, threads)
    return sprite_physical.billboard_colours(
        scene, lights, np.asarray(out["instance"], np.int64), points, trans, shadow,
        camera.position,
    )  # fmt: skip


def _corner_light(args: tuple, caf: np.ndarray, shade: dict, cam: dict, draw: dict,
                  threads: int, n: int) -> np.ndarray:  # fmt: skip
    """``(N, 4, L)``: each light's ``H·CAF·D`` at every corner, by the C++ vertex shading with
    three lights at a time, one per colour channel, no ambient."""
    n_lights = shade["light_dirs"].shape[0]
    out = np.zeros((n, 4, n_lights), np.float32)
    for first in range(0, n_lights, 3):
        rows = list(range(first, min(first + 3, n_lights)))
        one = dict(shade, ambient=(0.0, 0.0, 0.0), k_amb=0.0)
        one["light_dirs"] = shade["light_dirs"][rows]
        one["light_radiance"] = np.eye(3, dtype=np.float32)[: len(rows)]
        got = _core.billboard_sprites(*args[:6], np.ascontiguousarray(caf[rows]), one, cam,
                                      draw, threads)  # fmt: skip
        colours = np.asarray(got["colours"], np.float32).reshape(n, 4, 3)
        out[:, :, rows] = colours[..., : len(rows)]
    return out


def _proxy_lights(lit: LitScene, parts: list, threads: int) -> list[tuple[Any, np.ndarray]]:
    """Per cloud of the pass (:func:`cloud_spheres` order): the physical light of its proxy
    medium and the point its lattice is built about. A field instance reads its variant's
    (``FIELD_GRID`` cells, not turned by its yaw: the light keeps its side towards the sun)."""
    md = lit.scene.billboard_shading.max_distance
    out = []
    for d, _ in parts:
        if isinstance(d, BillboardCloud):
            placed = [(d, sprite_physical.GRID, np.zeros(3))]
        else:
            cells = sprite_physical.FIELD_GRID
            placed = [(d.variants[int(d.variant[i])], cells, np.asarray(d.offsets[i], np.float64))
                      for i in range(d.n)]  # fmt: skip
        for v, cells, offset in placed:
            dist = default_max_distance(v) if md is None else md
            known = _lattices.setdefault(v, {})
            if (dist, cells) not in known:
                known[(dist, cells)] = sprite_physical.box_extinction(v.boxes, dist, cells)
            light = sprite_physical.proxy_light(known[(dist, cells)], lit.scene)
            out.append((light, offset))
    return out


#: Each variant's proxy lattices by ``(max_distance, cells)``.
_lattices: weakref.WeakKeyDictionary[BillboardCloud, dict] = weakref.WeakKeyDictionary()


#: The box `finish` composites a pass's layer with: every ray enters it.
_EVERYWHERE = np.array([[[-1e30] * 3, [1e30] * 3]], np.float32)


def finish(layer: np.ndarray, lit: LitScene, camera: Camera, threads: int = 0) -> np.ndarray:
    """The layer over the sky: ``rgb = C + (1 − A)·sky(d)``, ``alpha = A`` at every pixel, by the
    C++ compositor (one layer, a box every ray enters), as both backends do."""
    scene = lit.scene
    return _core.composite_layers(
        layer[None], _EVERYWHERE, camera_params(camera), sky_args(scene.sky), scene.sun.direction,
        scene.sun.radiance, threads,
    )  # fmt: skip


def check_pass(scene: Any, indices: Sequence[int]) -> None:
    """Limits that need no light: lights of fragment shading and the combined atlas size."""
    shading = scene.billboard_shading
    if shading.shading == "fragment" and 1 + len(scene.lights) > MAX_SHADE_LIGHTS:
        raise ValueError(f"fragment shading takes at most {MAX_SHADE_LIGHTS} lights (sun included)")
    atlases: list[SpriteAtlas] = []
    total = 0
    for k in indices:
        d = scene.clouds[k]
        for v in _variants(d):
            if v.atlas not in atlases:
                atlases.append(v.atlas)
        if isinstance(d, BillboardCloud):
            total += d.n_billboards
        else:
            counts = np.bincount(d.variant, minlength=len(d.variants))
            total += sum(v.n_billboards * int(c) for v, c in zip(d.variants, counts, strict=True))
    if total > MAX_SPRITES:
        raise ValueError(f"the scene's billboard clouds hold {total} billboards (> {MAX_SPRITES})")
    if atlases:
        combined_atlas(tuple(atlases))


# --- solids and splitting ----------------------------------------------------------------------
def sort_key(lit: LitScene, point: Sequence[float], camera: Camera) -> float:
    """The billboard sort key of a point (``BillboardShading.sort``: ``"distance"`` |p − eye| or
    ``"depth"`` (p − eye)·f): where impostor splitting cuts a cloud around a solid."""
    v = np.subtract(point, camera.position, dtype=np.float64)
    if lit.scene.billboard_shading.sort == "depth":
        return float(v @ camera.basis()[0].astype(np.float64))
    return float(np.linalg.norm(v))


def split_frames(
    lit: LitScene, k: int, camera: Camera, width: int, height: int, cuts: Sequence[float],
    threads: int = 0,
) -> tuple[BillboardFrame, list[tuple[Sprites, FragmentShading | None]]]:  # fmt: skip
    """Drawable ``k``'s frame and its billboards, in drawing order, cut at the sort keys
    ``cuts`` ([H] §3.1.1): ``m + 1`` batches, farthest first — batch j holds the billboards whose
    key lies between the (m − j)-th and the (m − j + 1)-th smallest cut (lower bound
    inclusive), in drawing order. A cloud's (or one instance's) billboards are drawn by
    decreasing key, so the batches are consecutive runs of the unsplit drawing; several
    instances' billboards regroup by key across instances (the impostor cache splits instance
    by instance)."""
    frame = billboard_frame(lit, [k], camera, width, height, threads)
    sp, shading = frame.sprites, frame.shading
    v = sp.centres.astype(np.float64) - np.asarray(camera.position, np.float64)
    if lit.scene.billboard_shading.sort == "depth":
        keys = v @ camera.basis()[0].astype(np.float64)
    else:
        keys = np.linalg.norm(v, axis=1)
    z = np.sort(np.asarray(cuts, dtype=np.float64))
    bins = len(z) - np.searchsorted(z, keys, side="right")
    out = []
    for j in range(len(z) + 1):
        sel = np.flatnonzero(bins == j)
        part = Sprites(sp.centres[sel], sp.half_sizes[sel], sp.colours[sel], sp.alpha[sel],
                       sp.rotation[sel] if sp.rotation is not None else None,
                       sp.texture[sel] if sp.texture is not None else None)  # fmt: skip
        rows = None
        if shading is not None:
            rows = FragmentShading(shading.frame[sel], shading.yrange[sel], shading.caf[sel],
                                   shading.light_dirs, shading.light_radiance,
                                   shading.params)  # fmt: skip
        out.append((part, rows))
    return frame, out


# --- drawers ------------------------------------------------------------------------------------
class BillboardGL:
    """GL drawer of billboard clouds and fields: the shared sprite pipeline (see the module
    docstring). One `SpriteLayerRenderer` per `cumuli.Renderer`; atlas textures are cached."""

    groups = True
    #: Draws only what lies in front of the scene's solids (depth test): exact with solids.
    clips_solids = True

    def __init__(self, gl: Any, tiles: Any) -> None:
        self.gl = gl
        self.tiles = tiles
        self.sprites = SpriteLayerRenderer(gl, tile=tiles.tile)
        self._solids: SolidsGL | None = None

    @staticmethod
    def check(scene: Any, indices: Sequence[int]) -> None:
        check_pass(scene, indices)

    def _splat(self, lit: LitScene, frame: Any, sprites: Sprites, shading: Any, camera: Camera,
               width: int, height: int, depth: Any = None) -> np.ndarray:  # fmt: skip
        sh = lit.scene.billboard_shading
        layer = self.sprites.draw(
            sprites, camera, width, height, atlas=frame.atlas, atlas_grid=frame.grid,
            exact=sh.exact_textures, near=sh.near, shading=shading, depth=depth,
        )  # fmt: skip
        gpu = self.sprites.gpu_time_ns
        self.tiles.last_gpu_ns = gpu if gpu is not None and 0 <= gpu < (1 << 62) else None
        return layer

    def draw(self, lit: LitScene, indices: Sequence[int], camera: Camera, width: int,
             height: int, with_sky: bool) -> np.ndarray:  # fmt: skip
        frame = billboard_frame(lit, indices, camera, width, height)
        depth = None
        if lit.scene.solids:
            if self._solids is None:
                self._solids = SolidsGL(self.gl, self.tiles)
            scene = lit.scene
            depth = solid_depth(self._solids.draw(scene.solids, scene.sun, camera, width, height))
        layer = self._splat(lit, frame, frame.sprites, frame.shading, camera, width, height, depth)
        return finish(layer, lit, camera) if with_sky else layer

    def draw_split(self, lit: LitScene, k: int, camera: Camera, width: int, height: int,
                   cuts: Sequence[float]) -> np.ndarray:  # fmt: skip
        """Drawable ``k`` as ``m + 1`` premultiplied layers ``(m + 1, H, W, 4)``, farthest
        first, cut at the sort keys ``cuts`` (:func:`split_frames`; no depth test)."""
        frame, batches = split_frames(lit, k, camera, width, height, cuts)
        return np.stack([self._splat(lit, frame, sp, sh, camera, width, height)
                         for sp, sh in batches])  # fmt: skip

    def release(self) -> None:
        self.sprites.release()
        if self._solids is not None:
            self._solids.release()


def draw_billboards_cpu(lit: LitScene, indices: Sequence[int], camera: Camera, width: int,
                        height: int, with_sky: bool, threads: int = 0) -> np.ndarray:  # fmt: skip
    """The CPU twin of :meth:`BillboardGL.draw` (C++ sprite rasteriser, exact atlas sampling)."""
    check_pass(lit.scene, indices)  # the sprite-count and atlas limits, before any allocation
    frame = billboard_frame(lit, indices, camera, width, height, threads)
    scene = lit.scene
    depth = None
    if scene.solids:
        depth = solid_depth(
            draw_solids_cpu(scene.solids, scene.sun, camera, width, height, threads)
        )
    layer = draw_sprites_cpu(
        frame.sprites, camera, width, height, atlas=frame.atlas, atlas_grid=frame.grid,
        near=scene.billboard_shading.near, threads=threads, shading=frame.shading, depth=depth,
    )  # fmt: skip
    return finish(layer, lit, camera, threads) if with_sky else layer


def split_billboards_cpu(lit: LitScene, k: int, camera: Camera, width: int, height: int,
                         cuts: Sequence[float], threads: int = 0) -> np.ndarray:  # fmt: skip
    """The CPU twin of :meth:`BillboardGL.draw_split`."""
    check_pass(lit.scene, [k])
    frame, batches = split_frames(lit, k, camera, width, height, cuts, threads)
    near = lit.scene.billboard_shading.near
    return np.stack([
        draw_sprites_cpu(sp, camera, width, height, atlas=frame.atlas, atlas_grid=frame.grid,
                         near=near, threads=threads, shading=sh)
        for sp, sh in batches
    ])  # fmt: skip
