"""Gaussian cumulus and the metaball preset (Jiménez de Parga & Gómez Palomo 2018, §3.6.1, §3.6.3).

* `gaussian_cumulus` — §3.6.1, Table 2, eqs. (15)–(17): primitives at clamped Gaussian offsets,
  radii by eq. (15) or (16), the hollow and containment filters.
* `metaball_cumulus` — §3.6.3, the small Gaussian preset of Fig. 13 with the metaball model.

Every generator runs in the C++ core and records in the returned cloud's ``params`` the exact
arguments it was called with (seed included, so ``generator(**cloud.params["args"])`` rebuilds
it) and in ``stats`` what each step did.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from cumuli import _core
from cumuli._util import validate as check
from cumuli._util.structs import core_struct
from cumuli._util.validate import MAX_COORD
from cumuli.model.cloud import Cloud

#: Most primitives the Gaussian generator draws (its containment filter is O(n²)).
MAX_GAUSSIAN_PRIMITIVES = 10_000
#: ε of each radius model when none is given: the paper's ε₁ = 15 (eq. 15) and ε₂ = 2.5 (eq. 16).
DEFAULT_EPSILON = {"eq15": 15.0, "eq16": 2.5}
#: Radius scale of each radius model when none is given. 2.9 with eq. (16) reproduces the authors'
#: cumuli (radii ≈ 6–7 for σ = (3.8, 1.7, 3.7)); eq. (15) already yields world-size radii.
DEFAULT_RADIUS_SCALE = {"eq15": 1.0, "eq16": 2.9, "uniform": 1.0}
RADIUS_MODELS = ("eq15", "eq16", "uniform")


def _clamps(value: Any) -> tuple[tuple[float, float], ...]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 3:
        raise TypeError(f"clamps must be three (lo, hi) pairs (x, y, z), got {value!r}")
    return tuple(check.pair(v, "clamps", positive=False) for v in value)


def _epsilon(value: Any, radius_model: str) -> float:
    if value is None:
        return DEFAULT_EPSILON.get(radius_model, 1.0)
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes)):
        if len(value) != 2:
            raise ValueError(f"epsilon must be a number or (eps15, eps16), got {value!r}")
        value = value[0] if radius_model == "eq15" else value[1]
    return check.real(value, "epsilon", 0.0, MAX_COORD, lo_open=True)


def _check_gaussian_reach(args: dict[str, Any]) -> None:
    """Refuse parameters whose products would carry centres or radii beyond ±MAX_COORD.

    Each is bounded on its own, but a centre lands anywhere in ``centre + mu + clamps · sigma``
    and a radius reaches ``epsilon · radius_scale`` (or ``radius_range · radius_scale``).
    """
    for k, axis in enumerate("xyz"):
        lo, hi = args["clamps"][k]
        reach = (
            abs(args["centre"][k]) + abs(args["mu"][k]) + max(abs(lo), abs(hi)) * args["sigma"][k]
        )
        if reach > MAX_COORD:
            raise ValueError(
                f"centre + mu + clamps * sigma reaches {reach:.3g} on {axis}, beyond the limit "
                f"±{MAX_COORD:g}: shrink sigma or clamps"
            )
    if args["radius_model"] == "uniform":
        biggest, what = args["radius_range"][1], "radius_range"
    else:
        biggest, what = args["epsilon"], "epsilon"
    if biggest * args["radius_scale"] > MAX_COORD:
        raise ValueError(
            f"{what} * radius_scale = {biggest * args['radius_scale']:.3g} exceeds the radius "
            f"limit {MAX_COORD:g}"
        )


def gaussian_cumulus(
    centre: Sequence[float] = (0.0, 0.0, 0.0),
    n: int = 35,
    mu: Sequence[float] = (0.0, 0.0, 0.0),
    sigma: Sequence[float] = (3.8, 1.7, 3.7),
    clamps: Sequence[Sequence[float]] = ((-2.0, 2.0), (0.0, 2.0), (-2.0, 2.0)),
    radius_model: str = "eq16",
    radius_scale: float | None = None,
    epsilon: float | Sequence[float] | None = None,
    eq16_combine: str = "sum",
    clamp_mode: str = "saturate",
    radius_range: Sequence[float] = (1.0, 1.0),
    hollow: bool = True,
    hollow_box: Sequence[float] = (0.75, 1.0 / 3.0, 0.75),
    remove_contained: bool = True,
    seed: int = 0,
    model: str = "spheroid",
    kappa: float = 0.5,
    phi: float = 0.6,
) -> Cloud:
    """A cumulus of spheres from a clamped 3D Gaussian (§3.6.1, Table 2, eqs. 15–17).

    Sphere ``i`` sits at ``centre + 𝒩(mu, sigma)`` per axis; each offset is clamped to
    ``[mu + lo·sigma, mu + hi·sigma]`` with ``clamps = ((lo_x, hi_x), (lo_y, hi_y), (lo_z, hi_z))``
    in units of sigma (Table 2 with k₁ = k₂ = t = m₁ = m₂ = 2 by default; ``lo_y = 0`` puts the
    base on the plane ``y = centre_y + mu_y``: a flat bottom). ``clamp_mode="saturate"`` moves an
    out-of-range draw onto the clamp (what makes the base flat and the hollow share ~20 % as in
    the paper); ``"resample"`` redraws it (a truncated normal).

    Radii (before ``radius_scale``, which multiplies them; ``None`` means 2.9 for eq. 16 and 1
    otherwise):

    * ``"eq16"`` (default): ``ε (1 − 0.1 √Σ_k (d_k / 2σ_k)²)`` with ``d = P − C``. The paper prints
      the three squared terms multiplied; the authors' implementation sums them (an ellipsoidal
      distance), which is the default here; ``eq16_combine="product"`` gives the printed formula.
      Radii are floored at 1 % of ε where the formula would turn negative (clamps beyond 10·2σ).
    * ``"eq15"``: ``ε / (|d_x| + |d_z| + 1)``.
    * ``"uniform"``: uniform in ``radius_range`` (the metaball preset).

    ``epsilon`` is ε of the chosen model (``None``: 15 for eq. 15, 2.5 for eq. 16; a pair
    ``(ε₁, ε₂)`` picks by model); every radius is ≤ ``radius_scale · ε``.

    Filters: ``hollow`` drops spheres whose offset from ``centre`` lies strictly inside the box of
    half extents ``hollow_box · sigma`` (the paper's ``(3σx/4, σy/3, 3σz/4)``); then
    ``remove_contained`` drops every sphere lying inside another (eq. 17:
    ``r_i − r_j ≥ |c_i − c_j|``). ``cloud.stats`` has ``drawn``, ``clamped``,
    ``removed_by_hollow``, ``removed_by_containment`` and ``kept``.

    Lengths and coordinates (``centre``, ``mu``, ``sigma``, ``epsilon``, ``radius_range``, and
    what they combine into: the clamp window ``centre + mu + clamps · sigma`` and the largest
    radius) must stay within ``±MAX_COORD`` (1e15), so that the float32 core cannot overflow.

    Raises ``ValueError`` when the filters leave no sphere (e.g. a tiny ``n``).
    """
    args: dict[str, Any] = {
        "centre": list(check.vec3(centre, "centre", bound=MAX_COORD)),
        "n": check.integer(n, "n", 1, MAX_GAUSSIAN_PRIMITIVES),
        "mu": list(check.vec3(mu, "mu", bound=MAX_COORD)),
        "sigma": list(check.vec3(sigma, "sigma", bound=MAX_COORD)),
        "clamps": [list(c) for c in _clamps(clamps)],
        "radius_model": check.choice(radius_model, "radius_model", RADIUS_MODELS),
        "radius_scale": None,
        "epsilon": None,
        "eq16_combine": check.choice(eq16_combine, "eq16_combine", ("sum", "product")),
        "clamp_mode": check.choice(clamp_mode, "clamp_mode", ("saturate", "resample")),
        "radius_range": list(check.pair(radius_range, "radius_range")),
        "hollow": check.flag(hollow, "hollow"),
        "hollow_box": list(check.vec3(hollow_box, "hollow_box", bound=MAX_COORD)),
        "remove_contained": check.flag(remove_contained, "remove_contained"),
        "seed": check.seed(seed),
        "model": model,
        "kappa": kappa,
        "phi": phi,
    }
    args["epsilon"] = _epsilon(epsilon, args["radius_model"])
    if radius_scale is None:
        radius_scale = DEFAULT_RADIUS_SCALE[args["radius_model"]]
    args["radius_scale"] = check.real(radius_scale, "radius_scale", 0.0, MAX_COORD, lo_open=True)
    if min(args["sigma"]) <= 0:
        raise ValueError(f"sigma must be positive on every axis, got {tuple(args['sigma'])}")
    if min(args["hollow_box"]) < 0:
        raise ValueError(f"hollow_box must be non-negative, got {tuple(args['hollow_box'])}")
    cl = args["clamps"]
    _check_gaussian_reach(args)
    params = core_struct(
        _core.GaussianCumulusParams,
        centre=args["centre"],
        n=args["n"],
        mu=args["mu"],
        sigma=args["sigma"],
        clamp_lo=[cl[0][0], cl[1][0], cl[2][0]],
        clamp_hi=[cl[0][1], cl[1][1], cl[2][1]],
        clamp_mode=args["clamp_mode"],
        radius_model=args["radius_model"],
        eq16_combine=args["eq16_combine"],
        epsilon=args["epsilon"],
        radius_scale=args["radius_scale"],
        radius_lo=args["radius_range"][0],
        radius_hi=args["radius_range"][1],
        hollow=args["hollow"],
        hollow_box=args["hollow_box"],
        remove_contained=args["remove_contained"],
        seed=args["seed"],
    )
    centres, radii, stats = _core.gaussian_cumulus(params)
    if centres.shape[0] == 0:
        raise ValueError(
            f"the filters removed all {stats['drawn']} spheres (n={args['n']}); "
            "raise n or pass hollow=False"
        )
    return Cloud(
        centres,
        radii,
        model=model,
        kappa=kappa,
        phi=phi,
        stats=dict(stats),
        params={"generator": "gaussian_cumulus", "args": args},
    )


def metaball_cumulus(
    centre: Sequence[float] = (0.0, 0.0, 0.0),
    n: int = 6,
    seed: int = 0,
    sigma: Sequence[float] = (1.6, 0.6, 1.4),
    radius_range: Sequence[float] = (0.9, 1.6),
    phi: float = 0.6,
) -> Cloud:
    """The paper's small metaball cumulus (§3.6.3, Fig. 13): a few Gaussian spheres, metaball model.

    ``n`` (about six) sphere centres from the clamped Gaussian of `gaussian_cumulus` (flat base,
    no hollow or containment filter: with so few spheres each one shapes the iso-surface
    ``Σ r_i² / |p − c_i|² ≥ 1``) and radii drawn uniformly in ``radius_range`` ("randomizing the
    sphere radius"). The returned cloud has ``model="metaball"`` and density
    ``fbm · r̄² · phi`` (eqs. 19–21).
    """
    cloud = gaussian_cumulus(
        centre=centre,
        n=n,
        sigma=sigma,
        radius_model="uniform",
        radius_range=radius_range,
        radius_scale=1.0,
        hollow=False,
        remove_contained=False,
        seed=seed,
        model="metaball",
        phi=phi,
    )
    cloud.params = {
        "generator": "metaball_cumulus",
        "args": {
            "centre": cloud.params["args"]["centre"],
            "n": cloud.params["args"]["n"],
            "seed": cloud.params["args"]["seed"],
            "sigma": cloud.params["args"]["sigma"],
            "radius_range": cloud.params["args"]["radius_range"],
            "phi": cloud.phi,
        },
    }
    return cloud
