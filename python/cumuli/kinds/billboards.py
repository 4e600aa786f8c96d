"""Billboard clouds and fields (Torchelsen & Musse 2005): textured billboards of seed-and-box
clouds, shaded by the cloud's accumulated optical depth (the CAF); a field is many instances of a
few clouds, each instance an impostor part of its own."""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np

from cumuli import registry
from cumuli.light import billboards as billboard_pass
from cumuli.light.caf import ground_caf, ground_caf_digest
from cumuli.model import billboard_field, billboards
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BillboardCloud
from cumuli.rendering import billboards as drawers
from cumuli.rendering.impostor_units import billboard_translation

Billboards = BillboardCloud | BillboardField


def shadow_digest(drawable: Billboards) -> tuple:
    """What its shadow depends on: the boxes, where they are, and the CAF's options."""
    return ("billboards", ground_caf_digest(drawable))


def cloud_sphere(cloud: BillboardCloud) -> tuple[np.ndarray, float]:
    """The sphere around its quads' and its boxes' bounds (the CAF's chords run through the
    boxes)."""
    (lo_q, hi_q), (lo_b, hi_b) = cloud.layer_box(), cloud.box_bounds()
    lo = np.minimum(np.asarray(lo_q, np.float64), lo_b)
    hi = np.maximum(np.asarray(hi_q, np.float64), hi_b)
    return (lo + hi) / 2, float(np.linalg.norm(hi - lo)) / 2


def field_sphere(field: BillboardField) -> tuple[np.ndarray, float]:
    """The sphere around its instances' such spheres."""
    if field.n == 0:
        return np.zeros(3), 0.0
    centres, radii = field.instance_spheres()
    reach = []  # per variant: the farthest box corner from its quads' sphere centre
    for v in field.variants:
        c = np.asarray(v.sphere()[0], np.float64)
        far = np.maximum(np.abs(v.boxes[:, 0] - c), np.abs(v.boxes[:, 1] - c))  # farthest corner
        reach.append(float(np.linalg.norm(far, axis=1).max()) if len(far) else 0.0)
    radii = np.maximum(radii, np.asarray(reach)[field.variant])
    lo, hi = (centres - radii[:, None]).min(axis=0), (centres + radii[:, None]).max(axis=0)
    centre = (lo + hi) / 2
    return centre, float((np.linalg.norm(centres - centre, axis=1) + radii).max())


def transmittance(
    drawable: Billboards, sun: Any, points: np.ndarray, scene: Any, light: Any, threads: int
) -> np.ndarray:
    """The sun's transmittance at ``points``: the CAF its own billboards would get there."""
    return ground_caf(drawable, sun, points, scene.billboard_shading, threads)


def receiver(drawable: Billboards, light: Any) -> Any:
    """Its boxes (or billboards) receive the others' light, a CAF entry each."""
    if not isinstance(light, billboard_pass.BillboardLighting):
        return None
    at = light.records[0].at
    return partial(billboard_pass.caf_points, drawable, at), (shadow_digest(drawable), at)


def _register(model: type, sphere: Any, **extra: Any) -> registry.Kind:
    return registry.register(
        registry.Kind(
            name=model.kind,
            model=model,
            paper="Torchelsen & Musse 2005",
            modules=(
                "model.billboards",
                "model.billboard_field",
                "model.seedbox",
                "model.atlas",
                "light.caf",
                "light.billboards",
                "light.billboard_shading",
                "rendering.billboards",
                "kinds.billboards",
            ),  # fmt: skip
            light=billboard_pass.billboard_light,
            shadow_digest=shadow_digest,
            caster=registry.Caster(sphere=sphere, transmittance=transmittance, receiver=receiver),
            forget=billboard_pass.clear_memo,
            # Billboard clouds and fields share one drawer: one pass draws them all.
            gl_drawer=drawers.BillboardGL,
            cpu_drawer=drawers.draw_billboards_cpu,
            groups=True,
            clips_solids=True,
            cpu_split=drawers.split_billboards_cpu,
            split_key=drawers.sort_key,
            **extra,
        )
    )


CLOUD = _register(
    BillboardCloud,
    cloud_sphere,
    cost=billboards.dict_cost,
    translation=billboard_translation,
    # Sorted by its boxes' centre c_C (RENDER_CONTRACT, "Billboards").
    order_point=lambda d: np.asarray(d.centre, np.float64),
)
FIELD = _register(BillboardField, field_sphere, cost=billboard_field.dict_cost)

__all__ = ["CLOUD", "FIELD", "receiver", "shadow_digest", "transmittance"]
