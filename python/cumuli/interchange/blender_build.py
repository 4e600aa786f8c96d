"""Build (and optionally render) a Blender scene from a JSON description: run by Blender's
Python (``bpy``), never imported by cumuli (it imports nothing of cumuli).

Usage: ``python blender_build.py spec.json``. The description (made by
:func:`cumuli.interchange.blender.blender_spec`) lists the volumes (``.vdb`` paths, albedo,
``g``), the sun (direction towards it, colour, strength), the sky (a lat-long ``.exr`` in
Blender's equirectangular convention, or none), the camera (position, target, up, vertical
field of view), the image size, the ``.blend`` to save and an optional render (Cycles on the
CPU, samples, transparent film, output ``.exr``). Positions and directions are in cumuli's
frame (y up); Blender's frame (z up) is cumuli's turned +90° about x: ``(x, y, z) → (x, −z, y)``.
"""

from __future__ import annotations

import json
import math
import sys


def to_blender_frame(v: list[float]) -> tuple[float, float, float]:
    """A cumuli point or direction in Blender's frame."""
    return (v[0], -v[2], v[1])


def _clear(bpy) -> None:  # noqa: ANN001
    bpy.ops.wm.read_factory_settings(use_empty=True)


def _volume(bpy, i: int, vol: dict) -> None:  # noqa: ANN001
    bpy.ops.object.volume_import(filepath=vol["path"], align="WORLD", location=(0, 0, 0))
    obj = bpy.context.active_object
    obj.name = f"cloud_{i}"
    obj.rotation_euler = (math.pi / 2, 0.0, 0.0)  # cumuli's frame → Blender's
    obj.location = to_blender_frame(vol.get("offset", [0.0, 0.0, 0.0]))
    mat = bpy.data.materials.new(f"cloud_{i}")
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    shader = nodes.new("ShaderNodeVolumePrincipled")
    out = nodes.new("ShaderNodeOutputMaterial")
    a = float(vol["albedo"])
    shader.inputs["Color"].default_value = (a, a, a, 1.0)
    shader.inputs["Density"].default_value = 1.0  # the grid already holds σt per unit
    shader.inputs["Anisotropy"].default_value = float(vol["g"])
    shader.inputs["Absorption Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    mat.node_tree.links.new(shader.outputs["Volume"], out.inputs["Volume"])
    obj.data.materials.append(mat)


def _sun(bpy, sun: dict) -> None:  # noqa: ANN001
    from mathutils import Vector

    light = bpy.data.lights.new("sun", type="SUN")
    light.color = sun["colour"]
    light.energy = float(sun["strength"])
    light.angle = math.radians(0.53)
    obj = bpy.data.objects.new("sun", light)
    bpy.context.scene.collection.objects.link(obj)
    towards = Vector(to_blender_frame(sun["direction"])).normalized()
    obj.rotation_euler = towards.to_track_quat("Z", "Y").to_euler()  # light travels along −Z


def _world(bpy, sky: dict | None) -> None:  # noqa: ANN001
    world = bpy.data.worlds.new("sky")
    bpy.context.scene.world = world
    world.use_nodes = True
    nodes = world.node_tree.nodes
    background = nodes["Background"]
    if sky is None:
        background.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        return
    image = bpy.data.images.load(sky["path"])
    image.pack()
    env = nodes.new("ShaderNodeTexEnvironment")
    env.image = image
    world.node_tree.links.new(env.outputs["Color"], background.inputs["Color"])


def _camera(bpy, cam: dict, width: int, height: int) -> None:  # noqa: ANN001
    from mathutils import Matrix, Vector

    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(float(cam["fov"]))
    obj = bpy.data.objects.new("camera", data)
    bpy.context.scene.collection.objects.link(obj)
    eye = Vector(to_blender_frame(cam["position"]))
    forward = (Vector(to_blender_frame(cam["target"])) - eye).normalized()
    right = forward.cross(Vector(to_blender_frame(cam["up"]))).normalized()
    up = right.cross(forward)
    rot = Matrix((right, up, -forward)).transposed()  # columns: camera x, y, z (looks along −z)
    obj.matrix_world = Matrix.Translation(eye) @ rot.to_4x4()
    scene = bpy.context.scene
    scene.camera = obj
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100


def build(spec: dict) -> None:
    """Build the scene of ``spec``, save it, and render it where asked."""
    import bpy

    _clear(bpy)
    for i, vol in enumerate(spec["volumes"]):
        _volume(bpy, i, vol)
    if spec.get("sun") is not None:
        _sun(bpy, spec["sun"])
    _world(bpy, spec.get("sky"))
    _camera(bpy, spec["camera"], int(spec["width"]), int(spec["height"]))
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.view_settings.view_transform = "Standard"
    if spec.get("blend"):
        bpy.ops.wm.save_as_mainfile(filepath=spec["blend"], compress=True)
    render = spec.get("render")
    if render:
        scene.cycles.samples = int(render.get("samples", 16))
        scene.cycles.use_denoising = False
        scene.cycles.seed = int(render.get("seed", 0))
        scene.cycles.max_bounces = int(render.get("max_bounces", 12))
        scene.cycles.volume_bounces = int(render.get("max_bounces", 12))
        scene.cycles.transparent_max_bounces = 8
        scene.render.film_transparent = bool(render.get("transparent", True))
        scene.render.threads_mode = "FIXED"
        scene.render.threads = int(render.get("threads", 2))
        scene.render.image_settings.file_format = "OPEN_EXR"
        scene.render.image_settings.color_mode = "RGBA"
        scene.render.image_settings.color_depth = "32"
        scene.render.filepath = render["path"]
        bpy.ops.render.render(write_still=True)


if __name__ == "__main__":
    with open(sys.argv[1], encoding="utf-8") as f:
        build(json.load(f))
