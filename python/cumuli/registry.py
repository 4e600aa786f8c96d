"""The kind registry: everything the stages ask of a kind of drawable, declared once per kind.

A kind of cloud (a 2018 `Cloud`, a `VolumeCloud`, a `ParticleCloud`, ...) is one :class:`Kind`
record, made and registered by its registration module under ``cumuli/kinds/`` — the only module
that sees all of the kind's stages at once. Stage code never asks "which class is this?": it looks
the drawable's kind up here (:func:`of`) and calls what the record holds. The records are plain
values of functions, like Mitsuba 3's plugins (one file and one registration per medium): Python
needs no plugin loader, and a frozen dataclass says in one screen what a new kind must provide.

This module imports nothing from the stages, so every stage may read it; the records are filled
when ``cumuli`` is imported (``cumuli/__init__.py`` imports ``cumuli.kinds``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

__all__ = ["Caster", "Kind", "Medium", "register", "of", "get", "kinds", "model_classes"]


@dataclass(frozen=True)
class Medium:
    """How a kind takes part in the extinction medium the C++ core marches (shadows on the
    ground and on other drawables, the physical mode's light).

    ``core_args(drawable, settings) -> (clouds, volumes)``: its entries of the core's medium lists
    (a 2018 cloud's primitives and extinction scale, or a lattice ``(density, lo, hi, σt)``);
    ``extinction(drawable, noise, settings, resolution, supersample, threads)``: its extinction
    field σt as an :class:`cumuli.light.medium.ExtinctionField` over its ``layer_box()``
    (``resolution=None``: its own lattice, where it has one); ``own_lattice(drawable)``: the
    ``(x, y, z)`` shape of its own lattice, or None (the physical pass keeps a lattice no finer
    than its own resolution); ``light_box(drawable)``: the box of its light array where the light
    value does not carry one (a volume's), else None; ``step(drawable)``: the step its medium is
    marched at by shadow and light rays, where it is at a scale of its own (None: the settings'
    ``light_step``); ``moved(drawable) -> (still, offset)``: the drawable is ``still`` moved by
    ``offset`` (world units) with its noise, the same medium elsewhere, so its own light is
    ``still``'s moved (a 2018 cloud the wind carries; a volume, whose light does not depend on
    where it stands, is its copy at the origin moved; the default: itself, not moved)."""

    core_args: Callable[[Any, Any], tuple[list, list]]
    extinction: Callable[..., Any]
    own_lattice: Callable[[Any], tuple[int, int, int] | None] = lambda d: None
    light_box: Callable[[Any], Any] = lambda d: None
    step: Callable[[Any], float] | None = None
    moved: Callable[[Any], tuple[Any, tuple[float, float, float]]] = lambda d: (d, (0.0, 0.0, 0.0))


@dataclass(frozen=True)
class Caster:
    """How a kind with its own light model and no extinction field (Harris's particles,
    Torchelsen's billboards) shades the others and receives their light.

    ``sphere(drawable) -> (centre, radius)``: outside it the kind's shadow is exactly 1, and its
    receiving points lie inside; ``transmittance(drawable, sun, points, scene, light, threads)``:
    the ``(N,)`` transmittance of ``sun``'s light through it at world points (``light``: its own
    light, which may lend buffers, or None); ``receiver(drawable, light)``: None when ``light``
    cannot be shaded, else ``(points, place)`` — a function making the ``(M, 3)`` points where its
    light is received (in the order of the light's rows) and a hashable key of where they are;
    the light is then shaded with ``light.through(t)``."""

    sphere: Callable[[Any], tuple[Any, float]]
    transmittance: Callable[..., Any]
    receiver: Callable[[Any, Any], tuple[Callable[[], Any], Any] | None]


@dataclass(frozen=True)
class Kind:
    """One kind of drawable, as every stage sees it.

    **Model**: ``name`` (its tag in scene files, ``model.kind``), ``model`` (the value class: it
    has ``bounds()``, ``layer_box()``, ``to_dict()`` and ``from_dict(data, where)``),
    ``paper`` (where its technique comes from) and ``modules``: its own modules (dotted names
    under ``cumuli``), the only ones that may test ``isinstance`` against its class;
    ``cost(data)``: the memory that building one from its scene-file dict ``data`` implies beyond
    the bytes the file holds, as ``(key, what, bytes)`` items (items of one key are counted once:
    a shared cache), estimated before anything is built (None: nothing beyond the file).

    **Light**: ``light(drawable, scene, given, threads)`` its light pass in the paper mode;
    ``physical_light`` the same in the physical mode (None: ``light`` in both modes, as
    particles and billboards keep their own light models); ``light_batch(drawables, scene,
    given, threads)`` the pass of all the scene's drawables of the kind at once (optional);
    ``digest(drawable)`` what its light depends on, as a hashable memo key (None: the object's
    identity) and ``shadow_digest`` what its shadow depends on (None: ``digest``); ``medium``
    or ``caster``: how it shades and is shaded (see :class:`Medium`, :class:`Caster`; a kind
    with neither casts no shadow); ``forget()``: clears its own light memo (optional).

    **Animation**: ``advance(drawable, seconds)``: the drawable that much later (a deck's wind
    moves its weather map); None: it does not change by itself.

    **Rendering**: ``gl_drawer`` (a class ``Drawer(gl, tiles)``) and ``cpu_drawer`` (its C++
    twin, a function), ``groups`` (one pass may draw several drawables of the kind),
    ``clips_solids`` (its drawers stop at the scene's solids), ``draws_ground`` (its drawer
    draws the ground itself when alone), ``cpu_split`` and ``split_key`` (impostor splitting
    around solids: the CPU twin of the GL drawer's ``draw_split``, and the sort key it cuts at),
    ``translation(old, new) -> offset | None`` (whether ``new`` is ``old`` moved: impostors keep
    their image) and ``order_point(drawable)`` (the point its drawer sorts it by, when not its
    bounding sphere's centre).
    """

    name: str
    model: type
    paper: str
    modules: tuple[str, ...]
    light: Callable[..., Any]
    gl_drawer: type
    cpu_drawer: Callable[..., Any]
    physical_light: Callable[..., Any] | None = None
    light_batch: Callable[..., list[Any]] | None = None
    digest: Callable[[Any], tuple] | None = None
    shadow_digest: Callable[[Any], tuple] | None = None
    medium: Medium | None = None
    caster: Caster | None = None
    forget: Callable[[], None] | None = None
    advance: Callable[[Any, float], Any] | None = None
    groups: bool = False
    clips_solids: bool = False
    draws_ground: bool = False
    cpu_split: Callable[..., Any] | None = None
    split_key: Callable[..., float] | None = None
    translation: Callable[[Any, Any], Any] | None = None
    order_point: Callable[[Any], Any] | None = None
    cost: Callable[[Any], list[tuple[Any, str, int]]] | None = None

    def light_pass(self, physical: bool) -> Callable[..., Any]:
        """The light pass of this kind in the physical (True) or paper (False) mode."""
        return self.physical_light if physical and self.physical_light is not None else self.light

    def light_digest(self, drawable: Any) -> tuple:
        """What the drawable's light depends on (:attr:`digest`, else its identity)."""
        return self.digest(drawable) if self.digest is not None else (self.name, id(drawable))

    def shadow_key(self, drawable: Any) -> tuple:
        """What the drawable's shadow depends on (:attr:`shadow_digest`, else its light's)."""
        if self.shadow_digest is not None:
            return self.shadow_digest(drawable)
        return self.light_digest(drawable)


_KINDS: dict[str, Kind] = {}


def register(kind: Kind) -> Kind:
    """Register (or replace) a kind; checks that its model class carries the protocol."""
    if not isinstance(kind, Kind):
        raise TypeError(f"kind must be a cumuli.registry.Kind, got {type(kind).__name__}")
    cls = kind.model
    if getattr(cls, "kind", None) != kind.name:
        raise ValueError(f"{cls.__name__}.kind must be {kind.name!r} to register it as such")
    for method in ("bounds", "layer_box", "to_dict", "from_dict"):
        if not callable(getattr(cls, method, None)):
            raise TypeError(f"{cls.__name__} needs a {method}() method to be a drawable kind")
    if (kind.cpu_split is None) != (kind.split_key is None):
        raise ValueError("cpu_split and split_key go together (the split cuts at the key)")
    _KINDS[kind.name] = kind
    return kind


def _tag(obj: Any) -> str:
    tag = getattr(type(obj), "kind", None)
    return tag if isinstance(tag, str) else ""


def get(name: str) -> Kind | None:
    """The kind registered under ``name``, or None."""
    return _KINDS.get(name)


def of(drawable: Any) -> Kind:
    """The kind of a drawable (by its ``kind`` tag and class); TypeError for anything else."""
    found = _KINDS.get(_tag(drawable))
    if found is None or not isinstance(drawable, found.model):
        raise TypeError(f"{type(drawable).__name__} is not a registered kind of drawable")
    return found


def kinds() -> Iterator[Kind]:
    """Every registered kind, in registration order."""
    return iter(tuple(_KINDS.values()))


def model_classes() -> dict[str, type]:
    """The model class of every kind, by its scene-file tag."""
    return {name: k.model for name, k in _KINDS.items()}


def is_drawable(obj: Any) -> bool:
    """Whether ``obj`` is an instance of a registered kind."""
    found = _KINDS.get(_tag(obj))
    return found is not None and isinstance(obj, found.model)
