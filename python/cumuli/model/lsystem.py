"""L-system clouds (Jiménez de Parga & Gómez Palomo 2018, §3.6.2, eq. 18, Fig. 11).

`lsystem_expand` rewrites an axiom with a general grammar; `lsystem_cloud` interprets the string
with a 3D turtle (yaw, pitch, roll, turn around, push/pop) that places a sphere at every drawing
symbol, drawing a proportional random radius and step length per placement. The paper's grammar
``X → X+Y, Y → X&Y`` from ``X`` gives 2ⁿ spheres after n iterations (128 at 7).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from cumuli import _core
from cumuli._util import validate as check
from cumuli._util.structs import core_struct
from cumuli._util.validate import MAX_COORD
from cumuli.model.cloud import MAX_PRIMITIVES, Cloud

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
    length = int(_core.lsystem_length(axiom, rules, iterations)[0])
    if length < 2**64 - 1:
        return length
    return _exact_length(axiom, rules, iterations)  # the core saturates at 2⁶⁴ − 1


def _exact_length(axiom: str, rules: dict[str, str], iterations: int) -> int:
    """The length with Python integers: the symbol counts ``v`` after ``n`` rewrites are
    ``v₀ · Mⁿ`` (``M[a][b]`` = occurrences of ``b`` in the rewrite of ``a``), by squaring."""
    symbols = sorted(set(axiom) | set(rules) | set("".join(rules.values())))
    at = {c: i for i, c in enumerate(symbols)}
    k = len(symbols)
    m = [[0] * k for _ in range(k)]
    for c in symbols:
        for d in rules.get(c, c):
            m[at[c]][at[d]] += 1
    v = [0] * k
    for c in axiom:
        v[at[c]] += 1

    def times(a: list[list[int]], b: list[list[int]]) -> list[list[int]]:
        cols = list(zip(*b, strict=True))
        return [[sum(x * y for x, y in zip(row, col, strict=True)) for col in cols] for row in a]

    n = iterations
    while n:
        if n & 1:
            v = times([v], m)[0]
        n >>= 1
        if n:
            m = times(m, m)
    return sum(v)


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
        return check.pair(value, "angle", positive=False)
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
        "seed": check.seed(seed),
        "radius": list(check.pair(radius, "radius")),
        "step": list(check.pair(step, "step", positive=False)),
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
    turtle = core_struct(
        _core.TurtleParams,
        angle_lo=a_lo,
        angle_hi=a_hi,
        radius_lo=args["radius"][0],
        radius_hi=args["radius"][1],
        step_lo=args["step"][0],
        step_hi=args["step"][1],
        draw_symbols=draw_symbols,
        move_symbols=move_symbols,
        start=args["start"],
        heading=args["heading"],
        up=args["up"],
        seed=args["seed"],
        max_spheres=MAX_PRIMITIVES,
    )
    centres, radii, stats = _core.lsystem_interpret(symbols, turtle)
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
