"""The light step's assembly in the core: the sun's transmittance on a drawable's world lattice
(``_core.lattice_transmittance``: e^−τ of its sun lattice at the world lattice's texel centres,
the trilinear read of ``_core.sample_frame`` at those points), the sky irradiance from the
visibility moments on any number of threads, and the RGBA light lattice from the fluence, the
sky irradiance and the lattice gains (``_core.physical_grid``) against a numpy twin."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.demo import cumulus_scene
from cumuli.light.physical import lattice_gains, own_sun_depth

F32 = np.float32


def _centres(lo: tuple, cell: tuple, dims: tuple[int, int, int]) -> np.ndarray:
    """Texel centres ``lo + (index + ½)·cell`` in float32, ``[z][y][x]`` order, (N, 3)."""
    axes = [
        F32(lo[a]) + (np.arange(dims[a], dtype=F32) + F32(0.5)) * F32(cell[a]) for a in range(3)
    ]
    zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return np.stack([xx, yy, zz], -1).reshape(-1, 3)


def _cloud_lattices(dims: tuple[int, int, int]) -> tuple[tuple, np.ndarray, tuple, tuple]:
    """The default cloud's sun lattice at resolution 16, ``(frame, depth)``, and a world lattice
    of ``dims`` (x, y, z) cells over its box as ``_core.lattice_transmittance`` takes it:
    ``(lo, cell)`` in float32."""
    scene = cumulus_scene(settings=cu.RenderSettings(physical_resolution=16))
    frame, depth = own_sun_depth(scene.clouds[0], scene, 2)
    lo, hi = scene.clouds[0].layer_box()
    lo32 = tuple(float(F32(v)) for v in lo)
    cell = tuple(float(F32((hi[a] - lo[a]) / dims[a])) for a in range(3))
    return frame, depth, lo32, cell


def test_transmittance_is_the_frame_read_at_the_lattice_centres() -> None:
    dims = (13, 7, 11)
    frame, depth, lo32, cell = _cloud_lattices(dims)
    got = _core.lattice_transmittance(depth, frame, lo32, cell, dims, 2)
    assert got.shape == (11, 7, 13) and got.dtype == np.float32
    tau = _core.sample_frame(depth, frame, _centres(lo32, cell, dims), 1).reshape(11, 7, 13)
    assert tau.max() > 1.0  # the cloud shades part of the lattice
    np.testing.assert_allclose(got, np.exp(-tau.astype(np.float64)), rtol=3e-7, atol=0)
    for threads in (1, 3):
        assert np.array_equal(
            _core.lattice_transmittance(depth, frame, lo32, cell, dims, threads), got
        )


def test_transmittance_rejects_bad_input() -> None:
    scene = cumulus_scene(settings=cu.RenderSettings(physical_resolution=8))
    frame, depth = own_sun_depth(scene.clouds[0], scene, 1)
    with pytest.raises(ValueError, match="frame's shape"):
        _core.lattice_transmittance(depth[1:], frame, (0, 0, 0), (1, 1, 1), (4, 4, 4))
    with pytest.raises(ValueError, match="cell"):
        _core.lattice_transmittance(depth, frame, (0, 0, 0), (1, -1, 1), (4, 4, 4))
    with pytest.raises(ValueError, match="lo"):
        _core.lattice_transmittance(depth, frame, (0, float("nan"), 0), (1, 1, 1), (4, 4, 4))
    with pytest.raises(ValueError, match="dims"):
        _core.lattice_transmittance(depth, frame, (0, 0, 0), (1, 1, 1), (4, 0, 4))


def test_sky_irradiance_is_the_same_on_any_thread_count() -> None:
    rng = np.random.default_rng(4)
    vis = rng.normal(size=(5, 6, 7, 9)).astype(F32)
    coeffs = rng.normal(size=27).astype(F32)
    one = _core.sky_irradiance_from(vis, coeffs, 1)
    want = np.maximum(
        0.0,
        np.einsum("dhwc,kc->dhwk", vis.astype(np.float64), coeffs.reshape(3, 9).astype(np.float64)),
    )
    np.testing.assert_allclose(one, want, rtol=1e-6, atol=1e-6)
    for threads in (2, 3):
        assert np.array_equal(_core.sky_irradiance_from(vis, coeffs, threads), one)


def _grid_twin(ext, phi, sky_e, lo, hi, depth, sun_gain, sky_gain) -> np.ndarray:
    """The light lattice as numpy writes it (lattice_gains' gains, float32 products)."""
    grid = np.zeros((*ext.shape, 4), F32)
    if sky_e is not None:
        grid[..., 1:4] = sky_e
    if phi is not None:
        grid[..., 0] = lattice_gains(ext, lo, hi, sun_gain, depth) * phi[..., 0]
        if sky_e is not None:
            gain = lattice_gains(ext, lo, hi, sky_gain, depth)
            grid[..., 1:4] = gain[..., None] * (sky_e + phi[..., 1:4])
    return grid


@pytest.mark.parametrize("depth", [0.0, 0.7])
@pytest.mark.parametrize("parts", ["sky and fluence", "fluence", "sky", "neither"])
def test_light_grid_is_its_numpy_twin(parts: str, depth: float) -> None:
    rng = np.random.default_rng(9)
    shape = (5, 4, 6)
    ext = (rng.uniform(-0.2, 3.0, shape)).astype(F32)  # a few negative values: clamped to 0
    lo, hi = (0.1, -1.0, 2.0), (3.3, 1.5, 4.7)
    sky_e = rng.uniform(0, 2, (*shape, 3)).astype(F32) if "sky" in parts else None
    channels = 4 if sky_e is not None else 1
    phi = rng.uniform(0, 5, (*shape, channels)).astype(F32) if "fluence" in parts else None
    d, h, w = shape
    edges = (np.asarray(hi) - np.asarray(lo)) / (w, h, d)
    cell = float(np.prod(np.abs(edges)) ** (1.0 / 3.0))
    want = _grid_twin(ext, phi, sky_e, lo, hi, depth, 1.52, 3.2)
    for threads in (1, 2, 3):
        got = _core.physical_grid(ext, phi, sky_e, cell, depth, 1.52, 3.2, threads)
        assert got.shape == (*shape, 4) and got.dtype == np.float32
        assert np.array_equal(got, want)


def test_light_grid_rejects_bad_input() -> None:
    ext = np.ones((3, 3, 3), F32)
    phi4, sky = np.ones((3, 3, 3, 4), F32), np.ones((3, 3, 3, 3), F32)
    with pytest.raises(ValueError, match="phi"):
        _core.physical_grid(ext, np.ones((3, 3, 2, 4), F32), None, 1.0, 0.5, 1.5, 3.0)
    with pytest.raises(ValueError, match="4 channels"):
        _core.physical_grid(ext, np.ones((3, 3, 3, 1), F32), sky, 1.0, 0.5, 1.5, 3.0)
    with pytest.raises(ValueError, match="sky_e"):
        _core.physical_grid(ext, phi4, np.ones((3, 3, 3, 4), F32), 1.0, 0.5, 1.5, 3.0)
    with pytest.raises(ValueError, match="gains"):
        _core.physical_grid(ext, phi4, sky, 1.0, 0.5, float("nan"), 3.0)
    with pytest.raises(ValueError, match="gain_depth"):
        _core.physical_grid(ext, phi4, sky, 1.0, -1.0, 1.5, 3.0)
    with pytest.raises(ValueError, match="cell"):
        _core.physical_grid(ext, phi4, sky, 0.0, 0.5, 1.5, 3.0)
    with pytest.raises(ValueError, match="extinction"):
        _core.physical_grid(ext[0], phi4, sky, 1.0, 0.5, 1.5, 3.0)


def test_upstream_map_reads_as_its_lattice_added_to_every_layer() -> None:
    """A per-column map given as ``upstream`` reads as if it were added to every layer of the
    sun lattice: sampled at any point, and in the transmittance on a world lattice."""
    dims = (13, 7, 11)
    frame, depth, lo32, cell = _cloud_lattices(dims)
    rng = np.random.default_rng(2)
    up = rng.uniform(0, 5, depth.shape[1:]).astype(F32)
    whole = depth + up[None]
    lo, hi = np.asarray(lo32), np.asarray(lo32) + np.asarray(cell) * dims
    pts = rng.uniform(lo - 1.0, hi + 1.0, (4000, 3)).astype(F32)
    for threads in (1, 2):
        got = _core.sample_frame(depth, frame, pts, threads, upstream=up)
        np.testing.assert_allclose(got, _core.sample_frame(whole, frame, pts), rtol=1e-5, atol=2e-5)
    got = _core.lattice_transmittance(depth, frame, lo32, cell, dims, 2, upstream=up)
    want = _core.lattice_transmittance(whole, frame, lo32, cell, dims, 2)
    assert want.min() < 0.5 * want.max()  # the map and the cloud shade part of it
    np.testing.assert_allclose(got, want, rtol=3e-5, atol=1e-7)
    for bad in (up[1:], up[:, 1:], up[None]):
        with pytest.raises(ValueError, match="upstream"):
            _core.sample_frame(depth, frame, pts, upstream=bad)
        with pytest.raises(ValueError, match="upstream"):
            _core.lattice_transmittance(depth, frame, lo32, cell, dims, upstream=bad)


def test_depth_scale_scales_the_optical_depth() -> None:
    dims = (9, 8, 7)
    frame, depth, lo32, cell = _cloud_lattices(dims)
    whole = _core.lattice_transmittance(depth, frame, lo32, cell, dims, 1).astype(np.float64)
    for k in (0.0, 0.55, 2.0):
        got = _core.lattice_transmittance(depth, frame, lo32, cell, dims, 2, depth_scale=k)
        np.testing.assert_allclose(got, whole**k, rtol=2e-5, atol=1e-30)
    for bad in (-0.1, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="depth_scale"):
            _core.lattice_transmittance(depth, frame, lo32, cell, dims, depth_scale=bad)


def test_forward_peak_share_integrates_the_phase_over_the_cone() -> None:
    """The Mie phase's diffraction peak holds ~0.45 of its light within 2.6°, as the Mitsuba
    references' tabulation finds; an HG lobe's share is its closed-form integral."""
    from dataclasses import replace

    from cumuli.light.physical import PEAK_COS, forward_peak_share

    mie = cu.RenderSettings()
    assert forward_peak_share(mie) == pytest.approx(0.4466, abs=2e-3)
    for g in (0.3, 0.6, 0.85):
        hg = replace(mie, phase="hg", hg_g=g)
        # 2π ∫ HG dμ over [c, 1] = (1 − g²)/(2g)·(1/(1 − g) − 1/√(1 + g² − 2gc)).
        exact = (1 - g * g) / (2 * g) * (1 / (1 - g) - 1 / np.sqrt(1 + g * g - 2 * g * PEAK_COS))
        assert forward_peak_share(hg) == pytest.approx(exact, rel=1e-4)
    assert forward_peak_share(replace(mie, droplet_diameter=5.0)) < forward_peak_share(mie)


def _carried_by_march(tau: np.ndarray, k: float, a: float, m: float, h: float = 1e-4) -> np.ndarray:
    """The carried source marched step by step along τ: the carried light C gains the collided
    ``e^{−kτ}`` and loses ``a·C`` to the diffusion (midpoint steps of ``h`` in τ)."""

    def step(c: float, t: float, h: float) -> float:
        mid = c + 0.5 * h * (np.exp(-k * t) - a * c)
        return c + h * (np.exp(-k * (t + 0.5 * h)) - a * mid)

    out = np.empty_like(tau)
    c, t = 0.0, 0.0
    for i in np.argsort(tau):
        while t + h <= tau[i]:
            c, t = step(c, t, h), t + h
        end = step(c, t, tau[i] - t)  # the last part step, to τ exactly
        out[i] = (1 - m) * np.exp(-k * tau[i]) + m * a * end
    return out


def test_the_carried_source_is_the_carried_light_turning_diffuse() -> None:
    """``carried`` m: the source is ``(1 − m)e^{−kτ} + m·a·C(τ)``, C the collided light carried on
    along the light (dC/dτ = e^{−kτ} − a·C), whose closed form holds for a above, below and at
    k; all of what collides diffuses in the end (∫ a·C dτ = ∫ e^{−kτ} dτ)."""
    dims = (9, 8, 7)
    frame, depth, lo32, cell = _cloud_lattices(dims)
    flat = _core.sample_frame(depth, frame, _centres(lo32, cell, dims), 1).astype(np.float64)
    tau = flat.reshape(dims[::-1])
    assert tau.max() > 2.0
    for k, a, m in ((0.55, 0.2, 0.3), (0.55, 1.7, 1.0), (0.55, 0.55, 0.5), (1.0, 0.1, 1.0)):
        got = _core.lattice_transmittance(
            depth, frame, lo32, cell, dims, 2, depth_scale=k, carried=m, carried_rate=a
        )
        want = _carried_by_march(flat, k, a, m).reshape(tau.shape)
        np.testing.assert_allclose(got, want, rtol=2e-4, atol=1e-7)
    # Along a long column the diffused total equals the collided total, 1/k.
    column = np.linspace(0.0, 80.0, 801)
    for a in (0.2, 0.55, 3.0):
        source = _carried_by_march(column, 0.55, a, 1.0, h=2e-3)
        total = np.sum(0.5 * (source[1:] + source[:-1]) * np.diff(column))
        assert total == pytest.approx(1 / 0.55, rel=2e-3)
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="carried"):
            _core.lattice_transmittance(depth, frame, lo32, cell, dims, carried=bad)
    for bad in (0.0, -1.0, float("inf")):
        with pytest.raises(ValueError, match="carried_rate"):
            _core.lattice_transmittance(depth, frame, lo32, cell, dims, carried=0.5,
                                        carried_rate=bad)  # fmt: skip


def test_the_diffusion_takes_the_sun_with_its_forward_peak_unscattered(monkeypatch) -> None:
    """The diffusion's sun source is fed ``(1 − f)`` of the collided light at the lattice's
    centres: ``e^{−kτ}`` (k = 1 − f·ϖ) where it collides, a share :data:`SUN_CARRIED` of it
    carried on along the light (``a/(a − k)·(e^{−kτ} − e^{−aτ})``, a = :func:`carried_rate`)."""
    from cumuli.light import physical as phys

    scene = cumulus_scene(settings=cu.RenderSettings(physical_resolution=12))
    seen: dict[str, np.ndarray] = {}
    real = _core.diffusion_light

    def spy(ext, lo, hi, sun_t, *args, **kwargs):
        seen["sun_t"] = np.array(sun_t)
        seen["ext"] = np.array(ext)
        return real(ext, lo, hi, sun_t, *args, **kwargs)

    monkeypatch.setattr(phys._core, "diffusion_light", spy)
    cu.light.prepare.clear_memo()
    light = phys.physical_light(scene.clouds[0], scene, 2)
    f = phys.forward_peak_share(scene.settings)
    w = scene.settings.albedo
    d, h, wd = seen["ext"].shape
    lo, hi = light.box
    lo32 = tuple(float(F32(lo[a])) for a in range(3))
    cell = tuple(float(F32((hi[a] - lo[a]) / (wd, h, d)[a])) for a in range(3))
    tau = _core.sample_frame(light.sun_depth, light.frame, _centres(lo32, cell, (wd, h, d)), 1)
    k, a, m = 1 - f * w, phys.carried_rate(scene.settings), phys.SUN_CARRIED
    tau = tau.astype(np.float64)
    carried = a / (a - k) * (np.exp(-k * tau) - np.exp(-a * tau))
    want = (1 - f) * ((1 - m) * np.exp(-k * tau) + m * carried).reshape(d, h, wd)
    assert f > 0.4 and tau.max() > 5.0 and 0 < m < 1 and abs(a - k) > 0.05
    np.testing.assert_allclose(seen["sun_t"], want, rtol=1e-4, atol=1e-12)
