"""The viewer's camera and sun as the mouse and the sliders move them: an orbit around a target
(azimuth, elevation, distance), panning in the image plane, zoom; the sun by azimuth/elevation.

Angles are in degrees; azimuth turns about +y from +z towards +x, elevation is above the xz
plane (the package's +y up)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from cumuli.camera import Camera

#: Degrees of orbit per pixel of mouse motion.
DEGREES_PER_PIXEL = 0.4
#: The elevation stays inside ±MAX_ELEVATION so that ``up`` never meets the view direction.
MAX_ELEVATION = 89.0


def direction(azimuth: float, elevation: float) -> tuple[float, float, float]:
    """The unit vector at ``azimuth`` (from +z towards +x) and ``elevation`` (above xz)."""
    az, el = math.radians(azimuth), math.radians(elevation)
    return (math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az))


def angles(vector: tuple[float, float, float] | np.ndarray) -> tuple[float, float]:
    """``(azimuth, elevation)`` in degrees of a non-zero vector (inverse of `direction`)."""
    x, y, z = (float(v) for v in vector)
    return math.degrees(math.atan2(x, z)), math.degrees(math.atan2(y, math.hypot(x, z)))


@dataclass(frozen=True)
class Orbit:
    """A camera orbiting ``target`` at ``distance``, seen from ``azimuth``/``elevation``."""

    target: tuple[float, float, float]
    distance: float
    azimuth: float
    elevation: float
    fov: float = 50.0

    @classmethod
    def from_camera(cls, camera: Camera) -> Orbit:
        """The orbit that gives ``camera`` back (its roll aside: ``up`` is +y)."""
        offset = np.subtract(camera.position, camera.target, dtype=np.float64)
        az, el = angles(offset)
        el = max(-MAX_ELEVATION, min(MAX_ELEVATION, el))
        target = tuple(float(v) for v in camera.target)
        return cls(target, float(np.linalg.norm(offset)), az, el, float(camera.fov))  # type: ignore[arg-type]

    def camera(self) -> Camera:
        """The camera at this orbit."""
        offset = np.multiply(direction(self.azimuth, self.elevation), self.distance)
        return Camera(tuple(np.add(self.target, offset)), self.target, (0.0, 1.0, 0.0), self.fov)

    def rotated(self, dx: float, dy: float) -> Orbit:
        """Dragged by ``(dx, dy)`` pixels: right turns the camera left round the target, down
        raises it (the scene follows the mouse)."""
        el = self.elevation + DEGREES_PER_PIXEL * dy
        az = (self.azimuth - DEGREES_PER_PIXEL * dx + 180.0) % 360.0 - 180.0
        return replace(self, azimuth=az, elevation=max(-MAX_ELEVATION, min(MAX_ELEVATION, el)))

    def panned(self, dx: float, dy: float, height: int) -> Orbit:
        """Target and camera moved together in the image plane so that the point under the mouse
        follows it: ``(dx, dy)`` pixels in an image ``height`` pixels tall."""
        f, r, u = self.camera().basis()
        scale = 2.0 * self.distance * math.tan(math.radians(self.fov) / 2) / max(1, height)
        move = (-dx * scale) * r.astype(np.float64) + (dy * scale) * u.astype(np.float64)
        return replace(self, target=tuple(float(v) for v in np.add(self.target, move)))

    def zoomed(self, factor: float) -> Orbit:
        """The distance times ``factor`` (< 1 comes closer), kept within [1e-3, 1e6]."""
        if not (math.isfinite(factor) and factor > 0):
            raise ValueError(f"zoom factor must be finite and > 0, got {factor}")
        return replace(self, distance=min(1e6, max(1e-3, self.distance * factor)))
