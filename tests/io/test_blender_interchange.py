"""Blender opens what cumuli writes: a cloud written as ``.vdb`` becomes a volume object with a
Principled Volume material, lit by the same sun under the same sky and rendered by Cycles on the
CPU from the same camera (160×120, few samples, transparent film): its alpha is cumuli's
``1 − T`` (mean |ΔT| ≤ 0.02) and its sky is cumuli's; the ``.blend`` opens in ``bpy``.

Blender's ``bpy`` (4.x for Python 3.11) pins numpy < 2, so it lives in an environment of its own
(``make blender``: ``.venv-blender``) and runs in a subprocess; ``$CUMULI_BLENDER_PYTHON`` names
another interpreter that has it."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu

ROOT = Path(__file__).resolve().parents[2]


def _python() -> str | None:
    env = os.environ.get("CUMULI_BLENDER_PYTHON")
    if env:
        return env
    local = ROOT / ".venv-blender" / "bin" / "python"
    if local.exists():
        return str(local)
    return sys.executable if importlib.util.find_spec("bpy") is not None else None


PYTHON = _python()
pytestmark = pytest.mark.skipif(
    PYTHON is None, reason="Blender's bpy is not installed (make blender, or CUMULI_BLENDER_PYTHON)"
)
W, H = 160, 120


@pytest.fixture(scope="module")
def blender_scene(tmp_path_factory: pytest.TempPathFactory) -> dict:
    tmp = tmp_path_factory.mktemp("blender")
    cloud = cu.gaussian_cumulus(seed=1)
    vol = cu.read_volume(cu.write_volume(tmp / "cloud.vdb", cloud, cu.Noise(seed=7), resolution=40))
    el = math.radians(35.0)
    scene = cu.Scene(
        clouds=[vol],
        sun=cu.Sun(direction=(math.cos(el), math.sin(el), 0.0)),
        sky=cu.Sky(),
        # the air (aureole, aerial perspective) is cumuli's pass on the image, not exported
        settings=cu.RenderSettings(lighting="physical", haze=0.0, air_extinction=0.0),
    )
    camera = cu.Camera(position=(0.0, 2.0, -45.0), target=(0.0, 1.0, 0.0), fov=38.0)
    blend = cu.to_blender(scene, camera, tmp / "scene.blend", W, H, python=PYTHON,
                          render={"path": str(tmp / "render.exr"), "samples": 16})  # fmt: skip
    return {"scene": scene, "camera": camera, "blend": blend, "render": tmp / "render.exr",
            "tmp": tmp}  # fmt: skip


def test_cycles_alpha_is_cumulis_transmittance(blender_scene: dict) -> None:
    theirs = cu.read_image(blender_scene["render"])
    ours = cu.render(blender_scene["scene"], blender_scene["camera"], W, H, backend="cpu")
    assert theirs.shape == (H, W, 4)
    assert theirs[..., 3].max() > 0.9  # the cloud is there, opaque in its core
    assert np.abs(theirs[..., 3] - ours[..., 3]).mean() <= 0.02


def test_cycles_sky_is_cumulis_sky(blender_scene: dict) -> None:
    tmp = blender_scene["tmp"]
    scene = blender_scene["scene"].replace(clouds=[])
    render = {"path": str(tmp / "sky.exr"), "samples": 4, "transparent": False}
    cu.to_blender(scene, blender_scene["camera"], tmp / "sky.blend", 40, 30, python=PYTHON,
                  render=render)  # fmt: skip
    theirs = cu.read_image(tmp / "sky.exr")[..., :3]
    ours = cu.render(scene, blender_scene["camera"], 40, 30, backend="cpu")[..., :3]
    # the same radiance in every direction (pixels across the horizon differ most: Cycles
    # averages over the pixel, cumuli shows its centre)
    assert np.abs(theirs - ours).mean() < 0.005 and np.median(np.abs(theirs - ours)) < 0.002


def test_the_blend_opens_in_bpy(blender_scene: dict) -> None:
    script = f"""
import json, bpy
bpy.ops.wm.open_mainfile(filepath={str(blender_scene["blend"])!r})
s = bpy.context.scene
vol = [o for o in s.objects if o.type == "VOLUME"]
vol[0].data.grids.load()
mat = vol[0].active_material.node_tree.nodes["Principled Volume"]
sun = [o for o in s.objects if o.type == "LIGHT"][0]
print("JSON" + json.dumps({{
    "volumes": len(vol), "grids": [g.name for g in vol[0].data.grids],
    "colour": list(mat.inputs["Color"].default_value)[:3],
    "density": mat.inputs["Density"].default_value,
    "anisotropy": mat.inputs["Anisotropy"].default_value,
    "sun_type": sun.data.type, "sun_strength": sun.data.energy,
    "sun_travel": list(sun.matrix_world.to_3x3() @ __import__("mathutils").Vector((0, 0, -1))),
    "camera": s.camera.data.angle_y, "size": [s.render.resolution_x, s.render.resolution_y],
    "world": any(n.type == "TEX_ENVIRONMENT" for n in s.world.node_tree.nodes),
}}))
"""
    out = subprocess.run([PYTHON, "-c", script], capture_output=True, text=True, check=True)
    info = json.loads(next(ln for ln in out.stdout.splitlines() if ln.startswith("JSON"))[4:])
    scene = blender_scene["scene"]
    vol = scene.clouds[0]
    assert info["volumes"] == 1 and "density" in info["grids"]
    assert np.allclose(info["colour"], vol.albedo) and info["density"] == 1.0
    assert info["anisotropy"] == pytest.approx(vol.g)
    assert info["sun_type"] == "SUN" and info["sun_strength"] == pytest.approx(scene.sun.intensity)
    d = np.asarray(scene.sun.direction)
    assert np.allclose(info["sun_travel"], [-d[0], d[2], -d[1]], atol=1e-5)  # −d in Blender's frame
    assert info["camera"] == pytest.approx(math.radians(38.0)) and info["size"] == [W, H]
    assert info["world"]


def test_to_blender_refuses_bad_input(tmp_path: Path) -> None:
    scene = cu.Scene(clouds=[])
    cam = cu.Camera(position=(0.0, 0.0, -10.0), target=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=".blend"):
        cu.to_blender(scene, cam, tmp_path / "x.txt", python=PYTHON)
    with pytest.raises(TypeError, match="Camera"):
        cu.to_blender(scene, "camera", tmp_path / "x.blend", python=PYTHON)
    with pytest.raises(FileNotFoundError):
        cu.to_blender(scene, cam, tmp_path / "x.blend", python=tmp_path / "no-python")
    assert list(tmp_path.iterdir()) == []
