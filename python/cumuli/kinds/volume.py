"""The density volume (Iwasaki, Nishino & Dobashi 2011): a lattice of density lit by sun and
sky light per voxel, ray marched on the GPU (its C++ twin on the CPU)."""

from __future__ import annotations

import copy

import numpy as np

from cumuli import registry
from cumuli.light.medium import volume_core_args, volume_extinction
from cumuli.light.memo import content_digest
from cumuli.light.physical import physical_pass
from cumuli.light.volume import volume_light
from cumuli.model.volume import VolumeCloud
from cumuli.rendering.volume import VolumeGL, draw_volume_cpu


def digest(volume: VolumeCloud) -> tuple:
    """What a volume's light depends on: its density, box, extinction and reconstruction (its
    physical light's lattice)."""
    return (
        "volume", content_digest(volume.density), volume.box, volume.sigma_t,
        volume.reconstruction,
    )  # fmt: skip


def own_lattice(volume: VolumeCloud) -> tuple[int, int, int] | None:
    """A trilinear volume's own lattice (its light is no finer); None for a cubic one, whose
    density is smooth between the voxels: its physical light takes the settings'
    ``physical_resolution`` however coarse the voxels are."""
    return tuple(volume.shape[::-1]) if volume.reconstruction == "linear" else None


def at_origin(volume: VolumeCloud) -> tuple[VolumeCloud, tuple[float, float, float]]:
    """``(still, offset)``: the volume is ``still``, the same volume with its box's low corner at
    the origin, moved by ``offset`` (the low corner). A volume's medium is its lattice over its
    box, so its light does not depend on where it stands (the sharp-volume erosion, anchored in
    the world, is the draw's, not the light's): the physical light step lights every translated
    copy of a volume once, at the origin, and moves the light (:attr:`registry.Medium.moved`).
    The still volume's size is the box's rounded to float32, the core's precision, so that
    copies moved by any offset share it; its arrays are shared."""
    lo, hi = volume.box
    if not any(lo):
        return volume, (0.0, 0.0, 0.0)
    still = copy.copy(volume)  # fields already checked: the light step asks several times
    size = tuple(float(np.float32(h - low)) for low, h in zip(lo, hi, strict=True))
    object.__setattr__(still, "box", ((0.0, 0.0, 0.0), size))
    return still, tuple(float(v) for v in lo)


MEDIUM = registry.Medium(
    core_args=volume_core_args,
    extinction=volume_extinction,
    own_lattice=own_lattice,
    light_box=lambda v: v.box,
    moved=at_origin,
)

KIND = registry.register(
    registry.Kind(
        name=VolumeCloud.kind,
        model=VolumeCloud,
        paper="Iwasaki, Nishino & Dobashi 2011",
        modules=(
            "model.volume",
            "light.volume",
            "rendering.volume",
            "anim.endless",
            "kinds.volume",
        ),  # fmt: skip
        light=volume_light,
        physical_light=physical_pass,
        digest=digest,
        medium=MEDIUM,
        gl_drawer=VolumeGL,
        cpu_drawer=draw_volume_cpu,
        clips_solids=True,
    )
)

__all__ = ["KIND", "MEDIUM", "at_origin", "digest", "own_lattice"]
