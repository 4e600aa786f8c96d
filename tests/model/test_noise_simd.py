"""SIMD fBm: every dispatch path gives the scalar path's bits.

The AVX2 and AVX-512 kernels perform the scalar kernel's float32 operations in the same order
(no FMA), so they must agree bit for bit on random points, on lattice boundaries, on negative
and huge coordinates (which take the general per-point path), at every tail length and thread
count, and for lattice sizes that take the 16-bit multiply-add index (≤ 180) or the 32-bit one.
The lattice fetches (gather, loads, cells) read the table, so these tests pin version 1; the hash
of version 2 is checked on every path in test_noise_versions.py.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

import cumuli as cu
from cumuli.noise import (
    SIMD_FETCHES,
    SIMD_LEVELS,
    preferred_simd_fetch,
    set_simd_fetch,
    set_simd_level,
    simd_fetch,
    simd_level,
    simd_levels,
)

F32 = np.float32
LEVELS = simd_levels()
WIDE = [lvl for lvl in LEVELS if lvl != "scalar"]
#: Every kernel this CPU can run: "scalar", and each wide level with each lattice fetch
#: ("level/fetch").
KERNELS = ["scalar"] + [f"{lvl}/{fetch}" for lvl in LEVELS[1:] for fetch in SIMD_FETCHES]
WIDE_KERNELS = [k for k in KERNELS if k != "scalar"]


@pytest.fixture(autouse=True)
def _restore_level() -> Iterator[None]:
    yield
    set_simd_level("auto")
    set_simd_fetch("auto")


def _use(kernel: str) -> None:
    """Select a kernel of `KERNELS` ("avx2/loads": level and fetch)."""
    level, _, fetch = kernel.partition("/")
    set_simd_level(level)
    set_simd_fetch(fetch or "auto")


def _at(kernel: str, fn: Callable[[], Any]) -> Any:
    """``fn()`` evaluated with the core's ``kernel`` (a level, or "level/fetch")."""
    _use(kernel)
    try:
        return fn()
    finally:
        set_simd_level("auto")
        set_simd_fetch("auto")


def _edge_points() -> np.ndarray:
    """Lattice texel centres and faces at the octave scales, both signs, wrap boundaries."""
    rng = np.random.default_rng(3)
    base = np.arange(-260, 261, dtype=F32) / F32(4.0)  # quarter-texel steps across two wraps
    near = np.nextafter(base, F32(np.inf)), np.nextafter(base, F32(-np.inf))
    values = np.concatenate([base, *near, np.array([0.0, -0.0, 63.5, 64.0, -64.0], F32)])
    return rng.choice(values, size=(6000, 3)).astype(F32)


def _huge_points() -> np.ndarray:
    """Beyond 2²² texels at some octave (general path) mixed with ordinary points."""
    rng = np.random.default_rng(4)
    pts = rng.uniform(-40, 40, (500, 3)).astype(F32)
    pts[::7, 0] = F32(3.0e7)
    pts[3::11, 1] = F32(-1.5e9)
    pts[5::13, 2] = F32(131072.25)  # 2¹⁷ · 2⁵ = 2²²: at the fast path's limit in octave 5
    return pts


def test_the_cell_table_exists_for_power_of_two_sizes_up_to_64() -> None:
    for size, has in ((64, True), (2, True), (32, True), (128, False), (256, False), (17, False)):
        assert cu.Noise(seed=1, size=size, version=1).has_cells is has, size


def test_scalar_is_always_available_and_the_default_is_the_widest() -> None:
    assert LEVELS[0] == "scalar"
    assert set(LEVELS) <= set(SIMD_LEVELS)
    assert simd_level() == LEVELS[-1]


@pytest.mark.parametrize("level", WIDE_KERNELS)
@pytest.mark.parametrize("size", [64, 2, 32, 128, 256, 17])
def test_wide_paths_equal_the_scalar_path(level: str, size: int) -> None:
    """Sizes ≤ 64 have the cell table, 128 and 256 read as "loads", 17 takes the general path;
    up to 180 the index is the 16-bit multiply-add."""
    noise = cu.Noise(seed=21, size=size, version=1)
    rng = np.random.default_rng(size)
    pts = np.concatenate(
        [
            rng.uniform(-60, 60, (20_000, 3)).astype(F32),
            rng.uniform(-1e4, 1e4, (3000, 3)).astype(F32),  # far from the origin, still fast
            _edge_points(),
            _huge_points(),
        ]
    )
    for params in ({}, {"octaves": 8, "gain": 0.6, "lacunarity": 1.7, "frequency": 0.37}):
        want = _at("scalar", lambda p=params: noise.fbm(pts, **p))
        got = _at(level, lambda p=params: noise.fbm(pts, **p))
        np.testing.assert_array_equal(got, want)
        assert np.isfinite(got).all()


@pytest.mark.parametrize("version", [1, 2])
@pytest.mark.parametrize("level", KERNELS)
def test_every_tail_length_and_thread_count(level: str, version: int) -> None:
    """Counts that leave partial registers (1..40 points: at most 8 take AVX2's kernel where
    AVX-512's is in use) and chunks split across threads, in both noise versions."""
    noise = cu.Noise(seed=5, version=version)
    pts = np.random.default_rng(9).uniform(-30, 30, (4099, 3)).astype(F32)
    ref = _at("scalar", lambda: noise.fbm(pts, threads=1))
    _use(level)
    for n in range(1, 41):
        np.testing.assert_array_equal(noise.fbm(pts[:n], threads=1), ref[:n])
    for threads in (1, 2, 3, 0):
        assert noise.fbm(pts, threads=threads).tobytes() == ref.tobytes()


@pytest.mark.parametrize("level", WIDE_KERNELS)
def test_grid_and_light_pass_do_not_depend_on_the_level(level: str) -> None:
    noise = cu.Noise(seed=7, version=1)
    grid = _at("scalar", lambda: noise.fbm_grid(24, (-5, -3, -7), (9, 4, 6)))
    np.testing.assert_array_equal(
        _at(level, lambda: noise.fbm_grid(24, (-5, -3, -7), (9, 4, 6))), grid
    )
    cloud = cu.gaussian_cumulus(n=8, seed=2)
    kw = {"resolution": 10}
    light = _at("scalar", lambda: cu.light_grid(cloud, (0.3, 0.8, 0.2), noise, **kw))
    np.testing.assert_array_equal(
        _at(level, lambda: cu.light_grid(cloud, (0.3, 0.8, 0.2), noise, **kw)), light
    )


def test_bad_levels_are_refused() -> None:
    with pytest.raises(ValueError, match="level"):
        set_simd_level("sse9")
    with pytest.raises(ValueError, match="level"):
        set_simd_level(2)  # type: ignore[arg-type]
    missing = [lvl for lvl in SIMD_LEVELS if lvl not in LEVELS]
    for lvl in missing:  # only on a CPU without AVX2 / AVX-512
        with pytest.raises(ValueError, match="not supported"):
            set_simd_level(lvl)
    assert simd_level() == LEVELS[-1]  # a refused level changes nothing


def _cpu_vendor() -> str | None:
    """The ``vendor_id`` of /proc/cpuinfo (Linux), else None."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("vendor_id"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return None


def test_the_preferred_fetch_is_cells_on_amd_and_gather_elsewhere() -> None:
    """bench_noise measured cells fastest on AMD, gathers on Intel; "auto" goes back to it."""
    vendor = _cpu_vendor()
    if vendor is not None and len(LEVELS) > 1:  # an x86 CPU with the wide kernels
        assert preferred_simd_fetch() == ("cells" if vendor == "AuthenticAMD" else "gather")
    assert preferred_simd_fetch() in SIMD_FETCHES
    set_simd_fetch("loads")
    set_simd_fetch("auto")
    env = os.environ.get("CUMULI_SIMD_FETCH", "")
    assert simd_fetch() == (env if env in SIMD_FETCHES else preferred_simd_fetch())


def test_fetch_is_chosen_and_refused_like_the_level() -> None:
    assert simd_fetch() in SIMD_FETCHES
    for fetch in SIMD_FETCHES:
        set_simd_fetch(fetch)
        assert simd_fetch() == fetch
    set_simd_fetch("gather")
    with pytest.raises(ValueError, match="fetch"):
        set_simd_fetch("scatter")
    with pytest.raises(ValueError, match="fetch"):
        set_simd_fetch(1)  # type: ignore[arg-type]
    assert simd_fetch() == "gather"  # a refused fetch changes nothing


@pytest.mark.parametrize(
    ("env", "level", "fetch", "warns"),
    [
        ({"CUMULI_SIMD": "scalar"}, "scalar", None, False),
        ({"CUMULI_SIMD_FETCH": "gather"}, None, "gather", False),
        ({"CUMULI_SIMD_FETCH": "loads"}, None, "loads", False),
        ({"CUMULI_SIMD_FETCH": "cells"}, None, "cells", False),
        ({}, None, preferred_simd_fetch(), False),  # the default: the CPU's preferred fetch
        ({"CUMULI_SIMD": "sse9"}, LEVELS[-1], None, True),
        ({"CUMULI_SIMD_FETCH": "scatter"}, None, None, True),
    ],
)
def test_environment_variables_choose_the_kernel(
    env: dict[str, str], level: str | None, fetch: str | None, warns: bool
) -> None:
    """CUMULI_SIMD / CUMULI_SIMD_FETCH are read at first use; an unknown value warns at import."""
    code = (
        "import warnings; warnings.simplefilter('always')\n"
        "with warnings.catch_warnings(record=True) as w:\n"
        "    import cumuli.noise as n\n"
        "print(n.simd_level(), n.simd_fetch(), len(w))"
    )
    clean = {k: v for k, v in os.environ.items() if not k.startswith("CUMULI_SIMD")}
    out = subprocess.run(
        [sys.executable, "-c", code], env={**clean, **env}, capture_output=True, text=True,
        check=True,
    ).stdout.split()  # fmt: skip
    if level is not None:
        assert out[0] == level
    if fetch is not None:
        assert out[1] == fetch
    assert out[1] in SIMD_FETCHES
    assert (int(out[2]) > 0) == warns
