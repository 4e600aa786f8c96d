"""The density volume (Iwasaki, Nishino & Dobashi 2011): a lattice of density lit by sun and
sky light per voxel, ray marched on the GPU (its C++ twin on the CPU)."""

from __future__ import annotations

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


MEDIUM = registry.Medium(
    core_args=volume_core_args,
    extinction=volume_extinction,
    own_lattice=own_lattice,
    light_box=lambda v: v.box,
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

__all__ = ["KIND", "MEDIUM", "digest", "own_lattice"]
