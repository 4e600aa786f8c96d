"""cumuli: volumetric clouds from Python.

A C++ core (noise, cloud generators, light precompute, a reference marcher) returns numpy arrays;
GLSL shaders run in a headless moderngl context render them. See docs/conventions.md for the
conventions: +y up, angles in degrees, volumes indexed [z, y, x], images (H, W, 4) float32 with
row 0 on top.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from cumuli import registry
from cumuli._util.budget import BudgetError, Limits, get_limits, limits, set_limits
from cumuli._util.buffer_cache import (
    buffer_cache_stats,
    release_buffer_cache,
    set_buffer_cache_limit,
)
from cumuli._version import __version__
from cumuli.anim import frames, weather_presets
from cumuli.anim.cluster import sweep
from cumuli.anim.endless import (
    EndlessAnimation,
    blend_volumes,
    crossfade_weights,
    similarity_matrix,
    transition_matrix,
)
from cumuli.anim.frames import fly_towards, orbit, render_frames
from cumuli.anim.weather import CloudLayer, Schedule, SkyState, Weather, load_weather
from cumuli.camera import Camera
from cumuli.ground import Ground
from cumuli.interchange.blender import to_blender
from cumuli.interchange.mitsuba import to_mitsuba
from cumuli.interchange.volumes import read_volume, write_volume
from cumuli.io import meshes
from cumuli.io.images import from_srgb8, read_image, to_srgb8, write_image
from cumuli.jupyter import Image, show
from cumuli.light.billboard_shading import BillboardShading
from cumuli.light.caf import absorption_factors
from cumuli.light.grid import LightGrid, LightParams, load_light_grid
from cumuli.light.medium import ExtinctionField, density_volume
from cumuli.light.ndt import LightStats, light_grid
from cumuli.light.particles import (
    ParticleLight,
    ground_shadow,
    particle_light,
    skylight_lights,
)
from cumuli.light.physical import PhysicalLight
from cumuli.light.prepare import LitScene, prepare_light
from cumuli.light.shadow import ShadowMap, shadow_map
from cumuli.light.sprite_settings import SpriteSettings
from cumuli.light.volume import VolumeLighting
from cumuli.model import seedbox_presets
from cumuli.model.atlas import sprite_atlas
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import (
    BasisModel,
    BillboardCloud,
    SeedBox,
    cloud_variants,
    load_billboards,
    seed_box_cloud,
)
from cumuli.model.cloud import Cloud, load_cloud, merge
from cumuli.model.deck import CloudDeck
from cumuli.model.gaussian import gaussian_cumulus, metaball_cumulus
from cumuli.model.lsystem import lsystem_cloud, lsystem_expand, lsystem_length
from cumuli.model.mesh import ellipsoids_from_mesh, mesh_cloud
from cumuli.model.particles import ParticleCloud, load_particles, particle_cumulus, particle_fill
from cumuli.model.solid import Solid
from cumuli.model.volume import (
    AnimationFrame,
    VolumeCloud,
    VolumeDatabase,
    evolving_cloud_volumes,
)
from cumuli.noise import Noise
from cumuli.rendering.compositor import Renderer, render, render_cpu, render_volume
from cumuli.rendering.impostor_cache import ImpostorCache
from cumuli.rendering.impostors import ImpostorSettings
from cumuli.rendering.marcher_cpu import MarchStats, occupancy_grid
from cumuli.rendering.volume import VolumeRenderer
from cumuli.scene import Scene, load_scene
from cumuli.settings import RenderSettings
from cumuli.sky import Sky, Sun

# isort: off
from cumuli import kinds as _kinds  # noqa: E402, F401 (registers every kind of drawable)
# isort: on


if TYPE_CHECKING:  # what `cu.Viewer` is, for type checkers (imported lazily below)
    from cumuli.jupyter.viewer import Viewer as Viewer


def __getattr__(name: str) -> object:
    # The Viewer needs the widget packages (anywidget): imported on first use only, and kept
    # out of __all__ so that `from cumuli import *` works without them.
    if name == "Viewer":
        from cumuli.jupyter.viewer import Viewer

        return Viewer
    raise AttributeError(f"module 'cumuli' has no attribute {name!r}")


__all__ = [
    "BudgetError",
    "Limits",
    "get_limits",
    "limits",
    "set_limits",
    "buffer_cache_stats",
    "release_buffer_cache",
    "set_buffer_cache_limit",
    "BasisModel",
    "BillboardCloud",
    "BillboardField",
    "BillboardShading",
    "CloudLayer",
    "Schedule",
    "SeedBox",
    "SkyState",
    "Weather",
    "absorption_factors",
    "cloud_variants",
    "load_billboards",
    "load_weather",
    "seed_box_cloud",
    "seedbox_presets",
    "sprite_atlas",
    "weather_presets",
    "AnimationFrame",
    "EndlessAnimation",
    "VolumeDatabase",
    "VolumeLighting",
    "VolumeRenderer",
    "blend_volumes",
    "crossfade_weights",
    "evolving_cloud_volumes",
    "render_volume",
    "similarity_matrix",
    "transition_matrix",
    "Camera",
    "Image",
    "show",
    "Cloud",
    "CloudDeck",
    "density_volume",
    "read_volume",
    "write_volume",
    "to_mitsuba",
    "to_blender",
    "ellipsoids_from_mesh",
    "ExtinctionField",
    "fly_towards",
    "frames",
    "from_srgb8",
    "gaussian_cumulus",
    "Ground",
    "light_grid",
    "LightGrid",
    "LightParams",
    "LitScene",
    "load_light_grid",
    "VolumeCloud",
    "LightStats",
    "load_cloud",
    "load_scene",
    "lsystem_cloud",
    "lsystem_expand",
    "lsystem_length",
    "merge",
    "mesh_cloud",
    "meshes",
    "MarchStats",
    "metaball_cumulus",
    "Noise",
    "occupancy_grid",
    "orbit",
    "PhysicalLight",
    "prepare_light",
    "read_image",
    "registry",
    "render",
    "render_cpu",
    "render_frames",
    "sweep",
    "Renderer",
    "RenderSettings",
    "Scene",
    "ShadowMap",
    "shadow_map",
    "Sky",
    "Sun",
    "to_srgb8",
    "write_image",
    "__version__",
    # Harris 2002: particle clouds, their light, impostors, solids
    "ParticleCloud",
    "ParticleLight",
    "particle_cumulus",
    "particle_fill",
    "load_particles",
    "SpriteSettings",
    "particle_light",
    "skylight_lights",
    "ground_shadow",
    "ImpostorSettings",
    "ImpostorCache",
    "Solid",
]
