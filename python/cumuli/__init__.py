"""cumuli: volumetric clouds from Python.

A C++ core (noise, cloud generators, light precompute, a reference marcher) returns numpy arrays;
GLSL shaders run in a headless moderngl context render them. See DESIGN.md for conventions:
+y up, angles in degrees, volumes indexed [z, y, x], images (H, W, 4) float32 with row 0 on top.
"""

from __future__ import annotations

from cumuli._version import __version__
from cumuli.anim import frames
from cumuli.anim.endless import (
    EndlessAnimation,
    blend_volumes,
    crossfade_weights,
    similarity_matrix,
    transition_matrix,
)
from cumuli.anim.frames import fly_towards, orbit, render_frames
from cumuli.camera import Camera
from cumuli.ground import Ground
from cumuli.io import meshes
from cumuli.io.images import from_srgb8, read_image, to_srgb8, write_image
from cumuli.light.grid import LightGrid, LightParams, load_light_grid
from cumuli.light.medium import ExtinctionField, density_volume
from cumuli.light.ndt import LightStats, light_grid
from cumuli.light.physical import PhysicalLight
from cumuli.light.prepare import LitScene, prepare_light
from cumuli.light.shadow import ShadowMap, shadow_map
from cumuli.light.volume import VolumeLighting
from cumuli.model.cloud import Cloud, load_cloud, merge
from cumuli.model.gaussian import gaussian_cumulus, metaball_cumulus
from cumuli.model.lsystem import lsystem_cloud, lsystem_expand, lsystem_length
from cumuli.model.mesh import ellipsoids_from_mesh, mesh_cloud
from cumuli.model.volume import (
    AnimationFrame,
    VolumeCloud,
    VolumeDatabase,
    evolving_cloud_volumes,
)
from cumuli.noise import Noise
from cumuli.rendering.compositor import Renderer, render, render_cpu, render_volume
from cumuli.rendering.volume import VolumeRenderer
from cumuli.scene import Scene, load_scene
from cumuli.settings import RenderSettings
from cumuli.sky import Sky, Sun

__all__ = [
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
    "Cloud",
    "density_volume",
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
    "metaball_cumulus",
    "Noise",
    "orbit",
    "PhysicalLight",
    "prepare_light",
    "read_image",
    "render",
    "render_cpu",
    "render_frames",
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
]
