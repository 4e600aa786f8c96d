"""What the light of a drawable depends on, as hashable keys for the light step's memo."""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np

from cumuli.light.caf import ground_caf_digest
from cumuli.light.grid import primitives_digest
from cumuli.light.particles import particles_digest
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BillboardCloud
from cumuli.model.cloud import Cloud
from cumuli.model.particles import ParticleCloud
from cumuli.model.volume import VolumeCloud


def content_digest(*arrays: np.ndarray) -> str:
    """A short hash of arrays (their shapes and bytes)."""
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        h.update(str(a.shape).encode())
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def drawable_digest(drawable: Any) -> tuple:
    """What a drawable's light depends on, as a hashable key."""
    if isinstance(drawable, Cloud):
        return ("cloud", primitives_digest(drawable), drawable.model, drawable.kappa, drawable.phi)
    if isinstance(drawable, VolumeCloud):
        return ("volume", content_digest(drawable.density), drawable.box, drawable.sigma_t)
    return (drawable.kind, id(drawable))


def shadow_digest(drawable: Any) -> tuple:
    """What a drawable's shadow on the ground depends on: its light's digest, and for a particle
    cloud (whose light does not depend on where it is) also its bounding sphere; a billboard
    cloud's or field's boxes where they are."""
    if isinstance(drawable, ParticleCloud):
        centre, radius = drawable.sphere
        return ("particles", particles_digest(drawable), tuple(centre.tolist()), radius)
    if isinstance(drawable, (BillboardCloud, BillboardField)):
        return ("billboards", ground_caf_digest(drawable))
    return drawable_digest(drawable)
