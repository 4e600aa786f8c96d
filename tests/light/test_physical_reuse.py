"""What a moving sun or a changing sky does not relight: the physical light keeps a medium's
extinction lattice and its sky visibility (the SH moments of the visibility, the expensive half
of the sky light) apart from the sun and the sky, so that a new sun direction recomputes only
the sun's terms and a new sky only re-projects the moments, with the same light as from
nothing."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.light import memo
from cumuli.light import physical as phys
from cumuli.sky import sky_args

SETTINGS = cu.RenderSettings(physical_resolution=20)


def _scene(sun: tuple[float, float, float] = (0.45, 0.75, 0.5), **kw: object) -> cu.Scene:
    return cu.Scene(
        [cu.gaussian_cumulus(seed=1)],
        noise=cu.Noise(seed=7, size=32),
        sun=cu.Sun(direction=sun),
        settings=SETTINGS,
        **kw,  # type: ignore[arg-type]
    )


@pytest.fixture
def counted(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Calls of the two memoised stages (the extinction lattice, the sky visibility)."""
    calls = {"extinction": 0, "visibility": 0}
    grid, visibility = phys.extinction_grid, _core.sky_visibility

    def count_grid(*a, **k):
        calls["extinction"] += 1
        return grid(*a, **k)

    def count_visibility(*a, **k):
        calls["visibility"] += 1
        return visibility(*a, **k)

    monkeypatch.setattr(phys, "extinction_grid", count_grid)
    monkeypatch.setattr(_core, "sky_visibility", count_visibility)
    memo.clear()
    yield calls
    memo.clear()


def _light(scene: cu.Scene) -> phys.PhysicalLight:
    return phys.physical_light(scene.clouds[0], scene, threads=2)


def _same(a: phys.PhysicalLight, b: phys.PhysicalLight) -> bool:
    return bool(np.array_equal(a.grid, b.grid) and np.array_equal(a.sun_depth, b.sun_depth))


@pytest.mark.parametrize("method", ["march", "lattice"])
def test_visibility_then_projection_is_the_sky_irradiance(method: str) -> None:
    rng = np.random.default_rng(1)
    ext = (rng.random((9, 10, 11)) > 0.5).astype(np.float32) * rng.uniform(0, 5, (9, 10, 11))
    ext = ext.astype(np.float32)
    lo, hi = (0.0, 0.0, 0.0), (1.1, 1.0, 0.9)
    coeffs = _core.sky_sh(sky_args(cu.Sky()), 3, 3)
    vis = _core.sky_visibility(ext, lo, hi, 3, 3, 1.0, 2, method=method)
    assert vis.shape == (9, 10, 11, 9) and vis.dtype == np.float32
    whole = _core.sky_irradiance(ext, lo, hi, coeffs, 3, 3, 1.0, 2, method=method)
    assert np.array_equal(_core.sky_irradiance_from(vis, coeffs), whole)


def test_a_moving_sun_relights_only_the_sun_terms(counted: dict[str, int]) -> None:
    first = _light(_scene())
    assert counted == {"extinction": 1, "visibility": 1}
    moved = _light(_scene(sun=(-0.3, 0.8, 0.2)))
    assert counted == {"extinction": 1, "visibility": 1}  # neither made again
    assert not _same(first, moved)  # and the light did move
    memo.clear()
    assert _same(moved, _light(_scene(sun=(-0.3, 0.8, 0.2))))  # as from nothing
    assert counted == {"extinction": 2, "visibility": 2}


def test_a_new_sky_reprojects_the_same_visibility(counted: dict[str, int]) -> None:
    first = _light(_scene())
    dusk = _scene(sky=cu.Sky(zenith=(0.05, 0.1, 0.2)))
    darker = _light(dusk)
    assert counted == {"extinction": 1, "visibility": 1}
    assert darker.grid[..., 1:].sum() < first.grid[..., 1:].sum()
    memo.clear()
    assert _same(darker, _light(dusk))


def test_new_settings_or_noise_make_the_medium_again(counted: dict[str, int]) -> None:
    _light(_scene())
    other = _scene()
    _light(other.replace(settings=cu.RenderSettings(physical_resolution=20, extinction_scale=3.0)))
    _light(other.replace(noise=cu.Noise(seed=8, size=32)))
    assert counted == {"extinction": 3, "visibility": 3}


def test_memoised_media_are_read_only_and_clear_with_the_memo() -> None:
    memo.clear()
    density = np.random.default_rng(0).random((8, 8, 8)).astype(np.float32)
    volume = cu.VolumeCloud(density=density, box=((0, 0, 0), (4, 4, 4)))
    scene = cu.Scene([volume], settings=SETTINGS)
    phys.physical_light(volume, scene, threads=1)
    kept = list(memo.media_store.values())
    assert kept and all(not getattr(v, "values", v).flags.writeable for v in kept)
    density[0, 0, 0] = 0.5  # the caller's array is still its own
    cu.light.prepare.clear_memo()
    assert not memo.media_store and not memo.store
