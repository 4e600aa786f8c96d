"""Billboard-cloud lighting (Torchelsen & Musse 2005 §3.2, Figs. 6–7, 9; spec §4).

**CAF** ("Computation of Absorption Factor"): from each box centre (or billboard centre,
``at="billboard"``) a ray runs towards the sun through the cloud's boxes (cumuli's slab test);
``L`` is the sum of the chords ("the sum of the red lines", ``overlap="sum"``) or the length of
their union (``"union"``, each point once); ``CAF = clamp(1 − L/D_max, 0, 1)`` (``curve="linear"``)
or ``exp(−3L/D_max)`` (``"exp"``); ``D_max = ∞`` gives 1. The owning box contributes its exit chord
unless ``include_self=False``. `absorption_factors` returns a `BillboardLight` value record; it is
never stored on the cloud. `field_absorption_factors` does the same for every instance of a
`BillboardField`, optionally through the other instances' boxes (``shadow_between_clouds``).

**Colour** per shading point ``v`` (a quad corner with ``shading="vertex"``, [TM]):
``k_amb·ambient + H(f_v)·Σ_ℓ CAF_ℓ·D_ℓ(v)·radiance_ℓ`` with the directional term
``D = d_min + (d_max − d_min)·((1 + cos φ)/2)^k_dir``, ``cos φ`` between ``v − c_C`` and the light;
``ambient`` defaults to the sky's mean ``(zenith + horizon)/2`` (C++: ``light/caf.hpp``).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli._util.structs import core_struct
from cumuli.light.billboard_shading import (  # noqa: F401  (re-exported)
    CAF_AT,
    CURVES,
    DIRECTIONAL,
    OVERLAPS,
    SHADING,
    BillboardShading,
    _choice,
    _max_distance,
)
from cumuli.light.footprint import box_corners, footprint
from cumuli.light.ndt import light_grid
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BillboardCloud
from cumuli.sky import Sun


def _sun_direction(sun: Any) -> tuple[float, float, float]:
    if isinstance(sun, Sun):
        return sun.direction
    if isinstance(sun, (Sequence, np.ndarray)) and not isinstance(sun, str):
        return check.direction(sun, "sun")
    raise TypeError(f"sun must be a cumuli.Sun or a direction (x, y, z), got {type(sun).__name__}")


def cloud_digest(cloud: BillboardCloud) -> str:
    """A short hash of a cloud's boxes and billboard centres (a CAF belongs to these)."""
    h = hashlib.blake2b(digest_size=12)
    for a in (cloud.boxes, cloud.box, cloud.centres):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


@dataclass(frozen=True, eq=False)
class BillboardLight:
    """What `absorption_factors` computed: ``caf`` ``(M,)`` per box (or ``(K,)`` per billboard,
    ``at="billboard"``) float32, the path lengths ``length`` (float64), the normalised ``sun``
    direction and ``params`` (max_distance, overlap, curve, include_self, at, cloud digest)."""

    caf: np.ndarray
    length: np.ndarray
    sun: tuple[float, float, float]
    at: str
    params: dict[str, Any] = field(default_factory=dict)

    def billboard_caf(self, cloud: BillboardCloud) -> np.ndarray:
        """The CAF of each billboard ``(K,)`` (its box's, or its own with ``at="billboard"``)."""
        self.check(cloud)
        return self.caf if self.at == "billboard" else self.caf[cloud.box]

    def check(self, cloud: BillboardCloud, sun: Any = None, tolerance: float = 1.0) -> None:
        """ValueError unless this record belongs to ``cloud`` (and to ``sun`` within
        ``tolerance`` degrees, when given)."""
        if self.params.get("cloud") != cloud_digest(cloud):
            raise ValueError("light was computed for another cloud (boxes or billboards differ)")
        if sun is not None:
            s = np.asarray(_sun_direction(sun))
            angle = math.degrees(math.acos(float(np.clip(np.dot(s, self.sun), -1.0, 1.0))))
            if angle > tolerance:
                raise ValueError(
                    f"light was computed for another sun direction ({angle:.2f}° away, "
                    f"tolerance {tolerance}°): recompute absorption_factors"
                )


def default_max_distance(cloud: BillboardCloud) -> float:
    """``2 × height`` of the cloud's box AABB (the spec's "2 × typical cloud height")."""
    lo, hi = cloud.box_bounds()
    return 2.0 * max(float(hi[1] - lo[1]), 1e-6)


def _points(cloud: BillboardCloud, at: str) -> tuple[np.ndarray, np.ndarray]:
    if at == "box":
        return cloud.box_centres, np.arange(cloud.n_boxes, dtype=np.int32)
    return cloud.centres, cloud.box


def absorption_factors(
    cloud: BillboardCloud,
    sun: Sun | Sequence[float],
    max_distance: float | None = None,
    overlap: str = "sum",
    curve: str = "linear",
    include_self: bool = True,
    at: str = "box",
    threads: int = 0,
) -> BillboardLight:
    """CAF of every box (or billboard) of ``cloud`` for ``sun`` (spec §4.1; C++, threads,
    deterministic). ``max_distance`` D_max > 0 or ``math.inf`` (None: `default_max_distance`)."""
    if not isinstance(cloud, BillboardCloud):
        raise TypeError(f"cloud must be a BillboardCloud, got {type(cloud).__name__}")
    s = _sun_direction(sun)
    d_max = _max_distance(max_distance, default_max_distance(cloud))
    overlap = _choice(overlap, "overlap", OVERLAPS)
    curve = _choice(curve, "curve", CURVES)
    at = _choice(at, "at", CAF_AT)
    if not isinstance(include_self, bool):
        raise TypeError("include_self must be a bool")
    threads = check.threads(threads)
    points, owner = _points(cloud, at)
    length = _core.caf_path_lengths(cloud.boxes, points, owner, s, overlap, include_self, threads)
    caf = _core.caf_values(length, d_max, curve)
    for a in (caf, length):
        a.setflags(write=False)
    params = {
        "max_distance": "inf" if math.isinf(d_max) else d_max,
        "overlap": overlap,
        "curve": curve,
        "include_self": include_self,
        "at": at,
        "cloud": cloud_digest(cloud),
    }
    return BillboardLight(caf, length, s, at, params)


@dataclass(frozen=True, eq=False)
class FieldLight:
    """CAFs of every instance of a field: ``caf`` flat float32, instance ``i``'s block is
    ``caf[first[i]:first[i + 1]]`` (its variant's boxes or billboards, in variant order)."""

    caf: np.ndarray
    length: np.ndarray
    first: np.ndarray
    sun: tuple[float, float, float]
    at: str
    params: dict[str, Any] = field(default_factory=dict)

    def instance(self, index: int) -> np.ndarray:
        """Instance ``index``'s CAF block."""
        i = check.integer(index, "index", 0, self.first.size - 2)
        return self.caf[self.first[i] : self.first[i + 1]]


def _local(v: Any, c: float, s: float) -> tuple[float, float, float]:
    """``R_yᵀ·v``: a world vector in an instance's local frame."""
    x, y, z = (float(a) for a in v)
    return (c * x - s * z, y, s * x + c * z)


def instance_vertex_colours(
    field_: BillboardField,
    index: int,
    sun: Sun,
    light: FieldLight,
    right: Sequence[float],
    up: Sequence[float],
    shading: BillboardShading | None = None,
    sky: Any = None,
    threads: int = 0,
) -> np.ndarray:
    """`vertex_colours` of instance ``index`` of a field, ``(K, 4, 3)`` in the corner order of
    `quad_corners`: shaded in the variant's local frame (sun, camera right/up turned by −yaw),
    with the instance's CAF block of ``light`` (`field_absorption_factors`). The world corners
    are the local ones turned by yaw and moved by the offset."""
    if not isinstance(field_, BillboardField):
        raise TypeError(f"field must be a BillboardField, got {type(field_).__name__}")
    if not isinstance(light, FieldLight) or not isinstance(sun, Sun):
        raise TypeError("light must be a FieldLight and sun a cumuli.Sun")
    i = check.integer(index, "index", 0, field_.n - 1)
    if light.first.size != field_.n + 1:
        raise ValueError("light was computed for another field (instance count differs)")
    tol = (shading or BillboardShading()).relight_tolerance
    cos_angle = float(np.clip(np.dot(sun.direction, light.sun), -1.0, 1.0))
    if math.degrees(math.acos(cos_angle)) > tol:
        raise ValueError("light was computed for another sun direction: recompute it")
    cloud = field_.variants[int(field_.variant[i])]
    c, s = _core.yaw_cos_sin(float(field_.yaw[i]))
    block = light.instance(i)
    expected = cloud.n_boxes if light.at == "box" else cloud.n_billboards
    if block.size != expected:
        raise ValueError("light was computed for another field (variant sizes differ)")
    local_sun = Sun(_local(sun.direction, c, s), sun.colour, sun.intensity)
    params = dict(light.params, cloud=cloud_digest(cloud))
    record = BillboardLight(block, light.length[light.first[i] : light.first[i + 1]],
                            local_sun.direction, light.at, params)  # fmt: skip
    return vertex_colours(
        cloud, local_sun, record, _local(check.vec3(right, "right"), c, s),
        _local(check.vec3(up, "up"), c, s), shading, sky, threads=threads,
    )  # fmt: skip


def field_absorption_factors(
    field_: BillboardField,
    sun: Sun | Sequence[float],
    max_distance: float | None = None,
    overlap: str = "sum",
    curve: str = "linear",
    include_self: bool = True,
    at: str = "box",
    shadow_between_clouds: bool = False,
    threads: int = 0,
) -> FieldLight:
    """CAF of every instance of ``field_`` (spec §4.1). Each instance's own cloud is traced
    exactly in its local frame (the sun turned by −yaw); with ``shadow_between_clouds`` (beyond
    [TM]) the rays also cross the other instances' boxes (as world AABBs of the turned boxes,
    found through a uniform grid). None ``max_distance``: 2 × the mean variant height."""
    if not isinstance(field_, BillboardField):
        raise TypeError(f"field must be a BillboardField, got {type(field_).__name__}")
    s = _sun_direction(sun)
    default = float(np.mean([default_max_distance(v) for v in field_.variants]))
    d_max = _max_distance(max_distance, default)
    overlap = _choice(overlap, "overlap", OVERLAPS)
    curve = _choice(curve, "curve", CURVES)
    at = _choice(at, "at", CAF_AT)
    for name, v in (
        ("include_self", include_self),
        ("shadow_between_clouds", shadow_between_clouds),
    ):
        if not isinstance(v, bool):
            raise TypeError(f"{name} must be a bool")
    threads = check.threads(threads)
    pts = [_points(v, at) for v in field_.variants]
    length = _core.field_path_lengths(
        [v.boxes for v in field_.variants],
        [p[0] for p in pts],
        [p[1] for p in pts],
        field_.variant,
        field_.offsets,
        field_.yaw,
        s,
        overlap,
        include_self,
        shadow_between_clouds,
        threads,
    )
    sizes = np.array([pts[v][0].shape[0] for v in field_.variant], dtype=np.int64)
    first = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    caf = _core.caf_values(length, d_max, curve)
    for a in (caf, length, first):
        a.setflags(write=False)
    params = {
        "max_distance": "inf" if math.isinf(d_max) else d_max,
        "overlap": overlap,
        "curve": curve,
        "include_self": include_self,
        "at": at,
        "shadow_between_clouds": shadow_between_clouds,
    }
    return FieldLight(caf, length, first, s, at, params)


def ground_caf_digest(drawable: BillboardCloud | BillboardField) -> str:
    """A short hash of what `ground_caf` depends on besides the sun and the shading: the boxes
    (a cloud's are in world space) and, for a field, its instances' variants, yaws, offsets and
    alphas."""
    if isinstance(drawable, BillboardCloud):
        return cloud_digest(drawable)
    h = hashlib.blake2b(digest_size=12)
    for v in drawable.variants:
        h.update(cloud_digest(v).encode())
    for a in (drawable.variant, drawable.yaw, drawable.offsets, drawable.alpha):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def ground_caf(
    drawable: BillboardCloud | BillboardField,
    sun: Sun | Sequence[float],
    points: Any,
    shading: BillboardShading | None = None,
    threads: int = 0,
) -> np.ndarray:
    """Sunlight transmittance ``(M,)`` through a billboard cloud or field at world ``points``
    ``(M, 3)``, for the cloud's shadow on the ground (beyond [TM]): the CAF the cloud's own
    billboards would get there (spec §4.1 with ``shading``'s ``max_distance``, ``overlap`` and
    ``caf_curve``: the chords of the ray towards the sun through its boxes; 1 where it crosses
    none). Each field instance shades on its own, faded with its alpha (``1 − α·(1 − CAF)``),
    and the instances' shadows multiply. A sun at or below the horizon gives ones."""
    if not isinstance(drawable, (BillboardCloud, BillboardField)):
        raise TypeError(
            f"expected a BillboardCloud or BillboardField, got {type(drawable).__name__}"
        )
    s = np.asarray(_sun_direction(sun), np.float64)
    pts = check.points3(points, "points", bound=check.MAX_COORD)
    sh = BillboardShading() if shading is None else shading
    if not isinstance(sh, BillboardShading):
        raise TypeError(f"shading must be a BillboardShading, got {type(sh).__name__}")
    threads = check.threads(threads)
    out = np.ones(pts.shape[0], np.float32)
    if s[1] <= 0 or pts.shape[0] == 0:
        return out
    if isinstance(drawable, BillboardCloud):
        d_max = _max_distance(sh.max_distance, default_max_distance(drawable))
        instances = [(drawable, np.zeros(3), 1.0, 0.0, 1.0)]
    else:  # field_absorption_factors' default: 2 × the mean variant height
        default = float(np.mean([default_max_distance(v) for v in drawable.variants]))
        d_max = _max_distance(sh.max_distance, default)
        instances = [
            (drawable.variants[v], drawable.offsets[i].astype(np.float64),
             *_core.yaw_cos_sin(float(drawable.yaw[i])), float(drawable.alpha[i]))
            for i, v in enumerate(drawable.variant)
        ]  # fmt: skip
    # Points sorted by x: an instance's candidates are a slice, then a test on z.
    order = np.argsort(pts[:, 0], kind="stable")
    # float64 like the bounds searched for (otherwise each search casts the whole array)
    xs, zs = pts[order, 0].astype(np.float64), pts[order, 2]
    heights = (float(pts[:, 1].min()), float(pts[:, 1].max()))
    for cloud, offset, c, sn, alpha in instances:
        if cloud.n_boxes == 0 or alpha <= 0:
            continue
        # The instance's frame: local = R_y(−yaw)·(world − offset), the sun turned alike.
        corners = box_corners(*cloud.box_bounds())
        world = np.stack([c * corners[:, 0] + sn * corners[:, 2], corners[:, 1],
                          -sn * corners[:, 0] + c * corners[:, 2]], -1) + offset  # fmt: skip
        x0, x1, z0, z1 = footprint(world, s, heights)
        i0, i1 = np.searchsorted(xs, x0, "left"), np.searchsorted(xs, x1, "right")
        strip = zs[i0:i1]
        near = order[i0:i1][(strip >= z0) & (strip <= z1)]
        if near.size == 0:
            continue
        rel = pts[near].astype(np.float64) - offset
        local = np.stack([c * rel[:, 0] - sn * rel[:, 2], rel[:, 1],
                          sn * rel[:, 0] + c * rel[:, 2]], -1).astype(np.float32)  # fmt: skip
        sun_local = (c * s[0] - sn * s[2], s[1], sn * s[0] + c * s[2])
        owner = np.full(near.size, -1, np.int32)
        # A few hundred rays take less time than starting a thread.
        length = _core.caf_path_lengths(
            cloud.boxes, local, owner, sun_local, sh.overlap, True,
            threads if near.size >= 4096 else 1,
        )  # fmt: skip
        caf = _core.caf_values(length, d_max, sh.caf_curve)
        out[near] *= (1.0 - alpha * (1.0 - caf)).astype(np.float32)
    return out


def quad_corners(cloud: BillboardCloud, right: Sequence[float], up: Sequence[float]) -> np.ndarray:
    """Camera-facing quad corners ``(K, 4, 3)``: ``v0 = p − ½w·r′ − ½h·u′``, ``v1 = p + ½w·r′ −
    ½h·u′``, ``v2 = p + ½w·r′ + ½h·u′``, ``v3 = p − ½w·r′ + ½h·u′``, ``(r′, u′)`` the camera's
    right/up turned by each billboard's rotation ρ about the view axis, ``r′ = cos ρ·r + sin ρ·u``,
    ``u′ = −sin ρ·r + cos ρ·u`` (C++). Triangles ``(v0, v1, v2)``, ``(v0, v2, v3)``; with the
    sprite's `SpriteAtlas.uv_rects` ``(u0, v0, u1, v1)`` (v from the top row) the corners take
    ``(u0, v1), (u1, v1), (u1, v0), (u0, v0)``: the sprite's top row is at the quad's top."""
    r = check.vec3(right, "right")
    u = check.vec3(up, "up")
    return _core.billboard_corners(cloud.centres, cloud.sizes, cloud.rotation, r, u)


def _shade_args(
    cloud: BillboardCloud,
    sun: Sun,
    light: BillboardLight,
    shading: BillboardShading | None,
    sky: Any,
    extra: Sequence[tuple[Sun, BillboardLight]],
) -> tuple[list[Any], str]:
    """The core's shading arguments after (caf, ...): checks every (sun, light) pair."""
    if not isinstance(cloud, BillboardCloud):
        raise TypeError(f"cloud must be a BillboardCloud, got {type(cloud).__name__}")
    shading = shading if shading is not None else BillboardShading()
    if not isinstance(shading, BillboardShading):
        raise TypeError("shading must be a BillboardShading")
    cafs, dirs, rads = [], [], []
    for i, pair in enumerate([(sun, light), *extra]):
        s, lt = pair
        if not isinstance(s, Sun) or not isinstance(lt, BillboardLight):
            raise TypeError(f"light {i} must be a (cumuli.Sun, BillboardLight) pair")
        lt.check(cloud, s, shading.relight_tolerance)
        if lt.at != light.at:
            raise ValueError("every light's CAF must be computed at the same place (box/billboard)")
        cafs.append(lt.caf)
        dirs.append(s.direction)
        rads.append(s.radiance)
    levels = [list(lv) for lv in shading.height_levels] if shading.height_levels else []
    args = [
        np.stack(cafs).astype(np.float32),
        cloud.boxes,
        np.asarray(dirs, dtype=np.float32),
        np.asarray(rads, dtype=np.float32),
        core_struct(
            _core.ShadeParams,
            d_min=shading.d_min,
            d_max=shading.d_max,
            k_dir=shading.k_dir,
            directional=shading.directional,
            ambient=shading.ambient_colour(sky),
            k_amb=shading.k_amb,
            height_levels=levels,
        ),
    ]
    return args, light.at


def shade_points(
    cloud: BillboardCloud,
    points: Any,
    billboard: Any,
    sun: Sun,
    light: BillboardLight,
    shading: BillboardShading | None = None,
    sky: Any = None,
    extra: Sequence[tuple[Sun, BillboardLight]] = (),
    threads: int = 0,
) -> np.ndarray:
    """Colours ``(N, 3)`` at points lying on billboards ``billboard[i]`` (spec §4.2; C++):
    ``k_amb·ambient + H·Σ_ℓ CAF_ℓ·D_ℓ·radiance_ℓ`` over the sun and the ``extra`` lights (each
    with its own CAF record). The fragment-mode entry point (``shading="fragment"``)."""
    args, at = _shade_args(cloud, sun, light, shading, sky, extra)
    pts = check.points3(points, "points")
    bb = np.asarray(billboard)
    if bb.dtype.kind not in "iu" or bb.shape != (pts.shape[0],):
        raise ValueError(f"billboard must be an integer array of shape ({pts.shape[0]},)")
    if bb.size and (bb.min() < 0 or bb.max() >= cloud.n_billboards):
        raise ValueError(f"billboard must hold indices in [0, {cloud.n_billboards})")
    index = (cloud.box[bb] if at == "box" else bb).astype(np.int32)
    return _core.billboard_shade(pts, index, *args, check.threads(threads))


def vertex_colours(
    cloud: BillboardCloud,
    sun: Sun,
    light: BillboardLight,
    right: Sequence[float],
    up: Sequence[float],
    shading: BillboardShading | None = None,
    sky: Any = None,
    extra: Sequence[tuple[Sun, BillboardLight]] = (),
    threads: int = 0,
) -> np.ndarray:
    """Per-vertex colours ``(K, 4, 3)`` of the camera-facing quads (corners as `quad_corners`
    for the camera's ``right``/``up``): [TM]'s vertex shading, what the renderer interpolates
    over the triangles ``(v0, v1, v2)``, ``(v0, v2, v3)`` (C++ ``billboard_vertex_colours``)."""
    args, at = _shade_args(cloud, sun, light, shading, sky, extra)
    r = check.vec3(right, "right")
    u = check.vec3(up, "up")
    index = (cloud.box if at == "box" else np.arange(cloud.n_billboards)).astype(np.int32)
    colours, _ = _core.billboard_vertex_colours(
        cloud.centres, cloud.sizes, cloud.rotation, index, *args, r, u, check.threads(threads)
    )
    return colours


def light_grid_at_boxes(
    cloud: BillboardCloud,
    sun: Sun | Sequence[float],
    resolution: int = 24,
    density: float = 0.3,
    extinction: float = 0.3,
    step: float = 0.1,
) -> np.ndarray:
    """cumuli's NDT light grid (Jiménez de Parga 2018) of ``cloud.to_cloud()`` at constant
    ``density``, sampled trilinearly at the box centres: ``(M,)`` float32, the volumetric
    reference the CAF is compared with (beyond [TM])."""
    vol = cloud.to_cloud()
    grid = light_grid(
        vol, sun, None, resolution=resolution, step=step, extinction=extinction,
        density_override=density,
    )  # fmt: skip
    lo, hi = (np.asarray(v, dtype=np.float64) for v in grid.box)
    res = np.array(grid.shape[::-1], dtype=np.float64)  # (x, y, z)
    u = (cloud.box_centres.astype(np.float64) - lo) / (hi - lo) * res - 0.5
    u = np.clip(u, 0.0, res - 1.0)
    i0 = np.minimum(np.floor(u).astype(int), (res - 2).astype(int))
    f = u - i0
    out = np.zeros(u.shape[0])
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                w = (
                    (f[:, 0] if dx else 1 - f[:, 0])
                    * (f[:, 1] if dy else 1 - f[:, 1])
                    * (f[:, 2] if dz else 1 - f[:, 2])
                )
                out += w * grid[i0[:, 2] + dz, i0[:, 1] + dy, i0[:, 0] + dx]
    return out.astype(np.float32)


def rank_correlation(a: Any, b: Any) -> float:
    """Spearman's rank correlation of two equal-length sequences (average ranks for ties)."""
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1 or x.size < 2:
        raise ValueError("a and b must be 1-D of the same length >= 2")

    def ranks(v: np.ndarray) -> np.ndarray:
        order = np.argsort(v, kind="stable")
        r = np.empty(v.size)
        r[order] = np.arange(v.size, dtype=np.float64)
        _, inverse, counts = np.unique(v, return_inverse=True, return_counts=True)
        sums = np.bincount(inverse, weights=r)
        return sums[inverse] / counts[inverse]

    rx, ry = ranks(x), ranks(y)
    rx -= rx.mean()
    ry -= ry.mean()
    denom = math.sqrt(float((rx * rx).sum() * (ry * ry).sum()))
    return float((rx * ry).sum() / denom) if denom > 0 else 0.0
