"""`BillboardField`: NC instances of NM billboard-cloud variants (Torchelsen & Musse 2005 §3.1, §5).

[TM] replicates a few generated cloud models many times ("10 cloud models … replicated 200 times");
a field holds the variants' geometry once and per instance a variant id, a source state id (the
weather's sky state), an offset, a yaw about +y (beyond [TM]) and an alpha (fades). Instance ``i``
places variant ``variant[i]`` at ``world = R_y(yaw[i])·local + offsets[i]`` with
``R_y = [[c, 0, s], [0, 1, 0], [−s, 0, c]]`` (``c, s`` exact at multiples of 90°); billboards keep
their size and view-axis rotation (they face the camera). Renderers draw instance by instance
(GPU instancing: one vertex buffer per variant, per-instance offset/yaw/alpha).
"""

from __future__ import annotations

import hashlib
import weakref
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from cumuli import _core
from cumuli._util import budget
from cumuli._util import validate as check
from cumuli.model.billboards import ARRAY_FIELDS, BillboardCloud, rotate_y
from cumuli.model.parts import DrawableParts

#: Most instances a field holds (spec §10: ≤ 2²⁰ instances per layer).
MAX_INSTANCES = 1 << 20
#: Bytes one drawn billboard of a field costs a renderer or its light pass: four vertices of
#: position, texture coordinate and colour, its sort key, index and CAF entries.
BYTES_PER_BILLBOARD = 192
_variant_digests: weakref.WeakKeyDictionary[BillboardCloud, str] = weakref.WeakKeyDictionary()
_variant_spheres: weakref.WeakKeyDictionary[BillboardCloud, tuple[np.ndarray, float]] = (
    weakref.WeakKeyDictionary()
)


_variant_points: weakref.WeakKeyDictionary[BillboardCloud, tuple[np.ndarray, np.ndarray]] = (
    weakref.WeakKeyDictionary()
)


def variant_points(cloud: BillboardCloud) -> tuple[np.ndarray, np.ndarray]:
    """What bounds a variant's quads at any orientation (cached, float64): its billboard centres
    and half-diagonals, or its boxes' centres and half-diagonals when it has no billboards."""
    known = _variant_points.get(cloud)
    if known is None:
        if cloud.n_billboards:
            known = (cloud.centres.astype(np.float64), cloud.half_diagonals().astype(np.float64))
        else:
            known = (
                cloud.box_centres.astype(np.float64),
                np.linalg.norm(cloud.box_half_sizes.astype(np.float64), axis=1),
            )
        _variant_points[cloud] = known
    return known


def variant_sphere(cloud: BillboardCloud) -> tuple[np.ndarray, float]:
    """`BillboardCloud.sphere` of a variant, cached (clouds are values)."""
    known = _variant_spheres.get(cloud)
    if known is None:
        known = cloud.sphere()
        _variant_spheres[cloud] = known
    return known


def variant_digest(cloud: BillboardCloud) -> str:
    """A hash of what a variant draws in its own frame (arrays and opacity; cached)."""
    known = _variant_digests.get(cloud)
    if known is None:
        h = hashlib.blake2b(digest_size=16)
        for name in ARRAY_FIELDS:
            h.update(np.ascontiguousarray(getattr(cloud, name)).tobytes())
        h.update(np.float64(cloud.opacity).tobytes())
        known = h.hexdigest()
        _variant_digests[cloud] = known
    return known


def _column(value: Any, n: int, name: str, dtype: Any, default: float) -> np.ndarray:
    if value is None:
        out = np.full(n, default, dtype=dtype)
    else:
        a = np.asarray(value)
        if a.dtype.kind == "O":  # integers beyond int64, or mixed objects
            raise ValueError(f"{name} must hold numbers within the int64/float64 range")
        if a.dtype.kind not in "fiu":
            raise TypeError(f"{name} must be numeric, got dtype {a.dtype}")
        if a.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},), got {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"{name} contains NaN or infinite values")
        if np.dtype(dtype).kind == "i" and (a != np.round(a)).any():
            raise ValueError(f"{name} must hold integers")
        if np.dtype(dtype).kind == "i" and a.size:
            info = np.iinfo(dtype)
            if a.min() < info.min or a.max() > info.max:
                raise ValueError(f"{name} holds integers outside [{info.min}, {info.max}]")
        out = np.array(a, dtype=dtype)
    out.setflags(write=False)
    return out


#: The keys a billboard field's dict may hold (others are refused, as every kind's are).
DICT_KEYS = ("kind", "variants", "offsets", "variant", "yaw", "alpha", "state", "ids", "params")


def dict_cost(data: Any) -> list[tuple[Any, str, int]]:
    """The memory a field's dict implies (see :attr:`cumuli.registry.Kind.cost`): its variants'
    atlases and its drawn billboards (instances × the billboards of their variant), estimated
    from the lists' lengths before anything is built."""
    from cumuli.model.billboards import dict_cost as cloud_cost

    if not isinstance(data, dict) or not isinstance(data.get("variants"), list):
        return []
    items: list[tuple[Any, str, int]] = []
    sizes = []
    for v in data["variants"]:
        items += cloud_cost(v)
        tex = v.get("texture") if isinstance(v, dict) else None
        sizes.append(len(tex) if isinstance(tex, list) else 0)
    offsets, variant = data.get("offsets"), data.get("variant")
    n = len(offsets) if isinstance(offsets, list) else 0
    if sizes and isinstance(variant, list) and len(variant) == n:
        drawn = sum(sizes[v] for v in variant if isinstance(v, int) and 0 <= v < len(sizes))
    else:  # the default: instances take the variants in turn
        drawn = n * max(sizes, default=0)
    what = f"a billboard field of {n} instances ({drawn} billboards)"
    return [*items, ((id(data), "field"), what, drawn * BYTES_PER_BILLBOARD)]


class BillboardField:
    """Instances of billboard-cloud variants; see the module docstring.

    Parameters
    ----------
    variants:
        The NM (or, in a weather layer, all states' NBM·NM) `BillboardCloud` variants.
    offsets:
        ``(NC, 3)`` instance positions (world).
    variant:
        ``(NC,)`` variant ids (default ``i mod NM``).
    yaw:
        ``(NC,)`` degrees about +y (default 0).
    alpha:
        ``(NC,)`` in [0, 1] multiplying the variant's opacity (default 1).
    state:
        ``(NC,)`` source sky-state ids (default 0).
    ids:
        ``(NC,)`` distinct instance ids, an instance's identity across frames (a `Weather`'s;
        default ``0 … NC − 1``): impostors are kept per instance id.
    """

    kind: ClassVar[str] = "billboard_field"

    def __init__(
        self,
        variants: Sequence[BillboardCloud],
        offsets: Any,
        variant: Any = None,
        yaw: Any = None,
        alpha: Any = None,
        state: Any = None,
        params: dict[str, Any] | None = None,
        ids: Any = None,
    ) -> None:
        if isinstance(variants, BillboardCloud) or not isinstance(variants, (list, tuple)):
            raise TypeError("variants must be a sequence of BillboardCloud")
        if not 1 <= len(variants) <= 1 << 24:
            raise ValueError("variants must hold at least one cloud")
        for i, v in enumerate(variants):
            if not isinstance(v, BillboardCloud):
                raise TypeError(f"variants[{i}] must be a BillboardCloud, got {type(v).__name__}")
        off = check.points3(offsets, "offsets", bound=check.MAX_COORD)
        n = off.shape[0]
        if n > MAX_INSTANCES:
            raise ValueError(f"a field holds at most {MAX_INSTANCES} instances, got {n}")
        nv = len(variants)
        var = (
            _column(np.arange(n) % nv, n, "variant", np.int32, 0)
            if variant is None
            else _column(variant, n, "variant", np.int32, 0)
        )
        if n and (var.min() < 0 or var.max() >= nv):
            raise ValueError(f"variant must hold ids in [0, {nv})")
        counts = np.array([v.n_billboards for v in variants], np.int64)
        drawn = int(counts[var].sum()) if n else 0
        budget.check_memory(
            f"a billboard field of {n} instances ({drawn} billboards)", drawn * BYTES_PER_BILLBOARD
        )
        yaw_a = _column(yaw, n, "yaw", np.float32, 0.0)
        alpha_a = _column(alpha, n, "alpha", np.float32, 1.0)
        if n and (alpha_a.min() < 0 or alpha_a.max() > 1):
            raise ValueError("alpha must be in [0, 1]")
        state_a = _column(state, n, "state", np.int32, 0)
        if n and state_a.min() < 0:
            raise ValueError("state must be >= 0")
        if ids is None:
            ids_a = np.arange(n, dtype=np.int64)
            ids_a.setflags(write=False)
        else:
            raw = np.asarray(ids)
            if raw.dtype.kind in "iu" and raw.size and (raw.max() >= 1 << 63):
                raise ValueError("ids must be integers in [0, 2**63)")
            ids_a = _column(ids, n, "ids", np.int64, 0)
            if n and (ids_a.min() < 0 or np.unique(ids_a).size != n):
                raise ValueError("ids must be distinct integers >= 0")
        off.setflags(write=False)
        self.variants: tuple[BillboardCloud, ...] = tuple(variants)
        self.offsets = off
        self.variant = var
        self.yaw = yaw_a
        self.alpha = alpha_a
        self.state = state_a
        self.ids = ids_a
        self.params: dict[str, Any] = dict(params or {})
        self._parts: DrawableParts | None = None
        self._box: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def n(self) -> int:
        """NC, the number of instances."""
        return int(self.offsets.shape[0])

    def __len__(self) -> int:
        return self.n

    def _cos_sin(self) -> tuple[np.ndarray, np.ndarray]:
        cs = np.array([_core.yaw_cos_sin(float(a)) for a in self.yaw], dtype=np.float64)
        cs = cs.reshape(-1, 2)
        return cs[:, 0], cs[:, 1]

    def instance_bounds(self) -> np.ndarray:
        """``(NC, 2, 3)`` world AABB of each instance's quads at any view orientation (its
        billboard centres turned and moved, ± their half-diagonals; its boxes' centres ± their
        half-diagonals when the variant has no billboards)."""
        out = np.empty((self.n, 2, 3), dtype=np.float32)
        if self.n == 0:
            return out
        c, s = self._cos_sin()
        used = np.zeros(len(self.variants), bool)
        used[self.variant] = True
        pts, rad = [], []
        for v, cloud in enumerate(self.variants):
            p, r = variant_points(cloud) if used[v] else (np.zeros((0, 3)), np.zeros(0))
            pts.append(p)
            rad.append(r)
        sizes = np.array([p.shape[0] for p in pts], np.int64)
        first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        points, radii = np.concatenate(pts), np.concatenate(rad)
        count = sizes[self.variant]
        offsets = self.offsets.astype(np.float64)
        # All (instance, point) pairs at once, in chunks of about 10⁶ points.
        ends = np.cumsum(count)
        begin = 0
        while begin < self.n:
            base = ends[begin - 1] if begin else 0
            stop = int(np.searchsorted(ends, base + (1 << 20), side="right"))
            stop = max(stop, begin + 1)
            ii = np.arange(begin, stop)
            k = count[ii]
            rep = np.repeat(ii, k)
            local = np.arange(int(k.sum())) - np.repeat(np.cumsum(k) - k, k)
            p = points[first[self.variant[rep]] + local]
            r = radii[first[self.variant[rep]] + local][:, None]
            ci, si = c[rep], s[rep]
            x = ci * p[:, 0] + si * p[:, 2]
            z = -si * p[:, 0] + ci * p[:, 2]
            w = np.stack([x, p[:, 1], z], axis=-1) + offsets[rep]
            cuts = np.cumsum(k) - k
            lo = np.minimum.reduceat(w - r, cuts, axis=0).astype(np.float32)
            hi = np.maximum.reduceat(w + r, cuts, axis=0).astype(np.float32)
            out[ii, 0] = np.nextafter(lo, -np.inf)
            out[ii, 1] = np.nextafter(hi, np.inf)
            begin = stop
        return out

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World AABB ``(lo, hi)`` of every instance's quads; raises on an empty field."""
        if self.n == 0:
            raise ValueError("an empty field has no bounds")
        b = self.instance_bounds()
        return b[:, 0].min(axis=0), b[:, 1].max(axis=0)

    def layer_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The compositor's box (float32): `bounds` (every instance's quads at any view
        orientation); a point at the origin for an empty field (which draws nothing)."""
        if self.n == 0:
            return np.zeros(3, np.float32), np.zeros(3, np.float32)
        if self._box is None:  # fields are values: computed once
            lo, hi = self.bounds()
            self._box = (lo.astype(np.float32), hi.astype(np.float32))
        return self._box[0].copy(), self._box[1].copy()

    def instance_spheres(self) -> tuple[np.ndarray, np.ndarray]:
        """Per instance, the bounding sphere of its quads at any orientation: ``centres (NC, 3)``
        float64 (the variant's `BillboardCloud.sphere` centre turned by yaw and moved by the
        offset) and ``radii (NC,)``."""
        sph = [variant_sphere(v) for v in self.variants]
        local = np.array([c for c, _ in sph], np.float64)[self.variant].reshape(-1, 3)
        radii = np.array([r for _, r in sph], np.float64)[self.variant]
        return self._to_world(local), radii

    def _to_world(self, local: np.ndarray) -> np.ndarray:
        c, s = self._cos_sin()
        world = np.stack([c * local[:, 0] + s * local[:, 2], local[:, 1],
                          -s * local[:, 0] + c * local[:, 2]], axis=1)  # fmt: skip
        return world.reshape(-1, 3) + self.offsets.astype(np.float64)

    def impostor_parts(self) -> DrawableParts:
        """The instances as independent parts (`cumuli.model.parts`): keyed by `ids`, bounded by
        `instance_spheres`, sorted by their variant's box centre ``c_C`` (as the drawers sort
        them), moved by their offset, and drawing the same image when variant, yaw and alpha
        agree. Made once per field (fields are values)."""
        if self._parts is None:
            centres, radii = self.instance_spheres()
            box_centres = np.array([v.centre for v in self.variants], np.float64)
            order = self._to_world(box_centres[self.variant].reshape(-1, 3))
            digests = [(variant_digest(v), v.atlas) for v in self.variants]
            signatures = tuple(
                (*digests[v], float(y), float(a))
                for v, y, a in zip(self.variant.tolist(), self.yaw.tolist(),
                                   self.alpha.tolist(), strict=True)
            )  # fmt: skip
            self._parts = DrawableParts(self.ids, centres, radii, order,
                                        self.offsets.astype(np.float64), signatures)  # fmt: skip
        return self._parts

    def part(self, index: int) -> BillboardField:
        """Instance ``index`` alone: a one-instance field over the same variants (same
        variant, offset, yaw, alpha, state and id), drawn — and lit by the light pass, whose
        default CAF distance depends on the variants — exactly as the instance is here."""
        i = check.integer(index, "index", 0, self.n - 1)
        return BillboardField(
            self.variants, self.offsets[i : i + 1], variant=self.variant[i : i + 1],
            yaw=self.yaw[i : i + 1],
            alpha=self.alpha[i : i + 1], state=self.state[i : i + 1], ids=self.ids[i : i + 1],
            params=self.params,
        )  # fmt: skip

    def world_billboards(self, index: int) -> dict[str, np.ndarray]:
        """Instance ``index``'s billboards in world space: ``centres (K, 3)``, ``sizes``,
        ``texture``, ``rotation``, ``box`` (the variant's arrays) and ``alpha`` (scalar array)."""
        i = check.integer(index, "index", 0, self.n - 1)
        cloud = self.variants[int(self.variant[i])]
        c, s = _core.yaw_cos_sin(float(self.yaw[i]))
        centres = rotate_y(cloud.centres, c, s) + self.offsets[i].astype(np.float64)
        return {
            "centres": centres.astype(np.float32),
            "sizes": cloud.sizes,
            "texture": cloud.texture,
            "rotation": cloud.rotation,
            "box": cloud.box,
            "alpha": np.float32(self.alpha[i] * cloud.opacity),
        }

    def to_dict(self) -> dict[str, Any]:
        """JSON-able (scene files): variants as their dicts, instance arrays as lists."""
        return {
            "kind": self.kind,
            "variants": [v.to_dict() for v in self.variants],
            "offsets": self.offsets.tolist(),
            "variant": self.variant.tolist(),
            "yaw": self.yaw.tolist(),
            "alpha": self.alpha.tolist(),
            "state": self.state.tolist(),
            "ids": self.ids.tolist(),
            "params": self.params,
        }

    @classmethod
    def from_dict(cls, data: Any, where: str | None = None) -> BillboardField:
        """Inverse of :meth:`to_dict` (validated); errors name ``where`` (scene files)."""
        if where is None:
            return cls._from_dict(data)
        try:
            return cls._from_dict(data)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{where}: {exc}") from None

    @classmethod
    def _from_dict(cls, data: Any) -> BillboardField:
        if not isinstance(data, dict):
            raise TypeError(f"billboard field must be an object, got {type(data).__name__}")
        if data.get("kind", cls.kind) != cls.kind:
            raise ValueError(f"kind must be {cls.kind!r}, got {data.get('kind')!r}")
        unknown = sorted(set(data) - set(DICT_KEYS))
        if unknown:
            raise ValueError(f"billboard field has unknown keys {unknown}")
        for key in ("variants", "offsets"):
            if key not in data:
                raise ValueError(f"billboard field is missing {key!r}")
        if not isinstance(data["variants"], list):
            raise ValueError("variants must be a list")
        offsets = np.asarray(data["offsets"], dtype=np.float32)
        if offsets.size == 0:
            offsets = offsets.reshape(0, 3)
        return cls(
            [BillboardCloud.from_dict(v) for v in data["variants"]],
            offsets,
            variant=data.get("variant"),
            yaw=data.get("yaw"),
            alpha=data.get("alpha"),
            state=data.get("state"),
            params=data.get("params"),
            ids=data.get("ids"),
        )

    def __repr__(self) -> str:
        return f"BillboardField(instances={self.n}, variants={len(self.variants)})"
