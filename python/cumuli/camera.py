"""The pinhole camera every renderer shares (RENDER_CONTRACT "Camera and pixels")."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from cumuli._util import validate as check


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.cross(a, b).astype(np.float32)


def _normalise(v: np.ndarray) -> np.ndarray:
    # glm::normalize's float32 operations (v · 1/√(v·v), dot summed x, y, z), so that the GL
    # marcher's camera basis is the C++ marcher's bit for bit.
    v = np.asarray(v, dtype=np.float32)
    d = (v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]
    return (v * (np.float32(1) / np.sqrt(d))).astype(np.float32)


@dataclass(frozen=True)
class Camera:
    """A pinhole camera. ``fov`` is the VERTICAL field of view in degrees (RENDER_CONTRACT).

    ``position`` looks at ``target``; ``up`` only fixes the roll and must not be parallel to the
    view direction.
    """

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov: float = 50.0

    def __post_init__(self) -> None:
        # Within ±MAX_COORD (1e15), like every generator's coordinates: the ray maths squares
        # distances in float32.
        pos = check.vec3(self.position, "camera.position", bound=check.MAX_COORD)
        tgt = check.vec3(self.target, "camera.target", bound=check.MAX_COORD)
        up = check.direction(self.up, "camera.up")
        fov = check.real(self.fov, "camera.fov", 0.0, 180.0, lo_open=True, hi_open=True)
        view = np.subtract(tgt, pos, dtype=np.float64)
        dist = float(np.linalg.norm(view))
        if dist < 1e-6 * max(1.0, float(np.abs(pos).max())):
            raise ValueError("camera.target must differ from camera.position")
        if np.linalg.norm(np.cross(view / dist, up)) < 1e-6:
            raise ValueError("camera.up must not be parallel to the view direction")
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "target", tgt)
        object.__setattr__(self, "up", up)
        object.__setattr__(self, "fov", fov)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(f, r, u)``: forward, right and up unit vectors, float32, as RENDER_CONTRACT says."""
        pos = np.asarray(self.position, dtype=np.float32)
        f = _normalise(np.asarray(self.target, dtype=np.float32) - pos)
        r = _normalise(_cross(f, np.asarray(self.up, dtype=np.float32)))
        u = _cross(r, f)
        return f, r, u

    def uniforms(self, width: int, height: int) -> dict[str, Any]:
        """The pinhole uniforms the GLSL ray setup reads (``u_cam_pos``, ``u_cam_f``/``r``/``u``,
        ``u_th``, ``u_aspect``, ``u_image_size``) for a ``width × height`` image."""
        f, r, u = self.basis()
        return {
            "u_cam_pos": tuple(np.float32(self.position).tolist()),
            "u_cam_f": tuple(f.tolist()),
            "u_cam_r": tuple(r.tolist()),
            "u_cam_u": tuple(u.tolist()),
            "u_th": math.tan(math.radians(self.fov) / 2),
            "u_aspect": width / height,
            "u_image_size": (width, height),
        }

    def ray_directions(self, width: int, height: int) -> np.ndarray:
        """Unit ray directions ``(H, W, 3)`` float32, row 0 at the top (the contract's formula).

        A slow numpy reference of what the shader computes per pixel.
        """
        width = check.integer(width, "width", 1, 1 << 14)
        height = check.integer(height, "height", 1, 1 << 14)
        f, r, u = self.basis()
        th = np.float32(math.tan(math.radians(self.fov) / 2))
        aspect = np.float32(width / height)
        j = np.arange(width, dtype=np.float32)
        i = np.arange(height, dtype=np.float32)
        x = (np.float32(2) * (j + np.float32(0.5)) / np.float32(width) - 1) * th * aspect
        y = (1 - np.float32(2) * (i + np.float32(0.5)) / np.float32(height)) * th
        d = f[None, None] + x[None, :, None] * r[None, None] + y[:, None, None] * u[None, None]
        return (d / np.linalg.norm(d, axis=-1, keepdims=True)).astype(np.float32)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)
