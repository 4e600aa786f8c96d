"""Iwasaki 2011 §2: similarity D, transition P, the endless walk and its cross-dissolves, and
the validation of its frames."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.anim.endless import default_sigma


def _database(n: int = 10, seed: int = 0) -> cu.VolumeDatabase:
    """A smooth 'animation': a blob moving along x plus a little noise."""
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.linspace(0, 1, 8),) * 3, indexing="ij")
    vols = [
        np.exp(-((x - 0.2 - 0.6 * k / n) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2) / 0.02)
        + 0.01 * rng.random(x.shape)
        for k in range(n)
    ]
    return cu.VolumeDatabase(np.array(vols, np.float32), (0, 0, 0), (1, 1, 1))


def test_similarity_matches_numpy_reference() -> None:
    db = _database(7)
    d = db.similarity()
    v = db.volumes.astype(np.float64).reshape(db.n, -1)
    ref = ((v[:, None, :] - v[None, :, :]) ** 2).sum(-1)
    assert d.shape == (7, 7) and d.dtype == np.float64
    np.testing.assert_allclose(d, ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(d, d.T)
    np.testing.assert_array_equal(np.diag(d), 0.0)
    one = cu.similarity_matrix(db.volumes, threads=1)
    np.testing.assert_array_equal(one, d)  # thread-count independent


def test_similarity_bad_input() -> None:
    with pytest.raises(ValueError):
        cu.similarity_matrix(np.zeros(5, np.float32))
    with pytest.raises(ValueError, match="NaN"):
        cu.similarity_matrix(np.full((2, 3), np.nan, np.float32))


def test_transition_rows_sum_to_one_and_favour_similar_successors() -> None:
    db = _database(10)
    d = db.similarity()
    sigma = default_sigma(d)
    p = cu.transition_matrix(db, sigma)
    np.testing.assert_allclose(p.sum(axis=1), 1.0, atol=1e-12)
    assert (p >= 0).all()
    n = db.n
    for k in range(n - 1):
        # The natural successor has D_{k+1,k+1} = 0: the most likely choice.
        assert p[k].argmax() == k + 1
        # The ordering follows D_{k+1, l}: more similar to k+1, more likely.
        order = np.argsort(d[k + 1])
        assert np.all(np.diff(p[k][order]) <= 1e-15)
        np.testing.assert_allclose(
            p[k], np.exp(-d[k + 1] / sigma) / np.exp(-d[k + 1] / sigma).sum()
        )
    # The last frame: l is likely when l − 1 resembles the last frame.
    assert p[n - 1, 0] == 0.0
    expect = np.exp(-d[n - 1, : n - 1] / sigma)
    np.testing.assert_allclose(p[n - 1, 1:], expect / expect.sum())


def test_transition_sigma_controls_jumps() -> None:
    d = _database(8).similarity()
    sharp = cu.transition_matrix(d, default_sigma(d, 0.01))
    soft = cu.transition_matrix(d, default_sigma(d, 10.0))
    assert np.diag(sharp, 1).min() > np.diag(soft, 1).max()


@pytest.mark.parametrize("sigma", [0.0, -1.0, np.nan])
def test_transition_bad_sigma(sigma: float) -> None:
    with pytest.raises(ValueError, match="sigma"):
        cu.transition_matrix(_database(4), sigma)


def test_transition_bad_similarity() -> None:
    with pytest.raises(ValueError, match="square"):
        cu.transition_matrix(np.zeros((3, 4)), 1.0)
    with pytest.raises(ValueError, match="non-negative"):
        cu.transition_matrix(-np.ones((3, 3)), 1.0)


def test_crossfade_weights() -> None:
    np.testing.assert_array_equal(cu.crossfade_weights(0), [])
    np.testing.assert_allclose(cu.crossfade_weights(1), [0.5])
    np.testing.assert_allclose(cu.crossfade_weights(3), [0.75, 0.5, 0.25])
    assert np.all(np.diff(cu.crossfade_weights(7)) < 0)


def _check_walk(frames: list[cu.AnimationFrame], n: int, h: int) -> None:
    """Every frame is the natural successor, a cut, or a step of a cross-dissolve."""
    weights = cu.crossfade_weights(h)
    prev = frames[0].source
    last = frames[0]
    t = 0
    for f in frames[1:]:
        assert 0 <= f.source < n and 0 <= f.target < n
        if f.crossfade:
            assert f.weight == pytest.approx(weights[t])
            if t == 0:
                assert f.source == prev + 1  # the source window starts at the successor
            else:
                assert (f.source, f.target) == (last.source + 1, last.target + 1)
            t += 1
            last = f
            if t == h:
                prev, t = f.target, 0
        else:
            assert t == 0 and f.weight == 1.0 and f.source == f.target
            if h > 0:
                assert f.source == prev + 1
            prev = f.source


@pytest.mark.parametrize("h", [0, 1, 3])
def test_walk_is_endless_and_well_formed(h: int) -> None:
    db = _database(12)
    anim = cu.EndlessAnimation(
        db, sigma=default_sigma(db.similarity(), 0.5), crossfade_frames=h, seed=3
    )
    frames = anim.frames(3000, densities=False)
    _check_walk(frames, db.n, h)
    live = anim.live
    assert not live[-1] or h == 0
    visited = {f.source for f in frames if not f.crossfade}
    assert all(live[v] for v in visited)
    if h:
        jumps = sum(1 for f in frames if f.crossfade) // h
    else:
        jumps = sum(1 for a, b in zip(frames, frames[1:], strict=False) if b.source != a.source + 1)
    assert jumps > 10  # it does loop back rather than stopping
    p = anim.transition_matrix
    np.testing.assert_allclose(p[live].sum(axis=1), 1.0, atol=1e-12)
    assert np.all(p[~live] == 0)


def test_walk_never_lands_on_dead_frames() -> None:
    db = _database(10)
    anim = cu.EndlessAnimation(db, crossfade_frames=2, seed=1)
    live = anim.live
    for _ in range(2000):
        anim.step()
        assert live[anim.current]


def test_walk_is_reproducible_from_its_seed() -> None:
    db = _database(10)
    a = [(f.source, f.target, f.weight) for f in cu.EndlessAnimation(db, seed=9).frames(300, False)]
    b = [(f.source, f.target, f.weight) for f in cu.EndlessAnimation(db, seed=9).frames(300, False)]
    c = [(f.source, f.target, f.weight) for f in cu.EndlessAnimation(db, seed=8).frames(300, False)]
    assert a == b
    assert a != c


def test_blended_frames_are_exact() -> None:
    db = _database(10)
    anim = cu.EndlessAnimation(
        db, sigma=default_sigma(db.similarity(), 1.0), crossfade_frames=2, seed=2
    )
    seen_fade = False
    for f in anim.frames(60):
        w = np.float32(f.weight)
        ref = w * db.volumes[f.source] + (np.float32(1) - w) * db.volumes[f.target]
        np.testing.assert_array_equal(f.density, ref)
        seen_fade |= f.crossfade
    assert seen_fade
    a, b = db.volumes[0], db.volumes[5]
    np.testing.assert_array_equal(cu.blend_volumes(a, b, 1.0), a)
    np.testing.assert_array_equal(cu.blend_volumes(a, b, 0.0), b)


def test_walk_bad_input() -> None:
    db = _database(6)
    with pytest.raises(ValueError, match="too short"):
        cu.EndlessAnimation(db, crossfade_frames=4)
    with pytest.raises(ValueError, match="dead-end"):
        cu.EndlessAnimation(db, crossfade_frames=1, start=5)
    with pytest.raises(ValueError, match="start"):
        cu.EndlessAnimation(db, start=6)
    with pytest.raises(ValueError, match="crossfade_frames"):
        cu.EndlessAnimation(db, crossfade_frames=-1)
    with pytest.raises(TypeError, match="database"):
        cu.EndlessAnimation(db.volumes)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="sigma"):
        cu.EndlessAnimation(db, sigma=0.0)
    with pytest.raises(ValueError, match="shape"):
        cu.blend_volumes(np.zeros(3), np.zeros(4), 0.5)
    with pytest.raises(ValueError, match="w"):
        cu.blend_volumes(np.zeros(3), np.zeros(3), 1.5)


# --- animation frames -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def anim() -> cu.EndlessAnimation:
    vols = np.random.default_rng(0).uniform(0, 1, (6, 4, 4, 4)).astype(np.float32)
    return cu.EndlessAnimation(cu.VolumeDatabase(vols, (0, 0, 0), (1, 1, 1)), crossfade_frames=1)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"source": -1, "weight": 5.0}, "source"),
        ({"weight": 5.0}, "weight"),
        ({"weight": float("nan")}, "weight"),
        ({"target": -2}, "target"),
        ({"index": -1}, "index"),
        ({"crossfade": "yes"}, "crossfade"),
        ({"source": 1.5}, "source"),
    ],
)
def test_animation_frames_are_validated(kwargs: dict, name: str) -> None:
    args = {"index": 0, "source": 0, "target": 1, "weight": 0.5, "crossfade": True, **kwargs}
    with pytest.raises((ValueError, TypeError), match=name):
        cu.AnimationFrame(**args)


def test_a_frame_outside_the_database_is_refused(anim: cu.EndlessAnimation) -> None:
    frame = cu.AnimationFrame(0, 99, 0, 1.0, False)
    with pytest.raises(ValueError, match="source"):
        anim.density(frame)
    frame = cu.AnimationFrame(0, 0, 6, 0.5, True)
    with pytest.raises(ValueError, match="target"):
        anim.density(frame)
    d = anim.density(cu.AnimationFrame(0, 0, 1, 0.25, True))
    assert d.max() <= anim.database.volumes.max()
