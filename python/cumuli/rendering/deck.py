"""The drawers of a `CloudDeck`: the deck baked to its density lattice
(:meth:`cumuli.CloudDeck.to_volume`) and drawn by the volume marcher (GLSL, :class:`VolumeGL`)
or its C++ twin (:func:`draw_volume_cpu`), with the deck's light — the volume light of that
lattice in the paper mode, its :class:`cumuli.PhysicalLight` in the physical mode. The same
lattice is the deck's medium for shadows (:mod:`cumuli.kinds.deck`), so what casts the shadow is
what is drawn."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli.camera import Camera
from cumuli.light.prepare import LitScene
from cumuli.rendering.volume import VolumeGL, draw_volume_cpu


def as_volumes(lit: LitScene, indices: Sequence[int]) -> LitScene:
    """``lit`` with the decks at ``indices`` replaced by their baked volumes (same lights)."""
    clouds = list(lit.scene.clouds)
    for k in indices:
        clouds[k] = clouds[k].to_volume()
    return LitScene(lit.scene.replace(clouds=tuple(clouds)), lit.lights, lit.shadow)


class DeckGL(VolumeGL):
    """Draws `CloudDeck` drawables with the volume marcher; one deck per draw."""

    def draw(
        self,
        lit: LitScene,
        indices: Sequence[int],
        camera: Camera,
        width: int,
        height: int,
        with_sky: bool,
    ) -> np.ndarray:
        return super().draw(as_volumes(lit, indices), indices, camera, width, height, with_sky)


def draw_deck_cpu(
    lit: LitScene,
    indices: Sequence[int],
    camera: Camera,
    width: int,
    height: int,
    with_sky: bool,
    threads: int = 0,
) -> np.ndarray:
    """The CPU twin of :meth:`DeckGL.draw`."""
    return draw_volume_cpu(
        as_volumes(lit, indices), indices, camera, width, height, with_sky, threads
    )


__all__: list[Any] = ["DeckGL", "as_volumes", "draw_deck_cpu"]
