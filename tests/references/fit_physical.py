"""Fit the physical mode's multiple-scattering constants to the Mitsuba 3 references.

The constants of ``cumuli.light.physical`` (the Poisson-weighted octaves ``OCTAVE_B``,
``OCTAVE_C``, ``OCTAVE_POISSON``, ``OCTAVE_A`` and the lattice gains ``SUN_GAIN``, ``SKY_GAIN``,
``GAIN_DEPTH``, the forward-scattered source's ``SUN_FORWARD``, the carried source's
``SUN_CARRIED`` and ``CARRIED_RATE`` and the view's ``FLUX_LIMIT``; ``OCTAVES`` held) are fitted
on the views of ``cumuli.light.physical.FIT_VIEWS`` alone, by a Nelder–Mead search from today's
values, on the CPU twin; the loss is the sum over those views of each error over its goal,
squared (cloud mean 5 %, block median 10 %, p90 25 %). The other views (``HELD_OUT_VIEWS``) are
only reported: they test the fit. Run::

    python tests/references/fit_physical.py [--iterations 120]

It prints the fitted constants and every view's errors with them (nothing is written: copy the
constants into ``python/cumuli/light/physical.py`` by hand, rounded).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

import cumuli as cu
from cumuli.light import memo
from cumuli.light import physical as phys

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import mitsuba_reference as mr  # noqa: E402
import mitsuba_views as mv  # noqa: E402

#: The fitted constants, in the search's order.
FITTED = (
    "OCTAVE_B",
    "OCTAVE_C",
    "OCTAVE_POISSON",
    "SUN_GAIN",
    "SKY_GAIN",
    "GAIN_DEPTH",
    "SUN_FORWARD",
    "FLUX_LIMIT",
    "OCTAVE_A",
    "SUN_CARRIED",
    "CARRIED_RATE",
)
#: Each constant's range (the search is clamped to it).
RANGES = {
    "OCTAVE_B": (0.0, 1.0),
    "OCTAVE_C": (0.05, 1.0),
    "OCTAVE_POISSON": (0.0, 4.0),
    "SUN_GAIN": (1.0, 4.0),
    "SKY_GAIN": (1.0, 6.0),
    "GAIN_DEPTH": (0.0, 8.0),
    "SUN_FORWARD": (0.0, 1.5),
    "FLUX_LIMIT": (0.0, 1.5),
    "OCTAVE_A": (0.0, 1.0),
    "SUN_CARRIED": (0.0, 1.0),
    "CARRIED_RATE": (0.05, 8.0),
}


def fitted() -> tuple[str, ...]:
    """:data:`FITTED` less ``OCTAVE_B`` where the orders' phase is the convolved one
    (``OCTAVE_PHASE``), which does not read it."""
    if phys.OCTAVE_PHASE == "convolved":
        return tuple(n for n in FITTED if n != "OCTAVE_B")
    return FITTED


GOAL = {"mean_ratio": 0.05, "block_median": 0.10, "block_p90": 0.25}


def sidelit_reference() -> np.ndarray:
    """The side-lit default's reference as RGBA (alpha the coverage ``1 − T``)."""
    ms = cu.read_image(HERE / mr.FILES["ms"])[..., :3]
    t = cu.read_image(HERE / mr.FILES["transmittance"])[..., :1]
    return np.concatenate([ms, 1.0 - t], -1)


def views() -> dict[str, tuple[Callable, Callable[[], np.ndarray]]]:
    """Name → (scene and camera, reference image) of every reference view."""
    out: dict[str, tuple[Callable, Callable[[], np.ndarray]]] = {
        "sidelit": (mr.reference_scene, sidelit_reference)
    }
    for name, make in mv.VIEWS.items():
        out[name] = (make, lambda name=name: cu.read_image(mv.view_file(name)))
    return out


def errors(names: Sequence[str], backend: str = "cpu") -> dict[str, dict[str, float]]:
    """``mitsuba_views.block_errors`` of each named view with today's constants."""
    memo.clear()  # the light step's memo does not know the constants
    table = views()
    out = {}
    for name in names:
        make, reference = table[name]
        scene, camera = make()
        img = cu.render(scene, camera, mv.WIDTH, mv.HEIGHT, backend=backend)
        out[name] = mv.block_errors(img, reference())
    return out


def loss(errs: dict[str, dict[str, float]]) -> float:
    """Σ over views and metrics of (error / goal)²."""
    return float(sum((abs(e[k]) / g) ** 2 for e in errs.values() for k, g in GOAL.items()))


def apply(x: Sequence[float]) -> None:
    for name, value in zip(fitted(), x, strict=True):
        lo, hi = RANGES[name]
        setattr(phys, name, float(min(max(value, lo), hi)))


def nelder_mead(f: Callable[[np.ndarray], float], x0: np.ndarray, iterations: int) -> np.ndarray:
    """A plain Nelder–Mead minimisation of ``f`` from ``x0`` (initial steps of 20 %)."""
    simplex = [x0] + [x0 + np.eye(len(x0))[i] * max(0.2 * abs(x0[i]), 0.1) for i in range(len(x0))]
    values = [f(x) for x in simplex]
    for _ in range(iterations):
        order = np.argsort(values)
        simplex, values = [simplex[i] for i in order], [values[i] for i in order]
        centre = np.mean(simplex[:-1], axis=0)
        reflected = centre + (centre - simplex[-1])
        fr = f(reflected)
        if fr < values[0]:
            expanded = centre + 2.0 * (centre - simplex[-1])
            fe = f(expanded)
            simplex[-1], values[-1] = (expanded, fe) if fe < fr else (reflected, fr)
        elif fr < values[-2]:
            simplex[-1], values[-1] = reflected, fr
        else:
            contracted = centre + 0.5 * (simplex[-1] - centre)
            fc = f(contracted)
            if fc < values[-1]:
                simplex[-1], values[-1] = contracted, fc
            else:  # shrink towards the best
                simplex = [simplex[0]] + [simplex[0] + 0.5 * (x - simplex[0]) for x in simplex[1:]]
                values = [values[0]] + [f(x) for x in simplex[1:]]
    return simplex[int(np.argmin(values))]


def report(errs: dict[str, dict[str, float]]) -> None:
    for name, e in errs.items():
        role = "fit" if name in phys.FIT_VIEWS else "held out"
        print(f"  {name:9s} ({role:8s}) mean {e['mean_ratio']:+7.1%}  median "
              f"{e['block_median']:6.1%}  p90 {e['block_p90']:6.1%}  "
              f"|ΔT| {e['transmittance']:.4f}", flush=True)  # fmt: skip


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=120)
    parser.add_argument("--octaves", type=int, default=phys.OCTAVES, help="orders drawn (held)")
    parser.add_argument("--start", default="", help="start values, e.g. OCTAVE_C=0.7,SUN_GAIN=2")
    args = parser.parse_args(argv)
    phys.OCTAVES = args.octaves
    for item in filter(None, args.start.split(",")):
        key, value = item.split("=")
        setattr(phys, key, float(value))
    x0 = np.array([getattr(phys, n) for n in fitted()], np.float64)

    def f(x: np.ndarray) -> float:
        apply(x)
        return loss(errors(phys.FIT_VIEWS))

    print("today's constants:", dict(zip(fitted(), x0.tolist(), strict=True)), flush=True)
    report(errors([*phys.FIT_VIEWS, *phys.HELD_OUT_VIEWS]))
    best = nelder_mead(f, x0, args.iterations)
    apply(best)
    values = {n: round(getattr(phys, n), 3) for n in fitted()}
    print("fitted:", values, f"loss {f(best):.3f} (today {f(x0):.3f})", flush=True)
    apply(best)
    report(errors([*phys.FIT_VIEWS, *phys.HELD_OUT_VIEWS]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
