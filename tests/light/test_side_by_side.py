"""Clouds lit side by side: `prepare_light` runs the physical light passes of a scene's media
in whole rounds of one cloud per core, sharing the memo, and gives the same light as one cloud
after another; the memo makes a value once however many threads ask for it."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

import cumuli as cu
from cumuli.light import memo
from cumuli.light import physical as phys
from cumuli.light import prepare as prep

SETTINGS = cu.RenderSettings(physical_resolution=16)
SUN = cu.Sun(direction=(0.45, 0.75, 0.5))


def _scene(count: int) -> cu.Scene:
    """``count`` cumulus clouds one behind the other towards the sun, each shading the next."""
    base = cu.gaussian_cumulus(seed=1)
    lo, hi = base.layer_box()
    along = np.asarray(SUN.direction) * 1.2 * float(np.max(np.asarray(hi) - np.asarray(lo)))
    clouds = [
        cu.gaussian_cumulus(seed=1 + k).translated(tuple(float(v) for v in k * along))
        for k in range(count)
    ]
    return cu.Scene(clouds, sun=SUN, noise=cu.Noise(seed=7, size=32), settings=SETTINGS)


def _one_after_another(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(prep, "_side_by_side", lambda todo, kinds, physical, threads: ([], todo))


@pytest.mark.parametrize("count", [2, 3])
def test_side_by_side_light_is_the_light_one_after_another(
    count: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    scene = _scene(count)
    memo.clear()
    together = prep.prepare_light(scene, threads=2, progress=False)
    # The split: whole rounds of two side by side, a last odd cloud alone on both cores.
    kinds = [cu.registry.of(c) for c in scene.clouds]
    side, alone = prep._side_by_side(list(range(count)), kinds, True, 2)
    assert side == list(range(count - count % 2)) and alone == list(range(count - count % 2, count))
    memo.clear()
    _one_after_another(monkeypatch)
    apart = prep.prepare_light(scene, threads=2, progress=False)
    memo.clear()
    shaded = 0
    for a, b in zip(together.lights, apart.lights, strict=True):
        np.testing.assert_array_equal(a.sun_depth, b.sun_depth)
        np.testing.assert_array_equal(a.grid, b.grid)
        assert (a.upstream is None) == (b.upstream is None)
        if a.upstream is not None:
            np.testing.assert_array_equal(a.upstream, b.upstream)
            shaded += int(a.upstream.max() > 0)
    assert shaded >= 1  # the clouds do shade each other: the shared sun lattices were read


def test_what_goes_side_by_side() -> None:
    scene = _scene(1).replace(clouds=[_scene(1).clouds[0]] * 5)
    kinds = [cu.registry.of(c) for c in scene.clouds]
    todo = list(range(5))
    assert prep._side_by_side(todo, kinds, True, 2) == ([0, 1, 2, 3], [4])
    assert prep._side_by_side(todo, kinds, True, 1) == ([], todo)  # one core: nothing to share
    assert prep._side_by_side(todo, kinds, True, 8) == ([], todo)  # fewer clouds than cores
    assert prep._side_by_side(todo, kinds, False, 2) == ([], todo)  # the paper mode: as before
    particles = cu.ParticleCloud(np.zeros((4, 3), np.float32), np.full(4, 0.5, np.float32))
    mixed = [cu.registry.of(particles), *kinds[:3]]  # particles keep their own pass
    assert prep._side_by_side([0, 1, 2, 3], mixed, True, 2) == ([1, 2], [0, 3])


def test_an_error_side_by_side_names_its_cloud(monkeypatch: pytest.MonkeyPatch) -> None:
    scene = _scene(2)
    real = phys.physical_light

    def refuse_second(drawable, sc, *a, **k):
        if drawable is scene.clouds[1]:
            raise ValueError("refused")
        return real(drawable, sc, *a, **k)

    monkeypatch.setattr(phys, "physical_light", refuse_second)
    memo.clear()
    with pytest.raises(ValueError, match=r"scene\.clouds\[1\]: refused"):
        prep.prepare_light(scene, threads=2, progress=False)
    assert not memo.pending  # nothing left half made
    memo.clear()


def test_the_memo_makes_a_value_once_for_many_threads() -> None:
    memo.clear()
    made = []
    started = threading.Event()

    def make() -> int:
        started.set()
        time.sleep(0.05)  # the other threads ask while it is being made
        made.append(1)
        return 42

    got: list[int] = []

    def ask() -> None:
        got.append(memo.remember(("side by side test",), make))

    first = threading.Thread(target=ask)
    first.start()
    started.wait()
    others = [threading.Thread(target=ask) for _ in range(3)]
    for t in others:
        t.start()
    for t in [first, *others]:
        t.join()
    assert got == [42] * 4 and len(made) == 1 and not memo.pending
    memo.clear()


def test_a_failed_make_leaves_the_memo_to_try_again() -> None:
    memo.clear()

    def fail() -> int:
        raise ValueError("no")

    with pytest.raises(ValueError, match="no"):
        memo.remember(("failing test",), fail)
    assert not memo.pending
    assert memo.remember(("failing test",), lambda: 7) == 7
    memo.clear()


def test_a_deck_and_clouds_side_by_side(monkeypatch: pytest.MonkeyPatch) -> None:
    """A deck over two cumuli (it shades them) and a volume: every medium kind of the physical
    pass, lit side by side, gives the light of one after another."""
    deck = cu.CloudDeck(
        base=20.0, top=30.0, extent=(-40.0, -40.0, 40.0, 40.0), coverage=0.6, sigma_t=0.8,
        detail_scale=8.0, map_scale=30.0, map_size=32, resolution=(24, 6, 24), seed=2,
    )  # fmt: skip
    volume = cu.VolumeCloud(
        np.random.default_rng(3).random((8, 8, 8)).astype(np.float32),
        ((-30.0, 0.0, -30.0), (-24.0, 6.0, -24.0)),
    )
    clouds = [
        deck,
        cu.gaussian_cumulus(seed=1),
        cu.gaussian_cumulus(seed=2).translated((12, 0, 0)),
        volume,
    ]
    scene = cu.Scene(clouds, sun=SUN, noise=cu.Noise(seed=7, size=32), settings=SETTINGS)
    memo.clear()
    together = prep.prepare_light(scene, threads=2, progress=False)
    memo.clear()
    _one_after_another(monkeypatch)
    apart = prep.prepare_light(scene, threads=2, progress=False)
    memo.clear()
    for a, b in zip(together.lights, apart.lights, strict=True):
        np.testing.assert_array_equal(a.grid, b.grid)
        np.testing.assert_array_equal(a.total_depth(), b.total_depth())
    assert together.lights[1].upstream is not None  # the deck shades the cumulus under it


def test_the_sun_lattices_go_first_and_are_marched_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """`prepare_light` marches every medium's own sun lattice before the passes that read them
    (one march per cloud, none for a light memoised or given), and each lattice once."""
    scene = _scene(3)
    kinds = [cu.registry.of(c) for c in scene.clouds]
    memo.clear()
    todo = [0, 1, 2]
    assert [k for k, _ in prep._marches(scene, todo, kinds, [None] * 3)] == todo
    # A given light needs no lattice of its own.
    assert [k for k, _ in prep._marches(scene, todo, kinds, [None, object(), None])] == [0, 2]
    # More media than the memo keeps until their passes read them: each pass marches its own.
    monkeypatch.setattr(memo, "MEMO_SIZE", 5)
    assert prep._marches(scene, todo, kinds, [None] * 3) == []
    monkeypatch.undo()
    marched = []
    real = cu._core.light_space_depth

    def counted(*args, **kwargs):
        marched.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(cu._core, "light_space_depth", counted)
    lit = prep.prepare_light(scene, threads=2, progress=False)
    assert len(marched) == 3
    assert any(light.upstream is not None for light in lit.lights)  # read by those they shade
    # Lit already: nothing to march again.
    assert prep._marches(scene, todo, kinds, [None] * 3) == []
    prep.prepare_light(scene, threads=2, progress=False)
    assert len(marched) == 3
    memo.clear()


def test_an_error_in_a_sun_lattice_names_its_cloud(monkeypatch: pytest.MonkeyPatch) -> None:
    scene = _scene(2)
    real = cu._core.light_space_depth
    calls = []

    def refuse_second(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise ValueError("no lattice")
        return real(*args, **kwargs)

    monkeypatch.setattr(cu._core, "light_space_depth", refuse_second)
    memo.clear()
    with pytest.raises(ValueError, match=r"scene\.clouds\[\d\]: no lattice"):
        prep.prepare_light(scene, threads=2, progress=False)
    assert not memo.pending
    memo.clear()


def test_known_is_what_the_memo_holds() -> None:
    memo.clear()
    assert not memo.known(("known test",))
    memo.remember(("known test",), lambda: 1)
    assert memo.known(("known test",))
    assert not memo.known(("known test", "other"))
    memo.clear()
    assert not memo.known(("known test",))
