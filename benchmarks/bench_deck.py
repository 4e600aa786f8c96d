"""What a cloud deck costs, stage by stage, and what marching its medium at its own step saves.

The demo's stratocumulus deck (``cumuli.demo.deck_scene``: 24 × 24 km, 1.2–1.9 km, a
192 × 24 × 192 lattice; 64 × 12 × 64 with ``--quick``) is timed through every stage: baking its
lattice (C++), its light in the paper mode (the volume light of the lattice: Iwasaki 2011's sun,
SH sky and multiple scattering) and in the physical mode, the ground's shadow map, and the draw
on GL and on the C++ twin at 320 × 200 (160 × 100 quick). The shadow map (256², 64² quick) is
timed twice in one run: with the deck's own march step (half a lattice cell, ``Medium.step``)
and with the settings' ``light_step`` (0.1 units, what every medium used before), as a ratio.
The wind: the light step (light and ground shadow, physical) of the deck blown at 15 m/s, a
first frame from nothing against each next second's frame (the wind carries the whole deck: its
time-0 light and shadow, moved), as a ratio.
Writes ``deck.json`` and ``deck.png`` under ``benchmarks/out/`` (or ``--out``).
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.demo import deck_scene  # noqa: E402
from cumuli.light.prepare import clear_memo, scene_shadow  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    machine = common.machine_info()
    quick = args.quick
    repeats = 2 if quick else 5
    width, height = (160, 100) if quick else (320, 200)
    base = deck_scene()
    deck = base.clouds[0]
    if quick:
        deck = dataclasses.replace(deck, resolution=(64, 12, 64))
    shadow_resolution = 64 if quick else 256
    scenes = {
        mode: base.replace(
            clouds=[deck],
            settings=cu.RenderSettings(lighting=mode, shadow_resolution=shadow_resolution),
        )
        for mode in ("paper", "physical")
    }
    common.log(f"GL renderer: {machine['gl_renderer']}; deck lattice {deck.resolution}")

    def fresh(d: cu.CloudDeck) -> cu.CloudDeck:
        return dataclasses.replace(d)  # a new object: its lattice is baked again

    def light(mode: str):
        def run() -> None:
            clear_memo()
            cu.prepare_light(scenes[mode].replace(ground=None), progress=False)

        return run

    own = scenes["physical"]
    kind = cu.registry.get("deck")
    stages = {
        "bake": lambda: fresh(deck).density_lattice(),
        "light_paper": light("paper"),
        "light_physical": light("physical"),
    }
    times = {name: common.time_repeats(fn, repeats)[0] for name, fn in stages.items()}

    def shadow() -> None:
        clear_memo()
        scene_shadow(own)

    times["shadow_own_step"] = common.time_repeats(shadow, repeats)[0]
    # The same map with the deck marched at settings.light_step (the registry's record swapped).
    plain = dataclasses.replace(kind, medium=dataclasses.replace(kind.medium, step=None))
    registry_table = cu.registry._KINDS
    registry_table["deck"] = plain
    try:
        times["shadow_light_step"] = common.time_repeats(shadow, 1 if quick else 2, warmup=0)[0]
    finally:
        registry_table["deck"] = kind
    # The wind: a first frame from nothing, then one second later each time (nothing relit).
    windy = dataclasses.replace(deck, wind=(15.0, 0.0))

    def windy_scene(t: float) -> cu.Scene:
        return own.replace(clouds=[windy.at(t)])

    def first_frame() -> None:
        clear_memo()
        cu.prepare_light(windy_scene(0.0), progress=False)

    times["wind_first_frame"] = common.time_repeats(first_frame, repeats)[0]
    clock = [0.0]

    def next_frame() -> None:
        clock[0] += 1.0
        cu.prepare_light(windy_scene(clock[0]), progress=False)

    times["wind_next_frame"] = common.time_repeats(next_frame, repeats)[0]
    lit = {mode: cu.prepare_light(sc, progress=False) for mode, sc in scenes.items()}
    with cu.Renderer() as renderer:
        for mode in lit:
            for backend in ("gl", "cpu"):

                def draw(mode: str = mode, backend: str = backend) -> None:
                    if backend == "gl":
                        renderer.render(lit[mode], base.camera, width, height)
                    else:
                        cu.render_cpu(lit[mode], base.camera, width, height)

                times[f"draw_{mode}_{backend}"] = common.time_repeats(draw, repeats)[0]
    spreads = {name: common.spread(t) for name, t in times.items()}
    for name, s in spreads.items():
        common.log(f"{name}: {1e3 * s['median']:.1f} ms (min {1e3 * s['min']:.1f})")
    ratio = spreads["shadow_light_step"]["median"] / spreads["shadow_own_step"]["median"]
    common.log(f"shadow map: the deck's own step is {ratio:.1f}x faster than light_step")
    wind = spreads["wind_first_frame"]["median"] / spreads["wind_next_frame"]["median"]
    common.log(f"wind: a next frame's light step is {wind:.0f}x faster than the first's")
    data = {
        "benchmark": "deck",
        "quick": quick,
        "machine": machine,
        "lattice": list(deck.resolution),
        "image": [width, height],
        "shadow_resolution": shadow_resolution,
        "seconds": spreads,
        "ratios": {
            "shadow_light_step_over_own_step": ratio,
            "wind_first_frame_over_next_frame": wind,
        },
    }
    common.write_json(args.out / "deck.json", data)
    plt = common.pyplot()
    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    names = list(spreads)
    ax.barh(names, [spreads[n]["median"] for n in names])
    ax.set_xscale("log")
    ax.set_xlabel("seconds (median)")
    ax.set_title(f"cloud deck {tuple(deck.resolution)}, {width}×{height}")
    fig.savefig(args.out / "deck.png", dpi=100)
    return 0


if __name__ == "__main__":
    sys.exit(main())
