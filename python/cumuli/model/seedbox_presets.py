"""Basis-model presets for seed-and-box billboard clouds (spec §10; [TM] Figs. 10–12).

All in cumuli's cloud scale (a cumulus ≈ 20 units across), centred near the origin (a weather
layer or a `BillboardField` places them), deterministic for a seed:

- `cumulus`: the spec's default seed box size (4, 1.5, 3) grown along four sideways directions and
  up (3 levels, (1, 2) boxes per level and direction, reach 3: compact), shrinking children,
  flat base, 8–12 large faint billboards per box, "sunny" atlas.
- `cirrus`: Fig. 10, **15 thin wide seed boxes and exactly 50 billboards** (10 seed boxes with
  2 billboards per box and 5 with 1, each with one child), "wispy" atlas, flat wide sprites.
- `nimbus`: Fig. 11, dense: 2 levels, (3, 6) boxes, large billboards, "sunny" atlas.
- `rain`: Fig. 12, "rainy" atlas, wide and dense (2 levels, (2, 5) boxes, 6–10 billboards).

`max_distance(model)` is the spec's default D_max for a preset: 2 × the height of its seed-0
cloud's boxes.
"""

from __future__ import annotations

import functools

from cumuli.model.atlas import sprite_atlas
from cumuli.model.billboards import BasisModel, SeedBox, seed_box_cloud

NAMES = ("cumulus", "cirrus", "nimbus", "rain")


def cumulus(atlas_seed: int = 0) -> BasisModel:
    """A sunny cumulus: the spec's default seed box size, four sideways directions and one up
    (5 directions, 3 levels, (1, 2) boxes), reach 3 (compact: with the default reach ‖h‖ the
    upward boxes of level 3 float apart from the cloud), flat base; 8–12 large (1.2–2 × the
    box's mean half size), faint (opacity 0.55) billboards per box, which blend into a soft
    cloud where the defaults' fewer, smaller ones show as separate puffs."""
    seed = SeedBox(
        centre=(0.0, 0.0, 0.0),
        half_size=(4.0, 1.5, 3.0),
        directions=(
            (1.0, 0.25, 0.0),
            (-1.0, 0.25, 0.0),
            (0.0, 0.25, 1.0),
            (0.0, 0.25, -1.0),
            (0.0, 1.0, 0.0),
        ),
        apertures=(60.0, 60.0, 60.0, 60.0, 50.0),
        levels=3,
        boxes_per_level=(1, 2),
        reach=3.0,
        child_scale=(0.6, 1.0),
        billboards_per_box=(8, 12),
        flat_base=True,
    )
    return BasisModel(
        (seed,), atlas=sprite_atlas("sunny", seed=atlas_seed), billboard_size=(1.2, 2.0),
        opacity=0.55, name="cumulus",
    )  # fmt: skip


def cirrus(atlas_seed: int = 0) -> BasisModel:
    """Fig. 10: 15 thin wide seed boxes, 50 billboards in all: large (4–7 × the box's mean half
    size), flat, faint wispy sprites, so that few billboards make visible streaks."""
    seeds = []
    for j in range(15):
        # A loose diagonal band of streaks, fixed (the variation comes from the RNG seed).
        x = -42.0 + 6.0 * j
        z = 8.0 * ((j * 7) % 5 - 2) + 0.4 * x
        seeds.append(
            SeedBox(
                centre=(x, 0.3 * ((j * 3) % 4), z),
                half_size=(3.0, 0.3, 1.2),
                directions=((1.0, 0.0, 0.3),),
                apertures=(30.0,),
                levels=1,
                boxes_per_level=(1, 1),
                child_scale=(0.7, 1.0),
                billboards_per_box=(2, 2) if j < 10 else (1, 1),
            )
        )
    return BasisModel(
        tuple(seeds),
        atlas=sprite_atlas("wispy", seed=atlas_seed),
        billboard_size=(4.0, 7.0),
        aspect_min=0.35,
        rotate=False,
        opacity=0.5,
        name="cirrus",
    )


def nimbus(atlas_seed: int = 0) -> BasisModel:
    """Fig. 11: a dense cloud, 2 levels of (3, 6) boxes, large billboards."""
    seed = SeedBox(
        half_size=(6.0, 2.5, 5.0),
        directions=(
            (1.0, 0.1, 0.0),
            (-1.0, 0.1, 0.0),
            (0.0, 0.1, 1.0),
            (0.0, 0.1, -1.0),
            (0.0, 1.0, 0.0),
        ),  # fmt: skip
        apertures=(70.0, 70.0, 70.0, 70.0, 50.0),
        levels=2,
        boxes_per_level=(3, 6),
        child_scale=(0.6, 1.0),
        billboards_per_box=(5, 9),
        flat_base=True,
    )
    return BasisModel(
        (seed,), atlas=sprite_atlas("sunny", seed=atlas_seed), billboard_size=(1.2, 2.0),
        opacity=0.85, name="nimbus",
    )  # fmt: skip


def rain(atlas_seed: int = 0) -> BasisModel:
    """Fig. 12: a wide, dense, dark raining cloud."""
    seed = SeedBox(
        half_size=(7.0, 2.0, 6.0),
        directions=(
            (1.0, 0.0, 0.0),
            (-1.0, 0.0, 0.0),
            (0.0, 0.0, 1.0),
            (0.0, 0.0, -1.0),
            (0.0, 1.0, 0.0),
        ),  # fmt: skip
        apertures=(80.0, 80.0, 80.0, 80.0, 40.0),
        levels=2,
        boxes_per_level=(2, 5),
        child_scale=(0.6, 1.0),
        billboards_per_box=(6, 10),
        flat_base=True,
    )
    return BasisModel(
        (seed,), atlas=sprite_atlas("rainy", seed=atlas_seed), billboard_size=(1.0, 1.8),
        opacity=0.9, name="rain",
    )  # fmt: skip


def preset(name: str, atlas_seed: int = 0) -> BasisModel:
    """The preset called ``name`` (one of `NAMES`)."""
    if not isinstance(name, str) or name not in NAMES:
        raise ValueError(f"name must be one of {NAMES}, got {name!r}")
    return {"cumulus": cumulus, "cirrus": cirrus, "nimbus": nimbus, "rain": rain}[name](atlas_seed)


@functools.lru_cache(maxsize=64)
def _height(model: BasisModel) -> float:
    lo, hi = seed_box_cloud(model, seed=0).box_bounds()
    return float(hi[1] - lo[1])


def max_distance(model: BasisModel) -> float:
    """The spec's default D_max for a model: 2 × the box height of its seed-0 cloud."""
    if not isinstance(model, BasisModel):
        raise TypeError(f"model must be a BasisModel, got {type(model).__name__}")
    return 2.0 * _height(model)
