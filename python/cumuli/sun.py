"""The sun: a direction towards it, a colour and an intensity (DESIGN §3)."""

from __future__ import annotations

from dataclasses import dataclass

from cumuli import _validate as check


@dataclass(frozen=True)
class Sun:
    """Directional light. ``direction`` points from the scene towards the sun (normalised here);
    light travels along ``-direction``."""

    direction: tuple[float, float, float] = (0.3, 0.8, 0.2)
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    intensity: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "direction", check.direction(self.direction, "sun.direction"))
        colour = check.vec3(self.colour, "sun.colour")
        if min(colour) < 0:
            raise ValueError(f"sun.colour must be non-negative, got {colour}")
        object.__setattr__(self, "colour", colour)
        object.__setattr__(self, "intensity", check.real(self.intensity, "sun.intensity", 0.0))

    @property
    def radiance(self) -> tuple[float, float, float]:
        """colour × intensity, what the renderer multiplies the light grid by."""
        return tuple(c * self.intensity for c in self.colour)  # type: ignore[return-value]
