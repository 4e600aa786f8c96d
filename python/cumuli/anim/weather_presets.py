"""Weather presets: [TM] Table 1 (two layers, Fig. 14) and a three-layer sky (Fig. 13).

[TM] gives the counts of Table 1 but not heights, winds, area, billboard counts or textures; this
preset states its own in cumuli's cloud scale: a 1000-unit square; the higher layer at altitude
150 (thin wispy clouds 25–35 units long, wind 10 units/s along +x), the lower at 40 (sunny
cumulus → nimbus → rain, wind 6 units/s along +z); CV from 0 to 1 over 600 s; the background
darkens from the scene's sky to a hazy (CV 0.5) and a stormy grey sky (CV 1), and the sun dims
to 0.8 and 0.5 (beyond [TM]).

Winds: the spec suggests 2 and 1 units/s, but new clouds only enter with the wind (the inflow
quota is the steady-state flux), so the count can follow N*(CV) no faster than one transit time
W/|w| — 500 and 1000 s at those speeds, longer than the 600 s schedule, and Fig. 14's sky would
lag far behind Table 1. At 10 and 6 units/s the transits take 100 and 167 s.

| layer  | sky   | CV  | NBM | NM | NC  |
|--------|-------|-----|-----|----|-----|
| higher | Sky 1 | 0.0 | 1   | 10 | 50  |
| higher | Sky 2 | 0.5 | 1   | 10 | 100 |
| lower  | Sky 1 | 0.0 | 3   | 10 | 100 |
| lower  | Sky 2 | 0.5 | 3   | 10 | 200 |
| lower  | Sky 3 | 1.0 | 3   | 10 | 400 |
"""

from __future__ import annotations

from dataclasses import replace

from cumuli.anim.weather import CloudLayer, Schedule, SkyState, Weather
from cumuli.model.atlas import sprite_atlas
from cumuli.model.billboards import BasisModel, SeedBox
from cumuli.model.seedbox_presets import cirrus, cumulus, nimbus, rain
from cumuli.sky import Sky

#: Table 1 of [TM]: (layer, sky, cv, NBM, NM, NC).
TABLE1 = (
    ("higher", "Sky 1", 0.0, 1, 10, 50),
    ("higher", "Sky 2", 0.5, 1, 10, 100),
    ("lower", "Sky 1", 0.0, 3, 10, 100),
    ("lower", "Sky 2", 0.5, 3, 10, 200),
    ("lower", "Sky 3", 1.0, 3, 10, 400),
)


#: Background skies of the lower layer's grey and stormy states (beyond [TM]: the sky darkens with
#: CV; the sunny state keeps the scene's own sky).
HAZY = Sky(zenith=(0.3, 0.42, 0.66), horizon=(0.62, 0.68, 0.76), ground=(0.28, 0.28, 0.3))
STORMY = Sky(zenith=(0.3, 0.32, 0.37), horizon=(0.5, 0.52, 0.56), ground=(0.22, 0.22, 0.23))


def _wisp(scale: float, atlas_seed: int) -> BasisModel:
    """A small high cloud: one thin seed box with a few children along x."""
    seed = SeedBox(
        half_size=(4.0 * scale, 0.4, 1.6 * scale),
        directions=((1.0, 0.0, 0.2), (-1.0, 0.0, -0.2)),
        apertures=(30.0, 30.0),
        levels=2,
        boxes_per_level=(0, 2),
        child_scale=(0.6, 1.0),
        billboards_per_box=(2, 3),
    )
    return BasisModel(
        (seed,), atlas=sprite_atlas("wispy", seed=atlas_seed), billboard_size=(1.5, 2.5),
        aspect_min=0.35, rotate=False, opacity=0.6, name=f"wisp{scale:g}",
    )  # fmt: skip


def _scaled(model: BasisModel, factor: float, name: str) -> BasisModel:
    seeds = tuple(
        replace(s, half_size=tuple(h * factor for h in s.half_size), centre=s.centre)
        for s in model.seeds
    )
    return replace(model, seeds=seeds, name=name)


def table1(
    seed: int = 0,
    area: float = 1000.0,
    duration: float = 600.0,
    winds: tuple[tuple[float, float], tuple[float, float]] = ((10.0, 0.0), (0.0, 6.0)),
) -> Weather:
    """The two-layer climatic variation of Table 1 / Fig. 14 (see the module docstring);
    ``winds`` are the (higher, lower) layers' ``(w_x, w_z)``."""
    half = area / 2.0
    high = CloudLayer(
        altitude=150.0,
        thickness=10.0,
        wind=winds[0],
        states=(
            SkyState(0.0, (_wisp(3.0, 0),), variants=10, count=50, name="Sky 1"),
            SkyState(0.5, (_wisp(4.0, 1),), variants=10, count=100, name="Sky 2"),
        ),
        name="higher",
    )
    sunny = (
        cumulus(0),
        _scaled(cumulus(0), 0.7, "cumulus small"),
        _scaled(cumulus(0), 1.3, "cumulus large"),
    )
    grey = (
        nimbus(0),
        _scaled(nimbus(0), 0.7, "nimbus small"),
        _scaled(cumulus(1), 1.5, "cumulus towering"),
    )
    dark = (rain(0), _scaled(rain(0), 0.8, "rain small"), _scaled(rain(1), 1.2, "rain large"))
    low = CloudLayer(
        altitude=40.0,
        thickness=8.0,
        wind=winds[1],
        states=(
            SkyState(0.0, sunny, variants=10, count=100, name="Sky 1"),
            SkyState(
                0.5, grey, variants=10, count=200, sun_scale=0.8, background=HAZY, name="Sky 2"
            ),
            SkyState(
                1.0, dark, variants=10, count=400, sun_scale=0.5, background=STORMY, name="Sky 3"
            ),
        ),
        name="lower",
    )
    return Weather(
        area=((-half, -half), (half, half)),
        layers=[high, low],
        cv=Schedule([(0.0, 0.0), (duration, 1.0)]),
        seed=seed,
    )


def three_layers(seed: int = 0, cv: float = 0.3) -> Weather:
    """Fig. 13: three layers at different heights, each with its own wind."""
    layers = [
        CloudLayer(180.0, 10.0, (2.5, 0.5), (SkyState(0.0, (cirrus(0),), variants=4, count=6),),
                   name="high"),
        CloudLayer(90.0, 10.0, (-1.5, 1.0), (SkyState(0.0, (nimbus(0),), variants=6, count=40),),
                   name="middle"),
        CloudLayer(40.0, 8.0, (1.0, -0.5), (SkyState(0.0, (cumulus(0),), variants=10, count=120),),
                   name="low"),
    ]  # fmt: skip
    return Weather(((-500.0, -500.0), (500.0, 500.0)), layers, cv=cv, seed=seed)
