"""Hypothesis property tests on the C++ shape entry points: no crash, no NaN for finite input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import cumuli
from cumuli import _core
from cumuli._util.structs import core_struct

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
finite = st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False, width=32)
positive = st.floats(1e-3, 1e3, allow_nan=False, allow_infinity=False)


@SETTINGS
@given(
    data=st.data(),
    n_vertices=st.integers(1, 30),
    n_faces=st.integers(1, 40),
    scale=st.floats(1e-3, 2.0),
    rotate=st.booleans(),
)
def test_mesh_random_arrays(
    data, n_vertices: int, n_faces: int, scale: float, rotate: bool
) -> None:
    v = data.draw(hnp.arrays(np.float32, (n_vertices, 3), elements=finite))
    f = data.draw(hnp.arrays(np.int64, (n_faces, 3), elements=st.integers(0, n_vertices - 1)))
    c, r, rot = cumuli.ellipsoids_from_mesh(v, f, scale=scale, rotate=rotate)
    for a in (c, r, rot):
        assert np.isfinite(a).all()
    assert (r > 0).all()
    np.testing.assert_allclose(np.linalg.det(rot.astype(np.float64)), 1.0, atol=1e-4)


def test_mesh_of_subnormal_extent_gets_a_valid_default_radius() -> None:
    """A mesh whose bounding box is a subnormal float32 (2e−42): its default floor on the radii,
    1e−4 of the diagonal, would round to 0 in float32; it is held at the smallest normal."""
    v = np.array([[2.17e-42, 0, 0], [0, 0, 0]], np.float32)
    c, r, rot = cumuli.ellipsoids_from_mesh(v, np.array([[0, 0, 0]]), rotate=False)
    assert (r >= np.finfo(np.float32).tiny).all() and np.isfinite(c).all()


@SETTINGS
@given(
    data=st.data(),
    n_vertices=st.integers(1, 10),
    bad=st.sampled_from(["negative", "too_big"]),
)
def test_mesh_bad_indices_always_refused(data, n_vertices: int, bad: str) -> None:
    v = np.zeros((n_vertices, 3), np.float32)
    f = np.zeros((3, 3), np.int64)
    f[data.draw(st.integers(0, 2)), data.draw(st.integers(0, 2))] = (
        -data.draw(st.integers(1, 2**62)) if bad == "negative" else n_vertices
    )
    with pytest.raises(ValueError, match="faces"):
        _core.ellipsoids_from_mesh(v, f, 1.0, True, 1e-4)


@SETTINGS
@given(
    centre=st.tuples(finite, finite, finite),
    n=st.integers(1, 200),
    mu=st.tuples(finite, finite, finite).map(lambda t: tuple(x / 100 for x in t)),
    sigma=st.tuples(positive, positive, positive),
    lo=st.floats(-5, 0),
    hi=st.floats(0, 5),
    model=st.sampled_from(["eq15", "eq16", "uniform"]),
    combine=st.sampled_from(["sum", "product"]),
    mode=st.sampled_from(["saturate", "resample"]),
    seed=st.integers(0, 2**64 - 1),
)
def test_gaussian_core_random_parameters(
    centre, n, mu, sigma, lo, hi, model, combine, mode, seed
) -> None:
    c, r, stats = _core.gaussian_cumulus(
        core_struct(
            _core.GaussianCumulusParams, centre=list(centre), n=n, mu=list(mu),
            sigma=list(sigma), clamp_lo=[lo, lo, lo], clamp_hi=[hi, hi, hi], clamp_mode=mode,
            radius_model=model, eq16_combine=combine, epsilon=2.5, radius_scale=1.0,
            radius_lo=0.5, radius_hi=1.5, hollow=True, hollow_box=[0.75, 0.33, 0.75],
            remove_contained=True, seed=seed,
        )
    )  # fmt: skip
    assert np.isfinite(c).all() and np.isfinite(r).all() and (r > 0).all()
    assert stats["drawn"] == n
    assert (
        stats["kept"] == len(c) == n - stats["removed_by_hollow"] - stats["removed_by_containment"]
    )


@SETTINGS
@given(
    axiom=st.text(alphabet="XYF+-&^\\/|f[]AB", max_size=8),
    rules=st.dictionaries(
        st.sampled_from(list("XYFAB")), st.text(alphabet="XYF+-&^\\/|fAB", max_size=6), max_size=4
    ),
    iterations=st.integers(0, 6),
    angle_lo=st.floats(-360, 360),
    spread=st.floats(0, 90),
    seed=st.integers(0, 2**64 - 1),
)
def test_lsystem_random_grammars(axiom, rules, iterations, angle_lo, spread, seed) -> None:
    expected = cumuli.lsystem_length(axiom, rules, iterations)
    if expected > 20000:
        with pytest.raises(ValueError, match="max_length"):
            cumuli.lsystem_expand(axiom, rules, iterations, max_length=20000)
        return
    s = cumuli.lsystem_expand(axiom, rules, iterations, max_length=20000)
    assert len(s) == expected
    try:
        c, r, stats = _core.lsystem_interpret(
            s,
            core_struct(
                _core.TurtleParams, angle_lo=angle_lo, angle_hi=angle_lo + spread,
                radius_lo=0.5, radius_hi=1.0, step_lo=0.5, step_hi=1.5, draw_symbols="XYF",
                move_symbols="f", start=[0, 0, 0], heading=[1, 0, 0], up=[0, 1, 0], seed=seed,
                max_spheres=1 << 20,
            ),
        )  # fmt: skip
    except ValueError as exc:  # only unbalanced brackets may be refused
        assert "unbalanced" in str(exc)
        return
    assert np.isfinite(c).all() and ((r >= 0.5) & (r <= 1.0)).all()
    assert len(c) == sum(s.count(ch) for ch in "XYF")
