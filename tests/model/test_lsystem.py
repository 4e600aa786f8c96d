"""L-system interpreter (§3.6.2): expansion counts, turtle geometry, jitter ranges, limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli
from cumuli.model.lsystem import PAPER_RULES

FIXED = {"radius": (1.0, 1.0), "step": (1.0, 1.0)}


def _reference_expand(axiom: str, rules: dict[str, str], n: int) -> str:
    s = axiom
    for _ in range(n):
        s = "".join(rules.get(c, c) for c in s)
    return s


@pytest.mark.parametrize("n", range(0, 9))
def test_paper_grammar_gives_two_to_the_n(n: int) -> None:
    s = cumuli.lsystem_expand("X", PAPER_RULES, n)
    assert s == _reference_expand("X", PAPER_RULES, n)
    assert s.count("X") + s.count("Y") == 2**n
    assert cumuli.lsystem_length("X", PAPER_RULES, n) == len(s)


def test_128_spheres_at_seven_iterations() -> None:
    c = cumuli.lsystem_cloud("X", PAPER_RULES, 7, angle=10, seed=2)
    assert c.n == 128 and c.stats["spheres"] == 128 and c.stats["turns"] == 127
    wide = cumuli.lsystem_cloud("X", PAPER_RULES, 7, angle=(50, 100), seed=2)
    assert wide.n == 128
    # Larger angles curl the chain up: a denser (smaller) cloud, as Fig. 12 describes.
    ext = lambda cl: np.ptp(cl.centres, axis=0).max()  # noqa: E731
    assert ext(wide) < ext(c)


def test_any_alphabet_and_empty_rules() -> None:
    rules = {"A": "AB", "B": "A", "Q": ""}
    s = cumuli.lsystem_expand("AQ", rules, 6)
    assert s == _reference_expand("AQ", rules, 6)
    assert len(s) == 21  # Fibonacci


def test_square_closes() -> None:
    c = cumuli.lsystem_cloud("F+F+F+F+F", {}, 0, angle=90, draw_symbols="F", **FIXED)
    p = c.centres.astype(np.float64)
    assert c.n == 5
    np.testing.assert_allclose(p[4], p[0], atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(np.diff(p, axis=0), axis=1), 1.0, atol=1e-5)
    # Heading +x, up +y: "+" yaws left, towards −z (left = up × heading).
    np.testing.assert_allclose(p[:4], [[0, 0, 0], [1, 0, 0], [1, 0, -1], [0, 0, -1]], atol=1e-5)


def test_pitch_and_roll_and_turn_around() -> None:
    kw = {"draw_symbols": "F", **FIXED}
    down = cumuli.lsystem_cloud("&FF", {}, 0, angle=90, **kw)
    np.testing.assert_allclose(down.centres[1], [0, -1, 0], atol=1e-5)
    # Roll 90° then yaw: yawing about the rolled up axis moves in y instead of z.
    rolled = cumuli.lsystem_cloud("/+FF", {}, 0, angle=90, **kw)
    assert abs(abs(rolled.centres[1][1]) - 1) < 1e-5 and abs(rolled.centres[1][2]) < 1e-5
    back = cumuli.lsystem_cloud("FF|FF", {}, 0, angle=90, **kw)
    np.testing.assert_allclose(back.centres[:, 0], [0, 1, 2, 1], atol=1e-5)


def test_brackets_restore_position_and_heading() -> None:
    c = cumuli.lsystem_cloud("F[+F&F]F", {}, 0, angle=37, draw_symbols="F", **FIXED)
    p = c.centres.astype(np.float64)
    # '[' is pushed at (1, 0, 0) heading +x; after ']' the last F places there again (F places
    # before it advances) and ends one step further along +x.
    np.testing.assert_allclose(p[3], [1, 0, 0], atol=1e-5)
    np.testing.assert_allclose(c.stats["final_position"], [2, 0, 0], atol=1e-5)
    np.testing.assert_allclose(c.stats["final_heading"], [1, 0, 0], atol=1e-6)
    assert c.stats["max_depth"] == 1


def test_move_only_symbol_advances_without_placing() -> None:
    c = cumuli.lsystem_cloud("FffF", {}, 0, draw_symbols="F", **FIXED)
    assert c.n == 2 and c.stats["moves"] == 2
    np.testing.assert_allclose(c.centres[1], [3, 0, 0], atol=1e-5)


def test_radius_step_and_angle_jitter_within_ranges() -> None:
    c = cumuli.lsystem_cloud(
        "X", PAPER_RULES, 8, angle=0, seed=5, radius=(0.5, 2.0), step=(0.7, 1.3)
    )
    r = c.radii[:, 0]
    assert (r >= 0.5).all() and (r <= 2.0).all() and r.std() > 0.2
    # With δ = 0 the chain is a straight line: gaps = r_i · s_i with s_i ∈ [0.7, 1.3].
    gaps = np.diff(c.centres[:, 0].astype(np.float64))
    ratio = gaps / r[:-1]
    assert (ratio >= 0.7 - 1e-4).all() and (ratio <= 1.3 + 1e-4).all() and ratio.std() > 0.05
    # A per-turn angle range: every yaw between consecutive steps within [50°, 100°].
    t = cumuli.lsystem_cloud(
        "F" + "+F" * 40, {}, 0, angle=(50, 100), seed=3, draw_symbols="F", **FIXED
    )
    d = np.diff(t.centres.astype(np.float64), axis=0)
    cosines = (d[1:] * d[:-1]).sum(axis=1)
    turn = np.degrees(np.arccos(np.clip(cosines, -1, 1)))
    assert (turn >= 50 - 1e-3).all() and (turn <= 100 + 1e-3).all() and turn.std() > 5


def test_same_seed_same_cloud() -> None:
    a = cumuli.lsystem_cloud(angle=(50, 100), seed=9)
    b = cumuli.lsystem_cloud(angle=(50, 100), seed=9)
    c = cumuli.lsystem_cloud(angle=(50, 100), seed=10)
    assert np.array_equal(a.centres, b.centres) and np.array_equal(a.radii, b.radii)
    assert not np.array_equal(a.centres, c.centres)


def test_expansion_over_limit_refused_before_allocating() -> None:
    with pytest.raises(ValueError, match="max_length"):
        cumuli.lsystem_expand("X", PAPER_RULES, 60)
    with pytest.raises(ValueError, match="2199023255551"):
        cumuli.lsystem_expand("X", PAPER_RULES, 40)
    with pytest.raises(ValueError, match="max_length"):
        cumuli.lsystem_cloud("X", {"X": "XXXXXXXX"}, 10_000)
    with pytest.raises(ValueError, match="intermediate"):
        cumuli.lsystem_expand("X", {"X": "AAAA", "A": ""}, 2, max_length=3)
    assert len(cumuli.lsystem_expand("X", PAPER_RULES, 10, max_length=2047)) == 2047


@pytest.mark.parametrize(
    "call,exc,word",
    [
        (lambda: cumuli.lsystem_expand("X", {"XY": "X"}, 2), ValueError, "rules"),
        (lambda: cumuli.lsystem_expand("X", {"X": 3}, 2), ValueError, "rules"),
        (lambda: cumuli.lsystem_expand("X", ["X"], 2), TypeError, "rules"),
        (lambda: cumuli.lsystem_expand(5, {}, 2), TypeError, "axiom"),
        (lambda: cumuli.lsystem_expand("X", {}, -1), ValueError, "iterations"),
        (lambda: cumuli.lsystem_expand("X", {}, 2.5), TypeError, "iterations"),
        (lambda: cumuli.lsystem_expand("é", {}, 1), ValueError, "ASCII"),
        (lambda: cumuli.lsystem_cloud(radius=(-1, 1)), ValueError, "radius"),
        (lambda: cumuli.lsystem_cloud(radius=(2, 1)), ValueError, "radius"),
        (lambda: cumuli.lsystem_cloud(step=(-1, 1)), ValueError, "step"),
        (lambda: cumuli.lsystem_cloud(angle=float("nan")), ValueError, "angle"),
        (lambda: cumuli.lsystem_cloud(heading=(0, 0, 0)), ValueError, "heading"),
        (lambda: cumuli.lsystem_cloud(heading=(0, 1, 0)), ValueError, "parallel"),
        (lambda: cumuli.lsystem_cloud(draw_symbols="Z"), ValueError, "no spheres"),
        (lambda: cumuli.lsystem_cloud(draw_symbols=""), ValueError, "draw_symbols"),
        (lambda: cumuli.lsystem_cloud(move_symbols="X"), ValueError, "both"),
        (lambda: cumuli.lsystem_cloud("X]X", {}, 0), ValueError, "unbalanced"),
        (lambda: cumuli.lsystem_cloud(seed=-2), ValueError, "seed"),
    ],
)
def test_bad_arguments(call, exc: type, word: str) -> None:
    with pytest.raises(exc, match=word):
        call()


# --- lsystem_length ---------------------------------------------------------------------------
def test_lsystem_length_is_exact_beyond_two_to_the_64() -> None:
    rules = {"X": "X+Y", "Y": "X&Y"}  # length 2^(n+1) − 1 after n iterations
    for n in (2, 10, 62, 63, 64, 65, 200, 5000):
        assert cumuli.lsystem_length("X", rules, n) == 2 ** (n + 1) - 1, n
    odd = {"A": "AB[C]", "B": "A", "C": "CC-"}
    for n in range(8):
        assert cumuli.lsystem_length("AC", odd, n) == len(cumuli.lsystem_expand("AC", odd, n))
    assert math.log2(cumuli.lsystem_length("AC", odd, 100)) > 64
