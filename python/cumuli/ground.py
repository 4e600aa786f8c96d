"""The ground: an optional Lambertian plane under the clouds (RENDER_CONTRACT, "Ground").

``cumuli.Ground(height, albedo)`` in ``Scene.ground`` is the background of every camera ray
that meets the plane ``y = height`` from above (the sky's elsewhere), lit by the sun through
every cloud (a shadow map made by the light step, :func:`cumuli.shadow_map`) and by the sky:
``L = albedo/π · (E_sun·max(sun.y, 0)·T_shadow + E_sky)``. Both lighting modes and both backends
draw it, in the single-pass marcher and in the compositor.
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from cumuli._util import validate as check
from cumuli.sky import Sky, Sun


@dataclass(frozen=True)
class Ground:
    """A horizontal Lambertian plane ``y = height`` with diffuse ``albedo`` (one grey value or
    linear RGB, each in [0, 1])."""

    height: float = 0.0
    albedo: Any = (0.3, 0.3, 0.3)

    def __post_init__(self) -> None:
        object.__setattr__(self, "height", check.real(self.height, "ground.height", -1e6, 1e6))
        albedo = self.albedo
        if isinstance(albedo, (int, float, np.integer, np.floating)) and not isinstance(
            albedo, bool
        ):
            albedo = (albedo, albedo, albedo)
        rgb = check.vec3(albedo, "ground.albedo")
        if min(rgb) < 0 or max(rgb) > 1:
            raise ValueError(f"ground.albedo must be in [0, 1], got {rgb}")
        object.__setattr__(self, "albedo", rgb)

    def to_dict(self) -> dict[str, Any]:
        return {"height": self.height, "albedo": list(self.albedo)}

    @classmethod
    def from_dict(cls, data: Any, where: str = "ground") -> Ground:
        if not isinstance(data, dict):
            raise ValueError(f"{where} must be a JSON object, got {type(data).__name__}")
        unknown = sorted(set(data) - {"height", "albedo"})
        if unknown:
            raise ValueError(f"{where} has unknown field(s): {', '.join(unknown)}")
        try:
            return cls(**data)
        except (TypeError, ValueError) as exc:
            raise type(exc)(f"{where}: {exc}") from None


@functools.lru_cache(maxsize=64)
def sky_irradiance(sky: Sky) -> tuple[float, float, float]:
    """The sky's irradiance on a horizontal plane, ``∫ L_sky(ω)·cosθ dω`` over the upper
    hemisphere (``Sky.radiance``, midpoint rule in cosθ and φ: 256 × 64 directions)."""
    n_mu, n_phi = 256, 64
    mu = (np.arange(n_mu) + 0.5) / n_mu
    phi = 2 * np.pi * (np.arange(n_phi) + 0.5) / n_phi
    s = np.sqrt(1 - mu * mu)[:, None]
    d = np.stack(
        [s * np.cos(phi)[None], mu[:, None] * np.ones((1, n_phi)), s * np.sin(phi)[None]], -1
    ).reshape(-1, 3)
    rad = sky.radiance(d.astype(np.float32)).astype(np.float64).reshape(n_mu, n_phi, 3)
    e = (rad * mu[:, None, None]).sum(axis=(0, 1)) * (1.0 / n_mu) * (2 * math.pi / n_phi)
    return tuple(float(v) for v in e)  # type: ignore[return-value]


def ground_radiance_unshadowed(ground: Ground, sky: Sky, sun: Sun) -> tuple[float, float, float]:
    """The ground's radiance where no cloud shades it (the lower hemisphere the physical mode's
    clouds see when the scene has a ground)."""
    e_sky = sky_irradiance(sky)
    lit = max(sun.direction[1], 0.0)
    return tuple(  # type: ignore[return-value]
        a / math.pi * (r * lit + e)
        for a, r, e in zip(ground.albedo, sun.radiance, e_sky, strict=True)
    )


def ground_args(ground: Ground | None, sky: Sky, shadow: Any = None) -> dict[str, Any] | None:
    """The core's ground dict (None without a ground); ``shadow`` a :class:`cumuli.ShadowMap`."""
    if ground is None:
        return None
    out: dict[str, Any] = {
        "height": float(ground.height),
        "albedo": ground.albedo,
        "sky_irradiance": sky_irradiance(sky),
    }
    if shadow is not None:
        out["shadow"] = shadow.values
        out["extent"] = tuple(float(v) for v in shadow.extent)
    return out


def ground_dict(ground: Ground) -> dict[str, Any]:
    """JSON form (for scene files)."""
    return asdict(ground)
