"""The cloud deck: a stratus, stratocumulus or altostratus layer over a large extent, its
coverage from a 2D weather map and its density detailed with the 2018 fBm, moved by the wind.
Every stage sees it through its density lattice (:meth:`cumuli.CloudDeck.to_volume`): its light
is that lattice's (Iwasaki 2011's volume light in the paper mode, the physical light in the
physical mode), its medium casts the shadows, and the volume marcher draws it."""

from __future__ import annotations

import weakref
from typing import Any

from cumuli import registry
from cumuli.light.medium import volume_core_args, volume_extinction
from cumuli.light.memo import content_digest
from cumuli.light.physical import physical_pass
from cumuli.light.volume import volume_light
from cumuli.model import deck as deck_model
from cumuli.model.deck import CloudDeck
from cumuli.rendering.deck import DeckGL, draw_deck_cpu

#: Each deck's digest, hashed once (the light step asks for it once per other drawable).
_digests: weakref.WeakKeyDictionary[CloudDeck, tuple] = weakref.WeakKeyDictionary()


def digest(deck: CloudDeck) -> tuple:
    """What a deck's light depends on: its baked lattice, box and extinction."""
    known = _digests.get(deck)
    if known is None:
        volume = deck.to_volume()
        known = ("deck", content_digest(volume.density), volume.box, volume.sigma_t)
        _digests[deck] = known
    return known


def light(deck: CloudDeck, scene: Any, given: Any = None, threads: int = 0) -> Any:
    """The paper mode's light of a deck: the volume light of its lattice under the scene's sun
    and sky (Iwasaki 2011, §3.1–3.2). A light per voxel, so a deck the wind has moved has its
    time-0 self's (:meth:`CloudDeck.still`), computed once for every time."""
    return volume_light(deck.still().to_volume(threads), scene, given, threads)


def moved(deck: CloudDeck) -> tuple[CloudDeck, tuple[float, float, float]]:
    """``(still, offset)``: the wind carries the whole deck, so a deck at any time is its time-0
    self moved by ``(ox, 0, oz)`` (:attr:`registry.Medium.moved`: the physical light step
    lights it once and moves the light)."""
    ox, oz = deck.offset
    return deck.still(), (ox, 0.0, oz)


def step(deck: CloudDeck) -> float:
    """Shadow and light rays march a deck at half its lattice's smallest cell edge: its density
    is trilinear in the lattice, and the deck is at a scale of its own (kilometres, where the
    settings' ``light_step`` suits clouds tens of units wide)."""
    (lo, hi), n = deck.box, deck.resolution
    return 0.5 * min((hi[a] - lo[a]) / n[a] for a in range(3))


MEDIUM = registry.Medium(
    core_args=lambda deck, settings: volume_core_args(deck.to_volume(), settings),
    extinction=lambda deck, *args: volume_extinction(deck.to_volume(), *args),
    own_lattice=lambda deck: tuple(deck.to_volume().shape[::-1]),
    light_box=lambda deck: deck.box,
    step=step,
    moved=moved,
)

KIND = registry.register(
    registry.Kind(
        name=CloudDeck.kind,
        model=CloudDeck,
        paper="beyond the papers: a layer cloud (Schneider 2015's height profiles and coverage)",
        modules=("model.deck", "rendering.deck", "kinds.deck"),
        cost=deck_model.dict_cost,
        light=light,
        physical_light=physical_pass,
        digest=digest,
        medium=MEDIUM,
        advance=lambda deck, seconds: deck.at(deck.time + seconds),
        gl_drawer=DeckGL,
        cpu_drawer=draw_deck_cpu,
        clips_solids=True,
    )
)

__all__ = ["KIND", "MEDIUM", "digest", "light", "moved"]
