"""Seed-and-box billboard clouds (Torchelsen & Musse 2005 §3).

A `SeedBox` (the paper's "seed"; ``seed=`` stays the RNG seed everywhere in cumuli) grows child
boxes over ``levels`` reproduction levels by eq. (1), ``B = S + l·ρ·λ·R̂``: ``R̂`` uniform on the
cap of half-angle ``θ_i/2`` about direction ``D_i``, ``ρ = ‖R‖`` uniform in (0, 1], ``λ`` the
reach (default the seed box's half-diagonal). Every box is filled with ``[b_min, b_max]``
camera-facing billboards at uniform positions. A `BasisModel` is a set of seed boxes plus the
billboard settings and the sprite atlas (both in `cumuli.model.seedbox`, re-exported here);
`seed_box_cloud` generates one `BillboardCloud` from it (C++,
``cpp/include/cumuli/model/seedbox.hpp``) and `cloud_variants` the paper's NM "models" of one
basis model, variant ``v`` seeded with ``Rng::stream(seed, basis·2¹⁶ + v)``.

A `BillboardCloud` is a value: read-only arrays (boxes ``(M, 2, 3)`` lo/hi with the seed boxes
first, their provenance, billboard centres ``(K, 3)``, sizes ``(K, 2)`` width/height, atlas
texture and owning box ``(K,)`` int32, rotation ``(K,)`` degrees about the view axis), the
global opacity, the atlas, and ``params``/``stats``. Transforms return new clouds. Light (CAF) is
computed by `cumuli.light.caf.absorption_factors` and returned, never stored on the cloud.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from cumuli import _core
from cumuli._util import budget
from cumuli._util import validate as check
from cumuli._util.atomic import atomic_target
from cumuli.io.jsonable import loads as json_loads
from cumuli.io.npz import (
    FileFormatError,
    check_path,
    check_readable,
    json_default,
    meta_array,
    meta_of,
    read_npz,
)
from cumuli.model.atlas import MAX_ATLAS_TEXELS, SpriteAtlas, recipe_cost, sprite_atlas
from cumuli.model.seedbox import (
    COUNT_PER,
    MAX_BILLBOARDS,
    MAX_BOXES,
    MAX_SEED_BOXES,
    BasisModel,
    SeedBox,
)


def _readonly(a: np.ndarray, dtype: Any, shape: tuple[int, ...], name: str) -> np.ndarray:
    arr = np.asarray(a)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be numeric, got dtype {arr.dtype}")
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    if arr.dtype.kind == "f" and np.dtype(dtype).kind == "i":
        if not np.isfinite(arr).all() or (arr != np.round(arr)).any():
            raise ValueError(f"{name} must hold integers")
    if np.dtype(dtype).kind == "i" and arr.size:
        info = np.iinfo(dtype)
        if arr.min() < info.min or arr.max() > info.max:
            raise ValueError(f"{name} holds integers outside [{info.min}, {info.max}]")
    out = np.array(arr, dtype=dtype, order="C")
    if out.dtype.kind == "f" and not np.isfinite(out).all():
        raise ValueError(f"{name} contains NaN or infinite values")
    out.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class BillboardCloud:
    """A billboard cloud: boxes and their billboards (spec §3 table); see the module docstring."""

    kind: ClassVar[str] = "billboards"

    boxes: np.ndarray
    box_level: np.ndarray
    box_seed: np.ndarray
    box_direction: np.ndarray
    centres: np.ndarray
    sizes: np.ndarray
    texture: np.ndarray
    box: np.ndarray
    rotation: np.ndarray
    opacity: float = 0.8
    atlas: SpriteAtlas | None = None
    params: dict[str, Any] = field(default_factory=dict)
    stats: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        b = np.asarray(self.boxes)
        if b.ndim != 3 or b.shape[1:] != (2, 3):
            raise ValueError(f"boxes must have shape (M, 2, 3), got {b.shape}")
        m = b.shape[0]
        if not 1 <= m <= MAX_BOXES:
            raise ValueError(f"boxes must hold 1 to {MAX_BOXES} boxes, got {m}")
        set_(self, "boxes", _readonly(b, np.float32, (m, 2, 3), "boxes"))
        if (np.abs(self.boxes) > check.MAX_COORD).any() or (
            self.boxes[:, 0] > self.boxes[:, 1]
        ).any():
            raise ValueError("boxes must have lo <= hi and coordinates within ±1e15")
        for name in ("box_level", "box_seed", "box_direction"):
            set_(self, name, _readonly(getattr(self, name), np.int32, (m,), name))
        c = np.asarray(self.centres)
        k = c.shape[0] if c.ndim == 2 else -1
        if c.ndim != 2 or c.shape[1] != 3 or k > MAX_BILLBOARDS:
            raise ValueError(f"centres must have shape (K, 3) with K <= {MAX_BILLBOARDS}")
        set_(self, "centres", _readonly(c, np.float32, (k, 3), "centres"))
        if k and np.abs(self.centres).max() > check.MAX_COORD:
            raise ValueError("centres must lie within ±1e15")
        set_(self, "sizes", _readonly(self.sizes, np.float32, (k, 2), "sizes"))
        if (self.sizes <= 0).any():
            raise ValueError("sizes must be positive")
        set_(self, "texture", _readonly(self.texture, np.int32, (k,), "texture"))
        set_(self, "box", _readonly(self.box, np.int32, (k,), "box"))
        set_(self, "rotation", _readonly(self.rotation, np.float32, (k,), "rotation"))
        if k and (self.box.min() < 0 or self.box.max() >= m):
            raise ValueError(f"box must hold indices in [0, {m})")
        set_(self, "opacity", check.real(self.opacity, "opacity", 0.0, 1.0, lo_open=True))
        atlas = self.atlas if self.atlas is not None else sprite_atlas("sunny")
        if not isinstance(atlas, SpriteAtlas):
            raise TypeError(f"atlas must be a SpriteAtlas, got {type(atlas).__name__}")
        set_(self, "atlas", atlas)
        if k and (self.texture.min() < 0 or self.texture.max() >= atlas.count):
            raise ValueError(f"texture must hold atlas indices in [0, {atlas.count})")
        for name in ("params", "stats"):
            value = getattr(self, name)
            if not isinstance(value, dict):
                raise TypeError(f"{name} must be a dict")
            try:
                set_(self, name, json.loads(json.dumps(value, default=json_default)))
            except (TypeError, ValueError) as exc:
                raise TypeError(f"{name} must be JSON-serialisable: {exc}") from None

    # --- sizes and geometry ---------------------------------------------------------------
    @property
    def n_boxes(self) -> int:
        """M, the number of boxes (seed boxes included)."""
        return int(self.boxes.shape[0])

    @property
    def n_billboards(self) -> int:
        """K, the number of billboards."""
        return int(self.centres.shape[0])

    def __len__(self) -> int:
        return self.n_billboards

    @property
    def box_centres(self) -> np.ndarray:
        """Box centres ``(M, 3)`` float32 (the CAF's sample points)."""
        return np.float32(0.5) * (self.boxes[:, 0] + self.boxes[:, 1])

    @property
    def box_half_sizes(self) -> np.ndarray:
        """Box half sizes ``(M, 3)`` float32."""
        return np.float32(0.5) * (self.boxes[:, 1] - self.boxes[:, 0])

    def box_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """AABB ``(lo, hi)`` of the boxes."""
        return self.boxes[:, 0].min(axis=0), self.boxes[:, 1].max(axis=0)

    @property
    def centre(self) -> np.ndarray:
        """``c_C``: the centre of the boxes' AABB (the directional term's cloud centre)."""
        lo, hi = self.box_bounds()
        return np.float32(0.5) * (lo + hi)

    def half_diagonals(self) -> np.ndarray:
        """``½·√(w² + h²)`` per billboard: the farthest a quad corner gets from its centre."""
        s = self.sizes.astype(np.float64)
        return (0.5 * np.hypot(s[:, 0], s[:, 1])).astype(np.float32)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World AABB ``(lo, hi)`` holding every billboard quad at any view orientation and
        rotation (centre ± half-diagonal per billboard); the boxes' AABB when K = 0."""
        if self.n_billboards == 0:
            return self.box_bounds()
        r = self.half_diagonals()[:, None]
        lo = (self.centres.astype(np.float64) - r).min(axis=0)
        hi = (self.centres.astype(np.float64) + r).max(axis=0)
        return np.nextafter(lo.astype(np.float32), -np.inf), np.nextafter(
            hi.astype(np.float32), np.inf
        )

    def sphere(self) -> tuple[np.ndarray, float]:
        """Bounding sphere ``(centre (3,), radius)`` of every quad at any orientation."""
        lo, hi = self.bounds()
        c = 0.5 * (lo.astype(np.float64) + hi.astype(np.float64))
        if self.n_billboards == 0:
            return c.astype(np.float32), float(0.5 * np.linalg.norm(hi - lo)) * (1 + 1e-6)
        d = np.linalg.norm(self.centres.astype(np.float64) - c, axis=1) + self.half_diagonals()
        return c.astype(np.float32), float(d.max()) * (1 + 1e-6)

    # --- transforms -------------------------------------------------------------------------
    def _arrays(self) -> dict[str, np.ndarray]:
        return {k: getattr(self, k) for k in ARRAY_FIELDS}

    def _derived(self, transform: dict[str, Any], **arrays: np.ndarray) -> BillboardCloud:
        params = json.loads(json.dumps(self.params, default=json_default))
        params.setdefault("transforms", []).append(transform)
        fields = self._arrays()
        fields.update(arrays)
        return BillboardCloud(
            **fields, opacity=self.opacity, atlas=self.atlas, params=params, stats=self.stats
        )

    def translated(self, offset: Sequence[float] | np.ndarray) -> BillboardCloud:
        """A copy moved by ``offset`` (world units)."""
        off = np.array(check.vec3(offset, "offset", bound=check.MAX_COORD))
        boxes = (self.boxes.astype(np.float64) + off).astype(np.float32)
        centres = (self.centres.astype(np.float64) + off).astype(np.float32)
        return self._derived({"translate": off.tolist()}, boxes=boxes, centres=centres)

    def rotated_y(self, degrees: float, about: Sequence[float] | None = None) -> BillboardCloud:
        """A copy turned by ``degrees`` about the vertical axis through ``about`` (default
        `centre`), ``x′ = c·x + s·z, z′ = −s·x + c·z`` (exact at multiples of 90°).

        Billboard centres turn exactly (billboards face the camera, so nothing else changes);
        boxes stay axis-aligned: each becomes the AABB of its turned box — exact at multiples of
        90°, larger in between (which changes the CAF there).
        """
        deg = check.real(degrees, "degrees")
        pivot = np.array(check.vec3(about, "about") if about is not None else self.centre, float)
        c, s = _core.yaw_cos_sin(deg)
        lo, hi = self.boxes[:, 0].astype(np.float64), self.boxes[:, 1].astype(np.float64)
        mid, half = rotate_y(0.5 * (lo + hi) - pivot, c, s) + pivot, 0.5 * (hi - lo)
        half = np.stack(
            [abs(c) * half[:, 0] + abs(s) * half[:, 2], half[:, 1],
             abs(s) * half[:, 0] + abs(c) * half[:, 2]], axis=1,
        )  # fmt: skip
        boxes = np.stack([mid - half, mid + half], axis=1).astype(np.float32)
        centres = (rotate_y(self.centres.astype(np.float64) - pivot, c, s) + pivot).astype(
            np.float32
        )
        return self._derived(
            {"rotate_y": deg, "about": pivot.tolist()}, boxes=boxes, centres=centres
        )

    def merged(self, *others: BillboardCloud) -> BillboardCloud:
        """This cloud and ``others`` as one (same atlas and opacity); seed boxes stay first."""
        parts = [self, *others]
        for i, p in enumerate(parts[1:]):
            if not isinstance(p, BillboardCloud):
                raise TypeError(f"others[{i}] must be a BillboardCloud, got {type(p).__name__}")
            if p.atlas != self.atlas or p.opacity != self.opacity:
                raise ValueError(f"others[{i}] has another atlas or opacity than this cloud")
        boxes = np.concatenate([p.boxes for p in parts])
        if boxes.shape[0] > MAX_BOXES:
            raise ValueError(f"merged cloud would hold {boxes.shape[0]} boxes (> {MAX_BOXES})")
        if sum(p.n_billboards for p in parts) > MAX_BILLBOARDS:
            raise ValueError(f"merged cloud would hold more than {MAX_BILLBOARDS} billboards")
        level = np.concatenate([p.box_level for p in parts])
        seed_shift = np.cumsum([0] + [int(p.box_seed.max()) + 1 for p in parts[:-1]])
        box_shift = np.cumsum([0] + [p.n_boxes for p in parts[:-1]])
        seed = np.concatenate([p.box_seed + k for p, k in zip(parts, seed_shift, strict=True)])
        owner = np.concatenate([p.box + k for p, k in zip(parts, box_shift, strict=True)])
        order = np.argsort(level != 0, kind="stable")  # seed boxes first, else input order
        new_index = np.empty_like(order)
        new_index[order] = np.arange(order.size)
        return BillboardCloud(
            boxes=boxes[order],
            box_level=level[order],
            box_seed=seed[order],
            box_direction=np.concatenate([p.box_direction for p in parts])[order],
            centres=np.concatenate([p.centres for p in parts]),
            sizes=np.concatenate([p.sizes for p in parts]),
            texture=np.concatenate([p.texture for p in parts]),
            box=new_index[owner],
            rotation=np.concatenate([p.rotation for p in parts]),
            opacity=self.opacity,
            atlas=self.atlas,
            params={"generator": "merge", "parts": [p.params for p in parts]},
            stats={"parts": [p.stats for p in parts]},
        )

    # --- conversions, files -------------------------------------------------------------------
    def to_cloud(
        self,
        kind: str = "ellipsoids",
        model: str = "spheroid",
        kappa: float = 0.5,
        phi: float = 0.6,
    ) -> Any:
        """A `cumuli.Cloud` with one axis-aligned ellipsoid per box (radii = half sizes), so the
        same seed-box shape renders with the volumetric marcher (beyond [TM])."""
        from cumuli.model.cloud import Cloud

        if kind != "ellipsoids":
            raise ValueError(f"kind must be 'ellipsoids', got {kind!r}")
        half = np.maximum(self.box_half_sizes, np.float32(1e-6))
        return Cloud(
            self.box_centres,
            half,
            model=model,
            kappa=kappa,
            phi=phi,
            params={"generator": "BillboardCloud.to_cloud", "source": self.params},
            stats={"boxes": self.n_boxes},
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-able (scene files): ``{"kind": "billboards", ...arrays as lists...}``."""
        return _cloud_to_dict(self)

    @classmethod
    def from_dict(cls, data: Any, where: str | None = None) -> BillboardCloud:
        """Inverse of :meth:`to_dict` (validated); errors name ``where`` (scene files)."""
        if where is None:
            return _cloud_from_dict(data)
        try:
            return _cloud_from_dict(data)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{where}: {exc}") from None

    def layer_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The compositor's box (float32): `bounds`, which holds every quad at any view
        orientation and rotation, so every pixel the cloud draws lies on a ray through it."""
        lo, hi = self.bounds()
        return lo.astype(np.float32), hi.astype(np.float32)

    def save(self, path: Any) -> Any:
        """Write ``.npz`` or ``.json`` atomically (a generated atlas is stored as its recipe, a
        user atlas as its image); returns the path. Read back with `load_billboards`."""
        return _save(self, path)

    def __repr__(self) -> str:
        lo, hi = self.box_bounds()
        return (
            f"BillboardCloud(boxes={self.n_boxes}, billboards={self.n_billboards}, "
            f"box_bounds=({lo.round(2).tolist()}, {hi.round(2).tolist()}))"
        )


ARRAY_FIELDS = (
    "boxes", "box_level", "box_seed", "box_direction", "centres", "sizes", "texture", "box",
    "rotation",
)  # fmt: skip


def rotate_y(points: np.ndarray, c: float, s: float) -> np.ndarray:
    """``(x, y, z) → (c·x + s·z, y, −s·x + c·z)`` in float64 (the field's instance rotation)."""
    p = np.asarray(points, dtype=np.float64)
    return np.stack([c * p[..., 0] + s * p[..., 2], p[..., 1], -s * p[..., 0] + c * p[..., 2]], -1)


def seed_box_cloud(model: BasisModel, seed: int = 0, threads: int = 0) -> BillboardCloud:
    """Generate one billboard cloud from a basis model (C++; spec §2.1 and §3).

    Boxes: the seed boxes in order, then each seed box's children in (seed, level, direction, m)
    order. Bit-identical for a ``seed`` whatever ``threads`` (0 = all cores). ``params`` holds
    the model (without the atlas) and the seed, so ``seed_box_cloud(BasisModel.from_dict(
    params["model"], atlas=cloud.atlas), params["seed"])`` rebuilds the cloud.
    """
    if not isinstance(model, BasisModel):
        raise TypeError(f"model must be a BasisModel, got {type(model).__name__}")
    seed = check.integer(seed, "seed", 0, 2**64 - 1)
    threads = check.threads(threads)
    r = _core.seed_box_cloud(
        [s.core_dict() for s in model.seeds],
        model.billboard_size,
        model.aspect_min,
        list(model.textures or ()),
        model.rotate,
        model.min_spacing,
        model.ellipsoid,
        seed,
        threads,
    )
    stats = r.pop("stats")
    return BillboardCloud(
        **r,
        opacity=model.opacity,
        atlas=model.atlas,
        params={"generator": "seed_box_cloud", "model": model.to_dict(atlas=False), "seed": seed},
        stats=dict(stats),
    )


def variant_seed(seed: int, basis: int, variant: int) -> int:
    """The generator seed of variant ``variant`` of basis model ``basis`` (spec §2.2)."""
    return int(
        _core.variant_seed(
            check.integer(seed, "seed", 0, 2**64 - 1),
            check.integer(basis, "basis", 0, 2**40),
            check.integer(variant, "variant", 0, 2**16 - 1),
        )
    )


def cloud_variants(
    model: BasisModel, n: int, seed: int = 0, basis: int = 0, threads: int = 0
) -> list[BillboardCloud]:
    """The NM models of one basis model ([TM] §3.1 diversity, Table 1): ``n`` clouds, variant
    ``v`` generated with seed ``variant_seed(seed, basis, v)`` (its ``params`` say so)."""
    n = check.integer(n, "n", 1, 2**16 - 1)
    seeds = [variant_seed(seed, basis, v) for v in range(n)]
    out = []
    for v, s in enumerate(seeds):
        cloud = seed_box_cloud(model, s, threads)
        params = dict(cloud.params, variant=v, basis=basis, sky_seed=seed)
        out.append(
            BillboardCloud(
                **cloud._arrays(),
                opacity=cloud.opacity,
                atlas=cloud.atlas,
                params=params,
                stats=cloud.stats,
            )  # fmt: skip
        )
    return out


def load_billboards(path: Any) -> BillboardCloud:
    """Read a cloud written by `BillboardCloud.save` (``.npz`` or ``.json``); ``ValueError``
    naming the file for a corrupt or foreign one, ``FileNotFoundError`` for a missing one."""
    return _load(path)


# --- files and dicts ---------------------------------------------------------------------
FILE_FORMAT = "cumuli.billboards"
FILE_VERSION = 1
_LIMITS = {
    "boxes": 6 * MAX_BOXES,
    "box_level": MAX_BOXES,
    "box_seed": MAX_BOXES,
    "box_direction": MAX_BOXES,
    "centres": 3 * MAX_BILLBOARDS,
    "sizes": 2 * MAX_BILLBOARDS,
    "texture": MAX_BILLBOARDS,
    "box": MAX_BILLBOARDS,
    "rotation": MAX_BILLBOARDS,
    "atlas_image": 4 * MAX_ATLAS_TEXELS,
    "meta": 1 << 26,
}


# --- dicts -------------------------------------------------------------------------------------
def _cloud_to_dict(cloud: BillboardCloud) -> dict[str, Any]:
    d: dict[str, Any] = {
        "kind": BillboardCloud.kind,
        "format": FILE_FORMAT,
        "version": FILE_VERSION,
    }
    for key in ARRAY_FIELDS:
        d[key] = getattr(cloud, key).tolist()
    d["opacity"] = cloud.opacity
    d["atlas"] = cloud.atlas.to_dict()  # type: ignore[union-attr]
    d["params"] = cloud.params
    d["stats"] = cloud.stats
    return d


#: The keys a billboard cloud's dict may hold (others are refused, as every kind's are).
DICT_KEYS = frozenset(
    ("kind", "format", "version", *ARRAY_FIELDS, "opacity", "atlas", "params", "stats")
)


def dict_cost(data: Any) -> list[tuple[Any, str, int]]:
    """The memory a billboard cloud's dict implies beyond the file's bytes (see
    :attr:`cumuli.registry.Kind.cost`): its atlas, when the dict holds a recipe."""
    return recipe_cost(data.get("atlas")) if isinstance(data, dict) else []


def _shaped(value: Any, key: str, width: tuple[int, ...], dtype: Any) -> np.ndarray:
    """``value`` as an array: real numbers only (integers beyond int64 or a ragged list are
    refused here; the constructor checks the integer fields' values and range)."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ValueError(f"{key} is not a numeric array ({exc})") from None
    if a.dtype.kind not in "fiu":
        raise ValueError(f"{key} is not an array of numbers (dtype {a.dtype})")
    if a.size == 0:  # [] has shape (0,): give it the row width
        a = a.reshape((0, *width))
    return a


def _cloud_from_dict(data: Any, atlas_image: np.ndarray | None = None) -> BillboardCloud:
    if not isinstance(data, dict):
        raise TypeError(f"billboard cloud must be an object, got {type(data).__name__}")
    if data.get("kind", BillboardCloud.kind) != BillboardCloud.kind:
        raise ValueError(f"kind must be {BillboardCloud.kind!r}, got {data.get('kind')!r}")
    if data.get("version", FILE_VERSION) != FILE_VERSION:
        raise ValueError(f"unsupported billboard cloud version {data.get('version')!r}")
    unknown = sorted(set(data) - DICT_KEYS)
    if unknown:
        raise ValueError(f"billboard cloud has unknown keys {unknown}")
    widths = {"boxes": (2, 3), "centres": (3,), "sizes": (2,)}
    arrays: dict[str, np.ndarray] = {}
    for key in ARRAY_FIELDS:
        if key not in data:
            raise ValueError(f"billboard cloud is missing {key!r}")
        value = data[key]
        dtype = (
            np.int32
            if key in ("box_level", "box_seed", "box_direction", "texture", "box")
            else np.float32
        )
        arrays[key] = _shaped(value, key, widths.get(key, ()), dtype)
    atlas_d = data.get("atlas")
    if atlas_d is None:
        raise ValueError("billboard cloud is missing 'atlas'")
    if atlas_image is not None:
        if not isinstance(atlas_d, dict) or "grid" not in atlas_d or "count" not in atlas_d:
            raise ValueError("atlas must have grid and count")
        grid = atlas_d["grid"]
        if not isinstance(grid, list) or len(grid) != 2:
            raise ValueError(f"atlas grid must be [nx, ny], got {grid!r}")
        atlas = SpriteAtlas(atlas_image, (grid[0], grid[1]), atlas_d["count"])
    else:
        atlas = SpriteAtlas.from_dict(atlas_d)
    return BillboardCloud(
        **arrays,
        opacity=data.get("opacity", 0.8),
        atlas=atlas,
        params=dict(data.get("params") or {}),
        stats=dict(data.get("stats") or {}),
    )


# --- files -------------------------------------------------------------------------------------
def _save(cloud: BillboardCloud, path: Any) -> Path:
    p = check_path(path, (".npz", ".json"))
    if not p.parent.is_dir():
        raise FileNotFoundError(f"folder of path does not exist: {str(p.parent)!r}")
    atlas = cloud.atlas
    assert atlas is not None
    with atomic_target(p) as tmp, open(tmp, "wb") as fh:
        if p.suffix.lower() == ".npz":
            meta = {
                "format": FILE_FORMAT,
                "version": FILE_VERSION,
                "opacity": cloud.opacity,
                "params": cloud.params,
                "stats": cloud.stats,
                "atlas": atlas.to_dict()
                if atlas.recipe is not None
                else {"grid": list(atlas.grid), "count": atlas.count},
            }
            arrays = {k: getattr(cloud, k) for k in ARRAY_FIELDS}
            arrays["meta"] = meta_array(meta)
            if atlas.recipe is None:
                arrays["atlas_image"] = atlas.image
            np.savez_compressed(fh, **arrays)
        else:
            text = json.dumps(_cloud_to_dict(cloud), default=json_default, allow_nan=False)
            fh.write(text.encode("utf-8"))
    return p


def _check_file_cost(p: Path, data: Any) -> None:
    """A file's atlas recipe costs at most what a scene file of its size may (the scene rule)."""
    size = p.stat().st_size
    budget.check_memory(
        f"billboard file {p.name!r} of {budget.amount(size)} (its atlas recipe)",
        sum(cost for _, _, cost in dict_cost(data)),
        budget.get_limits().scene_bytes(size),
        "cumuli.set_limits(scene_expansion=..., scene_allowance=...) or CUMULI_SCENE_ALLOWANCE",
    )


def _load(path: Any) -> BillboardCloud:
    p = check_path(path, (".npz", ".json"))
    check_readable(p, "billboard cloud")
    try:
        if p.suffix.lower() == ".npz":
            arrays = read_npz(p, _LIMITS, (*ARRAY_FIELDS, "meta"))
            meta = meta_of(arrays, p, FILE_FORMAT)
            if meta.get("version") != FILE_VERSION:
                raise FileFormatError(f"{p.name}: unsupported version {meta.get('version')!r}")
            _check_file_cost(p, meta)
            data = dict(meta)
            data.update(arrays)
            image = data.pop("atlas_image", None)
            return _cloud_from_dict(data, atlas_image=image)
        try:
            doc = json_loads(p.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
            raise FileFormatError(f"{p.name}: not readable JSON ({exc})") from None
        if not isinstance(doc, dict) or doc.get("format") != FILE_FORMAT:
            raise FileFormatError(f"{p.name}: not a {FILE_FORMAT} file (format tag missing)")
        _check_file_cost(p, doc)
        return _cloud_from_dict(doc)
    except (FileFormatError, budget.BudgetError):
        raise
    except (ValueError, TypeError, KeyError, IndexError) as exc:
        raise FileFormatError(f"{p.name}: invalid billboard cloud data: {exc}") from None


__all__ = [
    "COUNT_PER",
    "MAX_BILLBOARDS",
    "MAX_BOXES",
    "MAX_SEED_BOXES",
    "BasisModel",
    "BillboardCloud",
    "SeedBox",
    "cloud_variants",
    "load_billboards",
    "seed_box_cloud",
    "variant_seed",
]
