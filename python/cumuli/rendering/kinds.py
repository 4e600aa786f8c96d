"""Which drawer draws which kind of drawable, on each backend.

A drawer draws drawables of one kind of a :class:`cumuli.LitScene` into an ``(H, W, 4)`` float32
image, row 0 on top: over the sky (``with_sky=True``) or as the premultiplied layer
``(colour, 1 − T)`` the compositor combines. GL drawers are classes made once per
:class:`cumuli.Renderer` (``Drawer(gl, tiles)``) with ``check(scene, indices)`` (limits that
need no light, run before the light pass), ``draw(lit, indices, camera, width, height,
with_sky)`` and ``release()``; ``groups = True`` says one pass may draw several drawables of the
kind (the 2018 marcher orders its clouds per pixel itself). CPU drawers are functions
``draw(lit, indices, camera, width, height, with_sky, threads)``, the C++ twins of the GL ones.
A new kind registers both here (see ARCHITECTURE.md).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from cumuli.model.cloud import Cloud
from cumuli.model.volume import VolumeCloud
from cumuli.rendering.cpu import draw_clouds_cpu
from cumuli.rendering.marcher import MarcherGL
from cumuli.rendering.volume import VolumeGL, draw_volume_cpu

#: GL drawer class of each kind.
GL_DRAWERS: dict[str, type] = {Cloud.kind: MarcherGL, VolumeCloud.kind: VolumeGL}
#: CPU drawer (the C++ twin) of each kind.
CPU_DRAWERS: dict[str, Callable[..., Any]] = {
    Cloud.kind: draw_clouds_cpu,
    VolumeCloud.kind: draw_volume_cpu,
}
#: Kinds whose drawer marches several drawables in one pass (per-pixel order inside the pass).
GROUPED_KINDS: set[str] = {Cloud.kind}
#: Kinds whose drawer draws the scene's ground itself (others are composited over it).
GROUND_KINDS: set[str] = {Cloud.kind}


def register_drawers(kind: str, gl: type, cpu: Callable[..., Any], groups: bool = False) -> None:
    """Register the GL drawer class and the CPU drawer function of a new kind."""
    GL_DRAWERS[kind] = gl
    CPU_DRAWERS[kind] = cpu
    if groups:
        GROUPED_KINDS.add(kind)
