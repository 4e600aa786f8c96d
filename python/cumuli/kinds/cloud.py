"""The 2018 cloud (Jiménez de Parga & Gómez Palomo 2018): ellipsoid primitives filled with fBm,
lit by the NDT light grid, ray marched on the GPU (its C++ twin on the CPU)."""

from __future__ import annotations

from typing import Any

from cumuli import registry
from cumuli.light.grid import primitives_digest
from cumuli.light.medium import cloud_core_args, cloud_extinction
from cumuli.light.ndt import cloud_light
from cumuli.light.physical import physical_pass
from cumuli.model.cloud import Cloud
from cumuli.rendering.impostor_units import cloud_translation
from cumuli.rendering.marcher import MarcherGL
from cumuli.rendering.marcher_cpu import draw_clouds_cpu


def digest(cloud: Cloud) -> tuple:
    """What a 2018 cloud's light depends on: its primitives (where the wind has taken them) and
    density model."""
    return ("cloud", primitives_digest(cloud), cloud.model, cloud.kappa, cloud.phi)


def advance(cloud: Cloud, seconds: float) -> Cloud:
    """The cloud ``seconds`` later: moved by its wind (itself when it has none)."""
    if not any(cloud.wind):
        return cloud
    return cloud.at(cloud.time + seconds)


KIND = registry.register(
    registry.Kind(
        name=Cloud.kind,
        model=Cloud,
        paper="Jiménez de Parga & Gómez Palomo 2018",
        modules=(
            "model.cloud",
            "model.gaussian",
            "model.lsystem",
            "model.mesh",
            "light.grid",
            "light.ndt",
            "rendering.marcher",
            "rendering.marcher_cpu",
            "kinds.cloud",
        ),  # fmt: skip
        light=cloud_light,
        physical_light=physical_pass,
        digest=digest,
        medium=registry.Medium(
            core_args=cloud_core_args,
            extinction=cloud_extinction,
            moved=lambda cloud: (cloud.still(), cloud.offset),
        ),
        advance=advance,
        translation=cloud_translation,
        gl_drawer=MarcherGL,
        cpu_drawer=draw_clouds_cpu,
        # The marcher orders its clouds per pixel itself, and draws the ground when alone.
        groups=True,
        clips_solids=True,
        draws_ground=True,
    )
)

__all__: list[Any] = ["KIND", "advance", "digest"]
