"""cumuli: volumetric clouds from Python.

A C++ core (noise, cloud generators, light precompute, a reference marcher) returns numpy arrays;
GLSL shaders run in a headless moderngl context render them. See DESIGN.md for conventions:
+y up, angles in degrees, volumes indexed [z, y, x], images (H, W, 4) float32 with row 0 on top.
"""

from __future__ import annotations

from cumuli import frames, meshes
from cumuli._version import __version__
from cumuli.animation import (
    AnimationFrame,
    EndlessAnimation,
    VolumeDatabase,
    VolumeLighting,
    blend_volumes,
    crossfade_weights,
    evolving_cloud_volumes,
    similarity_matrix,
    transition_matrix,
)
from cumuli.cloud import Cloud, load_cloud, merge
from cumuli.cpu_render import render_cpu
from cumuli.frames import fly_towards, orbit, render_frames
from cumuli.imageio import from_srgb8, read_image, to_srgb8, write_image
from cumuli.light import LightStats, light_grid
from cumuli.noise import Noise
from cumuli.renderer import Renderer, prepare_light, render
from cumuli.scene import Camera, RenderSettings, Scene, Sky, load_scene
from cumuli.shapes import (
    ellipsoids_from_mesh,
    gaussian_cumulus,
    lsystem_cloud,
    lsystem_expand,
    lsystem_length,
    mesh_cloud,
    metaball_cumulus,
)
from cumuli.sun import Sun
from cumuli.volume_render import VolumeRenderer, render_volume

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
    "ellipsoids_from_mesh",
    "fly_towards",
    "frames",
    "from_srgb8",
    "gaussian_cumulus",
    "light_grid",
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
    "prepare_light",
    "read_image",
    "render",
    "render_cpu",
    "render_frames",
    "Renderer",
    "RenderSettings",
    "Scene",
    "Sky",
    "Sun",
    "to_srgb8",
    "write_image",
    "__version__",
]
