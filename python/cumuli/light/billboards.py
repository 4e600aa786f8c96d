"""The light pass of billboard clouds and fields (Torchelsen & Musse 2005 §3.2; spec §4, §13.5).

`billboard_light` (the light pass the kinds ``"billboards"`` and ``"billboard_field"``
register, :mod:`cumuli.kinds.billboards`) computes the CAF of every box (or billboard) of a
`BillboardCloud` — `absorption_factors` — or of every instance of a `BillboardField` —
`field_absorption_factors` — for the scene's sun and each of ``scene.lights``, with the CAF
options of ``scene.billboard_shading``, and returns a `BillboardLighting` value. Nothing is
stored on the cloud.

Results are memoised by content (the cloud's boxes and billboards, a field's instances, the CAF
options): a memoised light is reused while every light has turned less than
``relight_tolerance`` degrees since it was computed ([TM]: the CAF is recomputed when the sun
moves; 0 recomputes for any change), so a camera path or a weather film does not repeat it.
Light the caller already has (``prepare_light(scene, lights=...)``) is used on the same terms.
"""

from __future__ import annotations

import hashlib
import math
import threading
import weakref
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from cumuli import _core
from cumuli.light.billboard_shading import BillboardShading
from cumuli.light.caf import (
    BillboardLight,
    FieldLight,
    absorption_factors,
    cloud_digest,
    field_absorption_factors,
)
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BillboardCloud
from cumuli.sky import Sun

#: Billboard lights kept by the memo (least recently used dropped first).
MEMO_SIZE = 64
_memo: OrderedDict[Any, BillboardLighting] = OrderedDict()
_lock = threading.Lock()
_digests: weakref.WeakKeyDictionary[Any, str] = weakref.WeakKeyDictionary()


@dataclass(frozen=True, eq=False)
class BillboardLighting:
    """The light of one billboard cloud or field in a scene.

    ``lights``: the scene's sun, then ``scene.lights`` (directions and radiances as the scene has
    them now: the directional term and the colour use these); ``records``: one CAF record per
    light (a `BillboardLight` for a cloud, a `FieldLight` for a field), each made for a direction
    within ``shading.relight_tolerance`` of its light; ``shading``: the scene's
    `BillboardShading`; ``ambient``: the ambient RGB it resolves to under the scene's sky;
    ``unshadowed``: the cloud's own light this one was made from by :meth:`through` (None: this
    is the cloud's own light).
    """

    lights: tuple[Sun, ...]
    records: tuple[Any, ...]
    shading: BillboardShading
    ambient: tuple[float, float, float]
    unshadowed: BillboardLighting | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if len(self.lights) != len(self.records) or not self.lights:
            raise ValueError("a BillboardLighting needs one CAF record per light (sun first)")
        kinds = {type(r) for r in self.records}
        if not (kinds <= {BillboardLight} or kinds <= {FieldLight}):
            raise TypeError("records must all be BillboardLight or all FieldLight")

    @property
    def caf(self) -> np.ndarray:
        """``(lights, columns)`` float32: each light's CAF values (a field's are flat)."""
        return np.stack([r.caf for r in self.records]).astype(np.float32, copy=False)

    def part(self, index: int) -> BillboardLighting:
        """The light of a field's instance ``index`` alone (`BillboardField.part`): each record
        cut to the instance's CAF block (the parts protocol, `cumuli.model.parts`)."""
        if not isinstance(self.records[0], FieldLight):
            raise TypeError("only the light of a BillboardField has parts")
        i = int(index)
        records = []
        for r in self.records:
            a, b = int(r.first[i]), int(r.first[i + 1])
            first = np.array([0, b - a], dtype=r.first.dtype)
            records.append(FieldLight(r.caf[a:b], r.length[a:b], first, r.sun, r.at, r.params))
        own = self.unshadowed.part(i) if self.unshadowed is not None else None
        return replace(self, records=tuple(records), unshadowed=own)

    def through(self, transmittance: np.ndarray) -> BillboardLighting:
        """The cloud's own light with CAF entry ``k`` of light ``ℓ`` times
        ``transmittance[k, ℓ]``: the light the scene's media let through to that box (or
        billboard) before the cloud's own absorption; ``(columns, lights)`` as `caf_points`."""
        own = self.unshadowed or self
        t = np.asarray(transmittance, dtype=np.float32)
        want = (own.records[0].caf.size, len(own.records))
        if t.shape != want:
            raise ValueError(f"transmittance must be {want}, got {t.shape}")
        records = tuple(
            replace(r, caf=(r.caf * t[:, i]).astype(np.float32)) for i, r in enumerate(own.records)
        )
        return replace(own, records=records, unshadowed=own)

    def same_as(self, other: Any, atol: float = 1e-6) -> bool:
        """Whether ``other`` shades exactly as this light: the same lights, ambient and
        shading, and CAFs within ``atol`` (a translated cloud's CAF, traced again, may differ in
        the last bit)."""
        if other is self:
            return True
        if not isinstance(other, BillboardLighting) or len(other.records) != len(self.records):
            return False
        if (other.lights, other.ambient, other.shading) != (self.lights, self.ambient,
                                                              self.shading):  # fmt: skip
            return False
        for a, b in zip(self.records, other.records, strict=True):
            if a is b:
                continue
            if a.caf.shape != b.caf.shape or a.at != b.at:
                return False
            if not np.array_equal(a.caf, b.caf) and np.abs(a.caf - b.caf).max() > atol:
                return False
        return True


def caf_points(drawable: BillboardCloud | BillboardField, at: str) -> np.ndarray:
    """``(columns, 3)`` float32: the world point of each CAF entry of ``drawable`` in the order of
    its light records — box centres (``at="box"``) or billboard centres (``"billboard"``); a
    field's instances one after another, each its variant's points turned by its yaw and moved
    by its offset."""
    name = "box_centres" if at == "box" else "centres"
    if isinstance(drawable, BillboardCloud):
        return np.ascontiguousarray(getattr(drawable, name), dtype=np.float32)
    if drawable.n == 0:
        return np.zeros((0, 3), np.float32)
    # Every (instance, point) pair at once: the variants' points side by side, each instance's
    # block taken from its variant's, then turned by its yaw and moved by its offset.
    local = [np.asarray(getattr(v, name), np.float64) for v in drawable.variants]
    sizes = np.array([p.shape[0] for p in local], np.int64)
    first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    count = sizes[drawable.variant]
    owner = np.repeat(np.arange(drawable.n), count)
    within = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    points = np.concatenate(local)[first[drawable.variant[owner]] + within]
    cos_sin = np.array([_core.yaw_cos_sin(float(y)) for y in drawable.yaw], np.float64)
    c, s = cos_sin[owner, 0], cos_sin[owner, 1]
    world = np.stack([c * points[:, 0] + s * points[:, 2], points[:, 1],
                      -s * points[:, 0] + c * points[:, 2]], axis=1)  # fmt: skip
    return (world + drawable.offsets.astype(np.float64)[owner]).astype(np.float32)


def _digest(drawable: Any) -> str:
    """Content hash of what the CAF depends on (cached per object: drawables are values). A
    field's instances are traced in their own frames, so their CAF does not depend on their
    offsets (a weather's drifting clouds keep theirs); with ``shadow_between_clouds`` the
    offsets join the key in `billboard_light`."""
    known = _digests.get(drawable)
    if known is not None:
        return known
    if isinstance(drawable, BillboardCloud):
        value = cloud_digest(drawable)
    else:
        h = hashlib.blake2b(digest_size=16)
        for v in drawable.variants:
            h.update(cloud_digest(v).encode())
        for a in (drawable.variant, drawable.yaw):
            h.update(np.ascontiguousarray(a).tobytes())
        value = h.hexdigest()
    _digests[drawable] = value
    return value


def _angle(a: tuple[float, float, float], b: tuple[float, float, float]) -> float:
    return math.degrees(math.acos(float(np.clip(np.dot(a, b), -1.0, 1.0))))


def _options(shading: BillboardShading, field: bool) -> tuple[Any, ...]:
    opts = (shading.max_distance, shading.overlap, shading.caf_curve, shading.include_self,
            shading.caf_at)  # fmt: skip
    return (*opts, shading.shadow_between_clouds) if field else opts


def _current(light: BillboardLighting, suns: tuple[Sun, ...], tolerance: float) -> bool:
    return len(light.records) == len(suns) and all(
        _angle(r.sun, s.direction) <= tolerance for r, s in zip(light.records, suns, strict=True)
    )


def _compute(drawable: Any, suns: tuple[Sun, ...], sh: BillboardShading, threads: int) -> tuple:
    kw = {"max_distance": sh.max_distance, "overlap": sh.overlap, "curve": sh.caf_curve,
          "include_self": sh.include_self, "at": sh.caf_at, "threads": threads}  # fmt: skip
    if isinstance(drawable, BillboardCloud):
        return tuple(absorption_factors(drawable, s, **kw) for s in suns)
    return tuple(
        field_absorption_factors(drawable, s, shadow_between_clouds=sh.shadow_between_clouds, **kw)
        for s in suns
    )


def _given(drawable: Any, given: Any, suns: tuple[Sun, ...], sh: BillboardShading) -> tuple:
    """The CAF records of light the caller passed in, checked (ValueError when stale)."""
    if isinstance(given, BillboardLighting):
        records = given.records
    elif isinstance(given, (BillboardLight, FieldLight)):
        records = (given,)
    else:
        raise TypeError(
            "the light of a billboard cloud must be a BillboardLighting (or a BillboardLight / "
            f"FieldLight for the sun alone), got {type(given).__name__}"
        )
    if len(records) != len(suns):
        raise ValueError(
            f"light holds {len(records)} CAF records, the scene has {len(suns)} lights"
        )
    field = isinstance(drawable, BillboardField)
    for r, s in zip(records, suns, strict=True):
        if field != isinstance(r, FieldLight):
            raise TypeError("a field's light is FieldLight records, a cloud's BillboardLight")
        if field:
            per = [v.n_boxes if r.at == "box" else v.n_billboards for v in drawable.variants]
            sizes = np.asarray(per, dtype=np.int64)[drawable.variant]
            if r.first.size != drawable.n + 1 or not np.array_equal(np.diff(r.first), sizes):
                raise ValueError("light was computed for another field (instances differ)")
        else:
            r.check(drawable)
        if r.at != sh.caf_at:
            raise ValueError(f"light was computed at {r.at!r}, the scene shades at {sh.caf_at!r}")
        if _angle(r.sun, s.direction) > sh.relight_tolerance:
            raise ValueError(
                f"light was computed for another sun direction (more than "
                f"relight_tolerance = {sh.relight_tolerance}° away): recompute it"
            )
    return records


def billboard_light(
    drawable: BillboardCloud | BillboardField, scene: Any, given: Any = None, threads: int = 0
) -> BillboardLighting:
    """The `BillboardLighting` of a billboard cloud or field in ``scene`` (see the module doc)."""
    if not isinstance(drawable, (BillboardCloud, BillboardField)):
        raise TypeError(
            f"expected a BillboardCloud or BillboardField, got {type(drawable).__name__}"
        )
    sh = scene.billboard_shading
    suns = (scene.sun, *scene.lights)
    ambient = sh.ambient_colour(scene.sky)
    if given is not None:
        records = _given(drawable, given, suns, sh)
        return BillboardLighting(suns, records, sh, ambient)
    field = isinstance(drawable, BillboardField)
    key: tuple[Any, ...] = ("billboards", _digest(drawable), _options(sh, field))
    if field and sh.shadow_between_clouds:
        key += (hashlib.blake2b(drawable.offsets.tobytes(), digest_size=16).hexdigest(),)
    with _lock:
        known = _memo.get(key)
        if known is not None and _current(known, suns, sh.relight_tolerance):
            _memo.move_to_end(key)
            return replace(known, lights=suns, shading=sh, ambient=ambient)
    light = BillboardLighting(suns, _compute(drawable, suns, sh, threads), sh, ambient)
    with _lock:
        _memo[key] = light
        _memo.move_to_end(key)
        while len(_memo) > MEMO_SIZE:
            _memo.popitem(last=False)
    return light


def clear_memo() -> None:
    """Forget every memoised billboard light."""
    with _lock:
        _memo.clear()
