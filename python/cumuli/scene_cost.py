"""What a scene's dict (a scene file's JSON) will cost to build and light, estimated from the
dict alone, before anything is built: each kind's own cost (:attr:`cumuli.registry.Kind.cost`:
a billboard atlas rebuilt from its recipe, a field's drawn billboards, a deck's baked volume),
the noise lattice, the 2018 clouds' light grids and the physical mode's light.

A malformed entry costs nothing here: building it refuses it with its own error.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import Any

from cumuli import registry
from cumuli._util import budget
from cumuli.settings import RenderSettings

#: Bytes per voxel of a 2018 cloud's light grid (float32) and of the noise lattice (float32).
LIGHT_GRID_BYTES_PER_VOXEL = 4
NOISE_BYTES_PER_VOXEL = 4


def _int(value: Any, default: int) -> int:
    return value if isinstance(value, int) and not isinstance(value, bool) else default


def _settings(data: Mapping[str, Any]) -> RenderSettings:
    given = data.get("settings")
    if not isinstance(given, Mapping):
        return RenderSettings()
    names = {f.name for f in fields(RenderSettings)}
    try:
        return RenderSettings(**{k: v for k, v in given.items() if k in names})
    except (TypeError, ValueError):
        return RenderSettings()  # its own error comes when the scene is built


def scene_items(data: Any) -> list[tuple[str, int]]:
    """``(what, bytes)`` of everything building and lighting the scene dict ``data`` costs
    beyond the bytes its file holds (a recipe named by several clouds counted once)."""
    if not isinstance(data, Mapping):
        return []
    items: dict[Any, tuple[str, int]] = {}
    counts: dict[str, int] = {}
    clouds = data.get("clouds")
    for entry in clouds if isinstance(clouds, list) else []:
        kind = registry.get(entry.get("kind", "cloud")) if isinstance(entry, Mapping) else None
        if kind is None or not isinstance(kind.name, str):
            continue
        counts[kind.name] = counts.get(kind.name, 0) + 1
        if kind.cost is not None:
            for key, what, cost in kind.cost(entry):
                items.setdefault(key, (what, cost))
    noise = data.get("noise")
    size = _int(noise.get("size", 64), 64) if isinstance(noise, Mapping) else 64
    items["noise"] = (f"the noise lattice (size={size})", size**3 * NOISE_BYTES_PER_VOXEL)
    settings = _settings(data)
    if settings.lighting == "physical":
        media = sum(n for name, n in counts.items() if (k := registry.get(name)) and k.medium)
        memory, _ = settings.physical_cost(media)
        res = settings.physical_resolution
        items["physical"] = (f"the physical light (physical_resolution={res})", memory)
    elif counts.get("cloud"):
        res, n = settings.light_resolution, counts["cloud"]
        items["grids"] = (
            f"{n} light grid(s) (light_resolution={res})",
            n * res**3 * LIGHT_GRID_BYTES_PER_VOXEL,
        )
    return list(items.values())


def check_scene(data: Any, where: str, limit: int, setting: str = "") -> None:
    """Refuse the scene dict ``data`` when what it costs to build (`scene_items`) is over
    ``limit`` bytes; the message names ``where``, the largest items, the cost and the budget."""
    items = scene_items(data)
    total = sum(cost for _, cost in items)
    if total <= limit:
        return
    grouped: dict[str, list[int]] = {}
    for what, cost in items:
        grouped.setdefault(what, []).append(cost)
    rows = sorted(grouped.items(), key=lambda row: -sum(row[1]))
    shown = ", ".join(
        f"{len(costs)} × {what}: {budget.amount(sum(costs))}" if len(costs) > 1
        else f"{what}: {budget.amount(costs[0])}"
        for what, costs in rows[:3]
    )  # fmt: skip
    more = f" and {len(rows) - 3} more" if len(rows) > 3 else ""
    budget.check_memory(f"{where} ({shown}{more})", total, limit, setting)
