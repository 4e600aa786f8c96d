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

Opaque solids (``Scene.solids``): drawers of the kinds in :data:`CLIPS_SOLIDS` draw only what lies
in front of them (the marchers stop each ray at the nearest solid, particle and billboard sprites
are depth-tested), so their layers composite exactly with the solids. Kinds in
:data:`CPU_SPLITS` (and whose GL drawer has ``draw_split``) can be cut into ``m + 1`` layers
around ``m`` solids for impostor splitting (Harris 2002 §3.1.1): ``split(lit, index, camera,
width, height, cuts[, threads])`` → ``(m + 1, H, W, 4)``, farthest first, cut at the solids'
sort keys, which :data:`SPLIT_KEYS` computes as the kind's drawer sorts (``key(lit, point,
camera)``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BillboardCloud
from cumuli.model.cloud import Cloud
from cumuli.model.particles import ParticleCloud
from cumuli.model.volume import VolumeCloud
from cumuli.rendering import billboards, particle_layers
from cumuli.rendering.billboards import BillboardGL, draw_billboards_cpu, split_billboards_cpu
from cumuli.rendering.cpu import draw_clouds_cpu
from cumuli.rendering.marcher import MarcherGL
from cumuli.rendering.particle_layers import (
    ParticleCloudsGL,
    draw_particle_clouds_cpu,
    split_particle_cloud_cpu,
)
from cumuli.rendering.volume import VolumeGL, draw_volume_cpu

#: GL drawer class of each kind.
GL_DRAWERS: dict[str, type] = {
    Cloud.kind: MarcherGL,
    VolumeCloud.kind: VolumeGL,
    ParticleCloud.kind: ParticleCloudsGL,
    BillboardCloud.kind: BillboardGL,
    BillboardField.kind: BillboardGL,
}
#: CPU drawer (the C++ twin) of each kind.
CPU_DRAWERS: dict[str, Callable[..., Any]] = {
    Cloud.kind: draw_clouds_cpu,
    VolumeCloud.kind: draw_volume_cpu,
    ParticleCloud.kind: draw_particle_clouds_cpu,
    BillboardCloud.kind: draw_billboards_cpu,
    BillboardField.kind: draw_billboards_cpu,
}
#: Kinds whose drawer draws several drawables in one pass (its own order inside the pass: the
#: marcher orders its clouds per pixel; particle clouds are splatted back to front cloud by
#: cloud, as SkyWorks does). Grouped kinds sharing one drawer (billboard clouds and fields) are
#: drawn together in one pass too.
GROUPED_KINDS: set[str] = {Cloud.kind, ParticleCloud.kind, BillboardCloud.kind, BillboardField.kind}
#: Kinds whose drawers draw only what lies in front of the scene's solids.
CLIPS_SOLIDS: set[str] = {
    Cloud.kind, VolumeCloud.kind, ParticleCloud.kind, BillboardCloud.kind, BillboardField.kind,
}  # fmt: skip
#: CPU split drawers (the GL drawer's ``draw_split``) of the kinds impostors can split.
CPU_SPLITS: dict[str, Callable[..., Any]] = {
    ParticleCloud.kind: split_particle_cloud_cpu,
    BillboardCloud.kind: split_billboards_cpu,
    BillboardField.kind: split_billboards_cpu,
}
#: The sort key a split cuts at, per splittable kind: ``key(lit, point, camera) -> float`` (the
#: kind's own depth order: particles by ``sprite_settings.sort``, billboards by
#: ``billboard_shading.sort``).
SPLIT_KEYS: dict[str, Callable[..., float]] = {
    ParticleCloud.kind: particle_layers.sort_key,
    BillboardCloud.kind: billboards.sort_key,
    BillboardField.kind: billboards.sort_key,
}
#: Kinds whose drawer draws the scene's ground itself (others are composited over it).
GROUND_KINDS: set[str] = {Cloud.kind}


def register_drawers(
    kind: str,
    gl: type,
    cpu: Callable[..., Any],
    groups: bool = False,
    *,
    clips_solids: bool = False,
    cpu_split: Callable[..., Any] | None = None,
    split_key: Callable[..., float] | None = None,
) -> None:
    """Register the GL drawer class and the CPU drawer function of a new kind (``groups``: one
    pass may draw several; ``clips_solids``: its drawers stop at the scene's solids;
    ``cpu_split``: the CPU twin of the GL drawer's ``draw_split``, for impostor splitting, with
    ``split_key`` the sort key it cuts at)."""
    if cpu_split is not None and split_key is None:
        raise ValueError("cpu_split needs split_key (the sort key the split cuts at)")
    GL_DRAWERS[kind] = gl
    CPU_DRAWERS[kind] = cpu
    if groups:
        GROUPED_KINDS.add(kind)
    if clips_solids:
        CLIPS_SOLIDS.add(kind)
    if cpu_split is not None and split_key is not None:
        CPU_SPLITS[kind] = cpu_split
        SPLIT_KEYS[kind] = split_key
