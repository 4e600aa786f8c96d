"""``to_blender``: a cumuli scene as a Blender ``.blend`` file (Blender's ``bpy``, run in its own
Python: ``pip install "bpy>=4.2,<5"`` in an environment of its own, see docs/interchange.md).

Each drawable with a density is written as an OpenVDB file beside the ``.blend``
(``<stem>_cloud<i>.vdb``, :func:`cumuli.write_volume`) and imported as a volume object with a
Principled Volume material: density 1 (the grid holds ``σt`` per unit), colour = albedo
(Cycles then scatters ``albedo·σt`` and absorbs ``(1 − albedo)·σt``), anisotropy = ``g``, black
absorption colour. The sun becomes a sun lamp (strength = ``Sun.intensity``, colour =
``Sun.colour``), the sky an equirectangular world texture of ``Sky.radiance``
(``<stem>_sky.exr``, packed into the ``.blend``), the camera a perspective camera with the same
vertical field of view. Blender (Cycles and EEVEE, 4.5) puts a grid's voxel ``(i, j, k)`` half a
voxel further along each axis than OpenVDB's index-to-world transform says (it centres voxels
at ``ijk + ½``); the volume objects are moved back by half a voxel to match (measured: the
alpha's mean error falls from 0.024 to 0.004 on the test scene). Blender's frame is z-up:
cumuli's ``(x, y, z)`` is Blender's ``(x, −z, y)``. The build itself is
:mod:`cumuli.interchange.blender_build`, which Blender's Python runs in a subprocess.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from cumuli.camera import Camera
from cumuli.interchange.volumes import volume_field
from cumuli.io import volumes as files
from cumuli.io.images import write_image

BUILD_SCRIPT = Path(__file__).with_name("blender_build.py")
#: Environment variable naming a Python that can ``import bpy``.
PYTHON_ENV = "CUMULI_BLENDER_PYTHON"


def blender_python(python: str | os.PathLike[str] | None = None) -> str:
    """The interpreter that runs Blender: ``python`` if given, else ``$CUMULI_BLENDER_PYTHON``,
    else this one if it can import ``bpy``; ``OSError`` if none."""
    for candidate in (python, os.environ.get(PYTHON_ENV)):
        if candidate:
            if not Path(candidate).exists():
                raise FileNotFoundError(f"no Python at {candidate} (for Blender's bpy)")
            return str(candidate)
    if importlib.util.find_spec("bpy") is not None:
        return sys.executable
    raise OSError(
        "to_blender needs Blender's Python module: install it (pip install 'bpy>=4.2,<5', "
        f"Python 3.11) and pass python= or set {PYTHON_ENV} to that interpreter"
    )


def sky_equirect(scene: Any, width: int = 512) -> np.ndarray:
    """``Sky.radiance`` in Blender's equirectangular convention ``(width/2, width, 3)``, row 0
    at the top: texel ``(u, v)`` shows Blender's direction ``(cos e·cos φ, cos e·sin φ, sin e)``
    with ``φ = (½ − u)·2π``, ``e = (v − ½)·π``."""
    height = width // 2
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    phi, elev = np.meshgrid((0.5 - u) * 2 * np.pi, (v - 0.5) * np.pi)
    bx, by, bz = np.cos(elev) * np.cos(phi), np.cos(elev) * np.sin(phi), np.sin(elev)
    d = np.stack([bx, bz, -by], -1).reshape(-1, 3)  # Blender's frame → cumuli's
    return scene.sky.radiance(d, scene.sun).reshape(height, width, 3)


def blender_spec(
    scene: Any,
    camera: Camera,
    path: str | os.PathLike[str],
    width: int = 160,
    height: int = 120,
    resolution: Any = None,
    sky_width: int = 512,
) -> dict[str, Any]:
    """Write the volumes and the sky beside ``path`` and return the build description
    (:mod:`cumuli.interchange.blender_build`)."""
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
    path = Path(path)
    if path.suffix.lower() != ".blend":
        raise ValueError(f"{path}: a Blender file ends in .blend")
    if not path.parent.is_dir():
        raise FileNotFoundError(f"folder {path.parent} does not exist")
    volumes = []
    media = [c for c in scene.clouds if getattr(type(c), "kind", None) is not None]
    for i, drawable in enumerate(media):
        field, attrs = volume_field(drawable, scene.noise, scene.settings, resolution)
        vdb = path.with_name(f"{path.stem}_cloud{i}.vdb")
        files.write(vdb, files.checked(field.values, field.box, attrs))
        voxel = (np.subtract(field.box[1], field.box[0]) / field.values.shape[::-1]).tolist()
        volumes.append({"path": str(vdb.resolve()), "albedo": attrs["albedo"], "g": attrs["g"],
                        "offset": [-0.5 * v for v in voxel]})  # fmt: skip
    sky = None
    if scene.sky is not None:
        sky_path = path.with_name(f"{path.stem}_sky.exr")
        write_image(sky_path, sky_equirect(scene, sky_width).astype(np.float32))
        sky = {"path": str(sky_path.resolve())}
    sun = scene.sun
    return {
        "volumes": volumes,
        "sun": {
            "direction": list(sun.direction),
            "colour": list(sun.colour),
            "strength": float(sun.intensity),
        },  # fmt: skip
        "sky": sky,
        "camera": {
            "position": list(camera.position),
            "target": list(camera.target),
            "up": list(camera.up),
            "fov": float(camera.fov),
        },  # fmt: skip
        "width": int(width),
        "height": int(height),
        "blend": str(path.resolve()),
    }


def run_blender(spec: dict[str, Any], python: str | None = None, timeout: float = 600) -> None:
    """Run the build of ``spec`` in Blender's Python (``OSError`` with its output on failure)."""
    exe = blender_python(python)
    with tempfile.TemporaryDirectory() as tmp:
        spec_path = Path(tmp) / "spec.json"
        spec_path.write_text(json.dumps(spec))
        done = subprocess.run([exe, str(BUILD_SCRIPT), str(spec_path)], capture_output=True,
                              text=True, timeout=timeout)  # fmt: skip
    if done.returncode != 0:
        tail = (done.stdout + done.stderr)[-2000:]
        raise OSError(f"Blender failed (exit {done.returncode}):\n{tail}")


def to_blender(
    scene: Any,
    camera: Camera,
    path: str | os.PathLike[str],
    width: int = 160,
    height: int = 120,
    *,
    resolution: Any = None,
    python: str | os.PathLike[str] | None = None,
    render: dict[str, Any] | None = None,
) -> Path:
    """Write ``scene`` seen by ``camera`` as a ``.blend`` (module docstring) at ``path``, with
    its volumes (``<stem>_cloud<i>.vdb``) and sky (``<stem>_sky.exr``) beside it; open it in
    Blender and render it with Cycles. ``python`` is an interpreter that can ``import bpy``
    (default: ``$CUMULI_BLENDER_PYTHON``, else this one); ``render`` also renders it (keys
    ``path`` — an ``.exr`` — ``samples``, ``transparent``, ``seed``, ``threads``). Returns the
    path."""
    exe = blender_python(python)  # before anything is written
    spec = blender_spec(scene, camera, path, width, height, resolution)
    if render is not None:
        spec["render"] = dict(render)
    run_blender(spec, exe)
    return Path(path)
