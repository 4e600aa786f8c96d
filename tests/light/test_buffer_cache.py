"""The light step's buffer cache (cumuli._util.buffer_cache): the core keeps the blocks of 64 KiB
or more it frees and hands them out again, so that a second light step makes no memory afresh,
without changing a value, without ever handing out a block an array still holds, and within its
limit."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator

import numpy as np
import pytest

import cumuli as cu
from cumuli.light import physical as phys
from cumuli.light.prepare import clear_memo

SETTINGS = cu.RenderSettings(physical_resolution=32)  # lattices of 32³ floats: 128 KiB and up


def _scene(seed: int = 1) -> cu.Scene:
    return cu.Scene(
        [cu.gaussian_cumulus(seed=seed)], noise=cu.Noise(seed=7, size=32), settings=SETTINGS
    )


def _light(sc: cu.Scene) -> dict[str, np.ndarray]:
    """The physical light of the scene's cloud from nothing memoised: its arrays."""
    clear_memo()
    light = phys.physical_light(sc.clouds[0], sc, threads=2)
    return {"grid": light.grid, "sun_depth": light.sun_depth, "anisotropy": light.anisotropy}


@pytest.fixture
def cache_limit() -> Iterator[None]:
    """Puts the process's limit back after the test."""
    previous = cu.set_buffer_cache_limit(64 << 20)
    yield
    cu.set_buffer_cache_limit(previous)


def test_a_second_light_step_reuses_every_block(cache_limit: None) -> None:
    sc = _scene()
    _light(sc)
    before = cu.buffer_cache_stats()
    _light(sc)
    after = cu.buffer_cache_stats()
    assert after["hits"] > before["hits"] + 10  # the lattices, sources, solves, results
    assert after["misses"] == before["misses"]  # nothing made afresh
    assert 0 < after["idle_bytes"] <= after["limit_bytes"]


def test_the_cache_changes_no_value(cache_limit: None) -> None:
    sc = _scene()
    cu.set_buffer_cache_limit(0)
    assert cu.buffer_cache_stats()["idle_bytes"] == 0
    fresh = _light(sc)
    cu.set_buffer_cache_limit(64 << 20)
    _light(_scene(seed=3))  # fill the cache with another cloud's blocks
    reused = _light(sc)
    for name, a in fresh.items():
        np.testing.assert_array_equal(reused[name], a, err_msg=name)


def test_blocks_held_by_arrays_are_never_handed_out(cache_limit: None) -> None:
    held = _light(_scene())
    kept = {k: v.copy() for k, v in held.items()}
    for seed in (2, 3):  # more light steps, each reusing what the cache holds
        _light(_scene(seed=seed))
    cu.release_buffer_cache()
    _light(_scene(seed=4))
    for name, a in kept.items():
        np.testing.assert_array_equal(held[name], a, err_msg=name)


def test_the_limit_bounds_what_is_kept(cache_limit: None) -> None:
    cu.set_buffer_cache_limit("1M")
    _light(_scene())
    stats = cu.buffer_cache_stats()
    assert stats["limit_bytes"] == 1 << 20
    assert stats["idle_bytes"] <= 1 << 20
    assert cu.set_buffer_cache_limit(0) == 1 << 20
    assert cu.buffer_cache_stats()["idle_blocks"] == 0


def test_release_gives_back_every_idle_block(cache_limit: None) -> None:
    _light(_scene())
    idle = cu.buffer_cache_stats()["idle_bytes"]
    assert idle > 0
    assert cu.release_buffer_cache() == idle
    stats = cu.buffer_cache_stats()
    assert stats["idle_bytes"] == 0 and stats["idle_blocks"] == 0
    assert stats["limit_bytes"] == 64 << 20  # still on


@pytest.mark.parametrize(
    ("limit", "error"),
    [(-1, ValueError), ("lots", ValueError), ("-5M", ValueError), (1.5, TypeError),
     (True, TypeError), (None, TypeError), (1 << 62, ValueError)],
)  # fmt: skip
def test_bad_limits_are_refused(cache_limit: None, limit: object, error: type) -> None:
    before = cu.buffer_cache_stats()["limit_bytes"]
    with pytest.raises(error, match="buffer cache limit"):
        cu.set_buffer_cache_limit(limit)  # type: ignore[arg-type]
    assert cu.buffer_cache_stats()["limit_bytes"] == before


@pytest.mark.parametrize(
    ("text", "limit"), [("256M", 256 << 20), ("0", 0), ("nonsense", 256 << 20)]
)
def test_the_environment_sets_the_starting_limit(text: str, limit: int) -> None:
    code = "import cumuli; print(cumuli.buffer_cache_stats()['limit_bytes'])"
    env = {**os.environ, "CUMULI_BUFFER_CACHE": text}
    run = subprocess.run(
        [sys.executable, "-W", "always", "-c", code], env=env, capture_output=True, text=True,
        check=True,
    )  # fmt: skip
    assert int(run.stdout.strip()) == limit
    assert ("CUMULI_BUFFER_CACHE ignored" in run.stderr) == (text == "nonsense")
