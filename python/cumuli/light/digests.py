"""What the light and the shadow of a drawable depend on, as hashable keys for the light step's
memo: each kind says it in its registration (:class:`cumuli.registry.Kind`)."""

from __future__ import annotations

from typing import Any

from cumuli import registry
from cumuli.light.memo import content_digest

__all__ = ["content_digest", "drawable_digest", "shadow_digest"]


def drawable_digest(drawable: Any) -> tuple:
    """What a drawable's light depends on, as a hashable key."""
    return registry.of(drawable).light_digest(drawable)


def shadow_digest(drawable: Any) -> tuple:
    """What a drawable's shadow depends on (for a particle cloud, whose light does not depend
    on where it is, also where it is)."""
    return registry.of(drawable).shadow_key(drawable)
