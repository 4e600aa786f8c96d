"""What an :class:`~cumuli.rendering.impostor_cache.ImpostorCache` keeps one impostor for, and
when two frames' versions of it draw the same image (Harris 2002 §3).

A **unit** is a whole drawable, or one part of a drawable that has parts (the optional
``impostor_parts()`` / ``part(i)`` protocol of :mod:`cumuli.model.parts`: a `BillboardField`'s
instances). Per unit the cache needs its bounding sphere, the point the direct drawer sorts it
by, its identity across frames (``key``: the drawable's index, or ``(index, part key)``), whether
its content is unchanged up to a translation (wind moves clouds without invalidating their
impostors) and whether its light is unchanged.

Pure translations are recognised per kind (its registered `translation`): a `ParticleCloud` or a
`BillboardCloud` compares its arrays relative to its bounding sphere; a 2018 cloud moved with
its noise (by its wind, or drifted) compares its primitives and density model (one translated
through the world's noise samples other noise: a change); a part compares its signature and
moves with its anchor; other kinds compare a digest of their scene-file dict.
"""

from __future__ import annotations

import hashlib
import json
import math
import weakref
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli import registry
from cumuli.light.prepare import LitScene
from cumuli.model.billboards import ARRAY_FIELDS, BillboardCloud
from cumuli.model.cloud import Cloud
from cumuli.model.particles import ParticleCloud

_digests: weakref.WeakKeyDictionary[Any, str] = weakref.WeakKeyDictionary()
_ZERO = np.zeros(3)


def drawable_sphere(drawable: Any) -> tuple[np.ndarray, float]:
    """A drawable's bounding sphere: its ``sphere`` (an attribute or a method) when it has one,
    else the sphere around its ``layer_box()``."""
    sphere = getattr(drawable, "sphere", None)
    if callable(sphere):
        sphere = sphere()
    if sphere is not None:
        c, r = sphere
        return np.asarray(c, np.float64), float(r)
    lo, hi = (np.asarray(v, np.float64) for v in drawable.layer_box())
    return (lo + hi) / 2, float(np.linalg.norm(hi - lo)) / 2


def _digest(drawable: Any) -> str:
    known = _digests.get(drawable)
    if known is None:
        text = json.dumps(drawable.to_dict(), sort_keys=True, default=repr)
        known = hashlib.blake2b(text.encode(), digest_size=16).hexdigest()
        _digests[drawable] = known
    return known


def _relative_points(old: Any, new: Any, name: str) -> np.ndarray | None:
    """The change of the bounding-sphere centre when ``getattr(·, name)`` (points) of ``new``
    equal those of ``old`` relative to it within 1e−5·R, else None."""
    (c0, r0), (c1, r1) = drawable_sphere(old), drawable_sphere(new)
    a = np.asarray(getattr(old, name), np.float64)
    b = np.asarray(getattr(new, name), np.float64)
    if a.shape != b.shape:
        return None
    if a.size and np.abs((a - c0) - (b - c1)).max() > 1e-5 * max(r0, r1):
        return None
    return c1 - c0


def particle_translation(old: ParticleCloud, new: ParticleCloud) -> np.ndarray | None:
    """``new − old`` when ``new`` is ``old`` translated (radii, τ, albedo equal), else None."""
    if new.n != old.n or not all(
        np.array_equal(getattr(new, a), getattr(old, a)) for a in ("radii", "tau", "albedo")
    ):
        return None
    return _relative_points(old, new, "centres")


def cloud_translation(old: Cloud, new: Cloud) -> np.ndarray | None:
    """``new − old`` when ``new`` is ``old`` moved with its noise (the same primitives and
    density model at another offset: its wind at another time, a drifted copy), else None."""
    if (new.model, new.kappa, new.phi) != (old.model, old.kappa, old.phi):
        return None
    if not all(
        np.array_equal(getattr(new, a), getattr(old, a)) for a in ("centres", "radii", "rotations")
    ):
        return None
    return np.subtract(new.offset, old.offset)


def billboard_translation(old: BillboardCloud, new: BillboardCloud) -> np.ndarray | None:
    """``new − old`` when ``new`` is ``old`` translated: the same billboards (sizes, atlas
    cells, rotations, owning boxes), boxes and opacity, at the same places relative to the
    bounding sphere; else None."""
    moved = ("boxes", "centres")
    for name in ARRAY_FIELDS:
        if name not in moved and not np.array_equal(getattr(new, name), getattr(old, name)):
            return None
    if new.opacity != old.opacity or new.atlas != old.atlas:
        return None
    offset = _relative_points(old, new, "centres")
    if offset is None:
        return None
    lo_old, lo_new = old.boxes.reshape(-1, 3), new.boxes.reshape(-1, 3)
    tol = 1e-5 * drawable_sphere(new)[1]
    if np.abs((lo_new.astype(np.float64) - lo_old) - offset).max() > tol:
        return None
    return offset


def same_content(old: Any, new: Any) -> tuple[bool, np.ndarray]:
    """Whether ``new`` is ``old`` up to a translation, and that translation (the change of the
    bounding-sphere centre): the kind's registered ``translation`` where it has one, else a
    digest of the scene-file dict."""
    if new is old:
        return True, _ZERO
    if type(new) is not type(old):
        return False, _ZERO
    test = registry.of(new).translation
    if test is not None:
        offset = test(old, new)
        return (False, _ZERO) if offset is None else (True, offset)
    return _digest(new) == _digest(old), _ZERO


def same_light(a: Any, b: Any) -> bool:
    """Whether two lights shade alike: a light value's own ``same_as`` when it has one (a
    `BillboardLighting`: lights, ambient, shading and CAFs), else equal arrays (``light`` and
    ``light_dirs`` of a `ParticleLight`, a grid's or volume's values)."""
    if a is b:
        return True
    if type(a) is not type(b):
        return False
    same_as = getattr(a, "same_as", None)
    if callable(same_as):
        return bool(same_as(b))
    arrays = [(getattr(a, n), getattr(b, n)) for n in ("light", "light_dirs") if hasattr(a, n)]
    if not arrays:
        arrays = [(a, b)]
    return all(
        np.shape(x) == np.shape(y) and np.array_equal(np.asarray(x), np.asarray(y))
        for x, y in arrays
    )


@dataclass(eq=False)
class Unit:
    """One impostor's subject this frame: drawable ``k`` of the scene (``part`` None) or its
    part ``part``; ``key`` its identity across frames; ``centre``/``radius`` its bounding
    sphere; ``order`` the point it is sorted by; ``anchor`` the point it moves with and
    ``signature`` its content up to translation (parts only)."""

    key: Any
    kind: str
    k: int
    part: int | None
    centre: np.ndarray
    radius: float
    order: np.ndarray
    anchor: np.ndarray | None = None
    signature: Any = None

    def drawable(self, lit: LitScene) -> Any:
        """What this unit draws, alone (a part as a drawable of its own)."""
        d = lit.scene.clouds[self.k]
        return d if self.part is None else d.part(self.part)

    def light(self, lit: LitScene) -> Any:
        """Its light (a part's: ``light.part(i)``)."""
        light = lit.lights[self.k]
        return light if self.part is None else light.part(self.part)

    def lit(self, lit: LitScene) -> tuple[LitScene, int]:
        """``(lit scene, index)`` its drawer draws it from: ``(lit, k)`` for a whole drawable,
        else a scene holding the part alone (same sun, lights, sky, settings and solids)."""
        if self.part is None:
            return lit, self.k
        scene = lit.scene.replace(clouds=(self.drawable(lit),))
        return LitScene(scene, (self.light(lit),)), 0


def units(lit: LitScene, k: int) -> list[Unit]:
    """The units of drawable ``k``: itself, or one per part (``impostor_parts()``)."""
    drawable = lit.scene.clouds[k]
    kind = drawable.kind
    parts_of = getattr(drawable, "impostor_parts", None)
    if parts_of is None:
        centre, radius = drawable_sphere(drawable)
        order = registry.of(drawable).order_point
        point = centre if order is None else order(drawable)
        return [Unit(k, kind, k, None, centre, radius, point)]
    parts = parts_of()
    return [
        Unit(
            (k, key),
            kind,
            k,
            i,
            parts.centres[i],
            radius,
            parts.order[i],
            parts.anchors[i],
            parts.signatures[i],
        )  # fmt: skip
        for i, (key, radius) in enumerate(
            zip(parts.keys.tolist(), parts.radii.tolist(), strict=True)
        )  # fmt: skip
    ]


def unit_content(entry: Any, unit: Unit, lit: LitScene) -> tuple[bool, np.ndarray]:
    """Whether ``unit`` draws what ``entry`` (an impostor made earlier) shows, up to the
    returned translation."""
    if unit.part is None:
        return same_content(entry.drawable, lit.scene.clouds[unit.k])
    if entry.signature != unit.signature or entry.anchor0 is None:
        return False, _ZERO
    return True, np.asarray(unit.anchor, np.float64) - entry.anchor0


def distance(point: np.ndarray, eye: tuple[float, float, float]) -> float:
    return math.dist(point, eye)
