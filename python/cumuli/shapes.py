"""Cloud shapes (Jiménez de Parga & Gómez Palomo 2018, §3.6): generators returning `Cloud`.

Every generator runs in the C++ core and records in the returned cloud's ``params`` the exact
arguments it was called with (seed included, so ``generator(**cloud.params["args"])`` rebuilds
it) and in ``stats`` what each step did.

* `gaussian_cumulus` — §3.6.1, Table 2, eqs. (15)–(17).
* `metaball_cumulus` — §3.6.3, the small Gaussian preset of Fig. 13 with the metaball model.
* `lsystem_expand` / `lsystem_cloud` — §3.6.2, a general L-system interpreter with a 3D turtle.
* `ellipsoids_from_mesh` / `mesh_cloud` — §3.6.4, one ellipsoid per triangle (eqs. 22–30).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli import _core
from cumuli import _validate as check
from cumuli._validate import MAX_COORD
from cumuli.cloud import MAX_PRIMITIVES, Cloud

#: Most primitives the Gaussian generator draws (its containment filter is O(n²)).
MAX_GAUSSIAN_PRIMITIVES = 10_000
#: ε of each radius model when none is given: the paper's ε₁ = 15 (eq. 15) and ε₂ = 2.5 (eq. 16).
DEFAULT_EPSILON = {"eq15": 15.0, "eq16": 2.5}
#: Radius scale of each radius model when none is given. 2.9 with eq. (16) reproduces the authors'
#: cumuli (radii ≈ 6–7 for σ = (3.8, 1.7, 3.7)); eq. (15) already yields world-size radii.
DEFAULT_RADIUS_SCALE = {"eq15": 1.0, "eq16": 2.9, "uniform": 1.0}
RADIUS_MODELS = ("eq15", "eq16", "uniform")


def _seed(seed: Any) -> int:
    return check.integer(seed, "seed", 0, 2**64 - 1)


def _choice(value: Any, name: str, options: Sequence[str]) -> str:
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name} must be one of {tuple(options)}, got {value!r}")
    return value


def _range(
    value: Any, name: str, *, positive: bool = True, bound: float | None = MAX_COORD
) -> tuple[float, float]:
    """A (lo, hi) pair of finite floats with lo <= hi, lo > 0 when ``positive``, |·| <= bound."""
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 2:
        raise TypeError(f"{name} must be a (lo, hi) pair, got {value!r}")
    floor = 0.0 if positive else (None if bound is None else -bound)
    lo = check.real(value[0], name, floor, bound, lo_open=positive)
    hi = check.real(value[1], name, floor, bound, lo_open=positive)
    if lo > hi:
        raise ValueError(f"{name} must have lo <= hi, got ({lo}, {hi})")
    return (lo, hi)


def _clamps(value: Any) -> tuple[tuple[float, float], ...]:
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or len(value) != 3:
        raise TypeError(f"clamps must be three (lo, hi) pairs (x, y, z), got {value!r}")
    return tuple(_range(v, "clamps", positive=False) for v in value)


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
        "radius_model": _choice(radius_model, "radius_model", RADIUS_MODELS),
        "radius_scale": None,
        "epsilon": None,
        "eq16_combine": _choice(eq16_combine, "eq16_combine", ("sum", "product")),
        "clamp_mode": _choice(clamp_mode, "clamp_mode", ("saturate", "resample")),
        "radius_range": list(_range(radius_range, "radius_range")),
        "hollow": bool(hollow),
        "hollow_box": list(check.vec3(hollow_box, "hollow_box", bound=MAX_COORD)),
        "remove_contained": bool(remove_contained),
        "seed": _seed(seed),
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
    centres, radii, stats = _core.gaussian_cumulus(
        args["centre"],
        args["n"],
        args["mu"],
        args["sigma"],
        [cl[0][0], cl[1][0], cl[2][0]],
        [cl[0][1], cl[1][1], cl[2][1]],
        args["clamp_mode"],
        args["radius_model"],
        args["eq16_combine"],
        args["epsilon"],
        args["radius_scale"],
        args["radius_range"][0],
        args["radius_range"][1],
        args["hollow"],
        args["hollow_box"],
        args["remove_contained"],
        args["seed"],
    )
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


# --- L-systems (§3.6.2) ---------------------------------------------------------------------

#: The paper's grammar (eq. 18): from axiom "X", 2ⁿ spheres after n iterations.
PAPER_RULES = {"X": "X+Y", "Y": "X&Y"}
#: Default cap on the expanded string's length (symbols).
DEFAULT_MAX_LENGTH = 1_000_000
#: Largest ``max_length`` accepted (the core keeps two strings of that many symbols).
MAX_LENGTH_LIMIT: int = int(_core.LSYSTEM_MAX_LENGTH)
#: Most rewrites accepted.
MAX_ITERATIONS = 100_000


def _lsystem_grammar(axiom: Any, rules: Any, iterations: Any) -> tuple[str, dict[str, str], int]:
    if not isinstance(axiom, str):
        raise TypeError(f"axiom must be a str, got {type(axiom).__name__}")
    if not axiom.isascii():
        raise ValueError("axiom must be ASCII")
    if not isinstance(rules, dict):
        raise TypeError(
            f"rules must be a dict of symbol -> replacement, got {type(rules).__name__}"
        )
    clean: dict[str, str] = {}
    for key, value in rules.items():
        if not isinstance(key, str) or len(key) != 1 or not key.isascii():
            raise ValueError(f"rules: every key must be one ASCII symbol, got {key!r}")
        if not isinstance(value, str) or not value.isascii():
            raise ValueError(f"rules[{key!r}] must be an ASCII str, got {value!r}")
        clean[key] = value
    return axiom, clean, check.integer(iterations, "iterations", 0, MAX_ITERATIONS)


def lsystem_length(axiom: str, rules: dict[str, str], iterations: int) -> int:
    """Number of symbols `lsystem_expand` would produce, computed without expanding."""
    axiom, rules, iterations = _lsystem_grammar(axiom, rules, iterations)
    return int(_core.lsystem_length(axiom, rules, iterations)[0])


def lsystem_expand(
    axiom: str, rules: dict[str, str], iterations: int, max_length: int = DEFAULT_MAX_LENGTH
) -> str:
    """Rewrite ``axiom`` ``iterations`` times with ``rules`` (in parallel, any ASCII alphabet).

    ``rules`` maps single symbols to replacement strings; symbols without a rule are copied. The
    length of the result (and of every intermediate string) is computed before anything is
    allocated; over ``max_length`` symbols raises ``ValueError``.

    >>> lsystem_expand("X", {"X": "X+Y", "Y": "X&Y"}, 2)
    'X+Y+X&Y'
    """
    axiom, rules, iterations = _lsystem_grammar(axiom, rules, iterations)
    max_length = check.integer(max_length, "max_length", 1, MAX_LENGTH_LIMIT)
    return _core.lsystem_expand(axiom, rules, iterations, max_length)


def _angle(value: Any) -> tuple[float, float]:
    if isinstance(value, Sequence) and not isinstance(value, (str, bytes)):
        return _range(value, "angle", positive=False)
    a = check.real(value, "angle")
    return (a, a)


def lsystem_cloud(
    axiom: str = "X",
    rules: dict[str, str] | None = None,
    iterations: int = 7,
    angle: float | Sequence[float] = 10.0,
    seed: int = 0,
    radius: Sequence[float] = (0.6, 1.0),
    step: Sequence[float] = (0.8, 1.2),
    draw_symbols: str = "XY",
    move_symbols: str = "f",
    start: Sequence[float] = (0.0, 0.0, 0.0),
    heading: Sequence[float] = (1.0, 0.0, 0.0),
    up: Sequence[float] = (0.0, 1.0, 0.0),
    max_length: int = DEFAULT_MAX_LENGTH,
    model: str = "spheroid",
    kappa: float = 0.5,
    phi: float = 0.6,
) -> Cloud:
    """A cloud of spheres from an L-system walked by a 3D turtle (§3.6.2, eq. 18, Figs. 11–12).

    The grammar (default: the paper's ``X → X+Y, Y → X&Y`` from ``X``, 2ⁿ spheres after n
    iterations) is expanded by `lsystem_expand`, then a turtle starting at ``start`` with
    ``heading`` and ``up`` reads it (angles in degrees):

    ``+``/``-`` yaw left/right about up, ``&``/``^`` pitch down/up about left (= up × heading),
    ``\\``/``/`` roll left/right about heading, ``|`` turn around, ``[``/``]`` push/pop the
    position and orientation.

    Each symbol of ``draw_symbols`` draws a radius ``r`` uniformly in ``radius``, places a sphere
    of radius ``r`` at the turtle, and advances ``r · s`` with ``s`` uniform in ``step`` (the
    paper's proportional random radius and length per placement, Fig. 11). Symbols in
    ``move_symbols`` (default ``"f"``) advance the same way without placing. ``angle`` is δ: a
    number, or a ``(lo, hi)`` range drawn per turn (Fig. 12b uses ``(50, 100)``). Other symbols
    are ignored by the turtle.

    ``stats`` holds ``symbols``, ``spheres``, ``turns``, ``moves``, ``max_depth``.

    ``start``, ``radius`` and ``step`` must stay within ``±MAX_COORD`` (1e15), and so must the
    farthest the turtle could walk (``|start| + moves · radius_hi · step_hi``), so that the
    float32 core cannot overflow.
    """
    if rules is None:
        rules = dict(PAPER_RULES)
    axiom, rules, iterations = _lsystem_grammar(axiom, rules, iterations)
    for name, value in (("draw_symbols", draw_symbols), ("move_symbols", move_symbols)):
        if not isinstance(value, str) or not value.isascii():
            raise TypeError(f"{name} must be an ASCII str, got {value!r}")
    if not draw_symbols:
        raise ValueError("draw_symbols must not be empty")
    args: dict[str, Any] = {
        "axiom": axiom,
        "rules": rules,
        "iterations": iterations,
        "angle": list(_angle(angle)) if not isinstance(angle, (int, float)) else float(angle),
        "seed": _seed(seed),
        "radius": list(_range(radius, "radius")),
        "step": list(_range(step, "step", positive=False)),
        "draw_symbols": draw_symbols,
        "move_symbols": move_symbols,
        "start": list(check.vec3(start, "start", bound=MAX_COORD)),
        "heading": list(check.direction(heading, "heading")),
        "up": list(check.direction(up, "up")),
        "max_length": check.integer(max_length, "max_length", 1, MAX_LENGTH_LIMIT),
        "model": model,
        "kappa": kappa,
        "phi": phi,
    }
    if args["step"][0] < 0:
        raise ValueError(f"step must be non-negative, got {tuple(args['step'])}")
    a_lo, a_hi = _angle(angle)
    symbols = lsystem_expand(axiom, rules, iterations, args["max_length"])
    moves = sum(symbols.count(c) for c in set(draw_symbols + move_symbols))
    reach = max(map(abs, args["start"])) + moves * args["radius"][1] * args["step"][1]
    if reach > MAX_COORD:
        raise ValueError(
            f"radius * step over {moves} moves lets the turtle reach {reach:.3g} from the origin, "
            f"beyond the limit ±{MAX_COORD:g}: shrink radius or step"
        )
    centres, radii, stats = _core.lsystem_interpret(
        symbols,
        a_lo,
        a_hi,
        args["radius"][0],
        args["radius"][1],
        args["step"][0],
        args["step"][1],
        draw_symbols,
        move_symbols,
        args["start"],
        args["heading"],
        args["up"],
        args["seed"],
        MAX_PRIMITIVES,
    )
    if centres.shape[0] == 0:
        raise ValueError(
            f"the L-system placed no spheres: none of draw_symbols {draw_symbols!r} occurs in "
            f"the expansion of {axiom!r}"
        )
    stats = dict(stats)
    stats["final_position"] = list(stats["final_position"])
    stats["final_heading"] = list(stats["final_heading"])
    return Cloud(
        centres,
        radii,
        model=model,
        kappa=kappa,
        phi=phi,
        stats=stats,
        params={"generator": "lsystem_cloud", "args": args},
    )


# --- Mesh → ellipsoids (§3.6.4) -------------------------------------------------------------


def _default_min_radius(vertices: np.ndarray) -> float:
    """1e-4 of the mesh's bounding-box diagonal (1e-6 for a single point)."""
    diag = float(np.linalg.norm(vertices.max(axis=0).astype(np.float64) - vertices.min(axis=0)))
    return 1e-4 * diag if diag > 0 else 1e-6


def ellipsoids_from_mesh(
    vertices: Any,
    faces: Any,
    scale: float = 1.0,
    rotate: bool = True,
    min_radius: float | None = None,
    threads: int = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One ellipsoid per triangle (§3.6.4, eqs. 22–30); returns ``(centres, radii, rotations)``.

    For a triangle ``(P1, P2, P3)`` with barycentre ``B`` (eq. 22), the vertices are scaled about
    ``B`` by ``scale`` ∈ (0, 2] (eq. 23), and the radii along the local x, y, z axes are the
    distances ``|B − P'i|`` (eq. 24). With ``rotate`` the longest local axis is turned onto the
    direction of the farthest scaled vertex by Rodrigues' formula (eqs. 25–30); otherwise the
    rotations are the identity. Radii are floored at ``min_radius`` (default 1e-4 of the mesh's
    bounding-box diagonal) so degenerate triangles give small valid ellipsoids, never NaN.

    ``vertices`` is ``(V, 3)`` real with components within ``±MAX_COORD`` (1e15), ``faces``
    ``(F, 3)`` integer indices into it. Arrays are
    float32 ``(F, 3)``, ``(F, 3)`` and ``(F, 3, 3)`` (rotation columns are the ellipsoid axes).
    """
    from cumuli.meshes import _mesh_arrays

    verts, f = _mesh_arrays(vertices, faces)
    if f.shape[0] > MAX_PRIMITIVES:
        raise ValueError(f"faces: {f.shape[0]} faces, more than a cloud holds ({MAX_PRIMITIVES})")
    scale = check.real(scale, "scale", 0.0, 2.0, lo_open=True)
    if min_radius is None:
        min_radius = _default_min_radius(verts)
    min_radius = check.real(min_radius, "min_radius", 0.0, MAX_COORD, lo_open=True)
    centres, radii, rotations, _ = _core.ellipsoids_from_mesh(
        verts, f, scale, bool(rotate), min_radius, check.threads(threads)
    )
    return centres, radii, rotations


def mesh_cloud(
    source: Any,
    scale: float = 1.0,
    target_faces: int | None = None,
    rotate: bool = True,
    min_radius: float | None = None,
    model: str = "spheroid",
    kappa: float = 0.5,
    phi: float = 0.6,
    threads: int = 0,
) -> Cloud:
    """A cloud of ellipsoids from a triangle mesh (§3.6.4, Figs. 14–15).

    ``source`` is a path (OBJ, PLY, STL, OFF, GLB/GLTF, read by `cumuli.meshes.load_mesh`), a
    ``trimesh.Trimesh`` or a ``(vertices, faces)`` pair. With ``target_faces`` the mesh is first
    decimated to about that many faces by trimesh's quadric decimation (the paper uses 300–700;
    needs the ``fast-simplification`` package); meshes already that small are kept. Then one
    ellipsoid per face, see `ellipsoids_from_mesh`.

    ``params`` records the source (path, or a SHA-256 of the arrays) and the arguments; ``stats``
    has ``faces_in``, ``faces`` (after decimation) and ``floored_faces`` (degenerate triangles).
    """
    from cumuli.meshes import _mesh_arrays, load_mesh

    if isinstance(source, (str, os.PathLike)):
        verts, f = load_mesh(source)
        origin: Any = os.fspath(source)
    else:
        if hasattr(source, "vertices") and hasattr(source, "faces"):
            pair = (source.vertices, source.faces)
        elif isinstance(source, (tuple, list)) and len(source) == 2:
            pair = (source[0], source[1])
        else:
            raise TypeError(
                "source must be a path, a trimesh.Trimesh or a (vertices, faces) pair, "
                f"got {type(source).__name__}"
            )
        verts, f = _mesh_arrays(*pair)
        digest = hashlib.sha256(verts.tobytes() + f.tobytes()).hexdigest()
        origin = {"sha256": digest, "vertices": int(verts.shape[0]), "faces": int(f.shape[0])}
    faces_in = int(f.shape[0])
    if target_faces is not None:
        target_faces = check.integer(target_faces, "target_faces", 4, MAX_PRIMITIVES)
        if target_faces < faces_in:
            verts, f = _decimate(verts, f, target_faces)
    if min_radius is None:
        min_radius = _default_min_radius(verts)
    scale = check.real(scale, "scale", 0.0, 2.0, lo_open=True)
    min_radius = check.real(min_radius, "min_radius", 0.0, MAX_COORD, lo_open=True)
    centres, radii, rotations, core_stats = _core.ellipsoids_from_mesh(
        verts, f, scale, bool(rotate), min_radius, check.threads(threads)
    )
    return Cloud(
        centres,
        radii,
        rotations,
        model=model,
        kappa=kappa,
        phi=phi,
        stats={
            "faces_in": faces_in,
            "faces": int(core_stats["faces"]),
            "floored_faces": int(core_stats["floored_faces"]),
        },
        params={
            "generator": "mesh_cloud",
            "args": {
                "source": origin,
                "scale": scale,
                "target_faces": target_faces,
                "rotate": bool(rotate),
                "min_radius": min_radius,
                "model": model,
                "kappa": kappa,
                "phi": phi,
            },
        },
    )


def _decimate(verts: np.ndarray, faces: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Quadric decimation to about ``target`` faces through trimesh (fast-simplification)."""
    import trimesh

    from cumuli.meshes import _mesh_arrays

    mesh = trimesh.Trimesh(vertices=verts, faces=faces, process=False)
    try:
        small = mesh.simplify_quadric_decimation(face_count=target)
    except ImportError as exc:
        raise ImportError(
            "target_faces needs the fast-simplification package (pip install fast-simplification)"
        ) from exc
    if len(small.faces) == 0:
        raise ValueError(f"decimation to {target} faces left no triangles")
    return _mesh_arrays(np.asarray(small.vertices), np.asarray(small.faces))
