"""The physical light step's bulk density: the extinction lattice and the sun's march gather the
samples that can hold density and evaluate their fBm in one SIMD call per row or ray. Checked
against the scalar path (`Cloud.density`, one fBm per point) bit for bit on the lattice and on
the march, for many clouds, metaballs, edge points, both noise versions and several thread
counts and SIMD levels."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.demo import cumulus_scene
from cumuli.light.medium import cloud_core_args
from cumuli.light.physical import physical_light
from cumuli.noise import set_simd_level, simd_levels

F32 = np.float32
FBM = {"octaves": 5, "gain": 0.5, "lacunarity": 2.0, "frequency": 1.0}


def _shape(cloud: cu.Cloud) -> _core.CloudShape:
    centres, radii, rotations, model, kappa, phi, _ = cloud.core_args()
    return _core.CloudShape(centres, radii, rotations, model, float(kappa), float(phi))


def _bulk_grid(cloud, noise, lo, hi, res, ss, threads) -> np.ndarray:
    return _core.density_grid(
        _shape(cloud), noise._core, -1.0, _core.FbmParams(**FBM), lo, hi, res, ss, threads
    )


def _scalar_grid(cloud, noise, lo, hi, res, ss) -> np.ndarray:
    """density_grid's definition from the scalar path: the mean of `Cloud.density` at ss³ points
    per voxel, the points and the sum formed as the core forms them (float32 points, a float64
    sum in sample order)."""
    lo32, hi32 = np.asarray(lo, F32), np.asarray(hi, F32)
    cell = (hi32 - lo32) / np.asarray(res, F32)
    offs = (np.arange(ss, dtype=F32) + F32(0.5)) / F32(ss)
    # Per axis: (cells, ss) coordinates, lo + (i + offset)·cell.
    axes = [lo32[a] + (np.arange(res[a], dtype=F32)[:, None] + offs[None, :]) * cell[a]
            for a in range(3)]  # fmt: skip
    # Sample order inside a voxel: c (z) outermost, then b (y), then a (x).
    z = axes[2][:, None, None, :, None, None]
    y = axes[1][None, :, None, None, :, None]
    x = axes[0][None, None, :, None, None, :]
    shape = (res[2], res[1], res[0], ss, ss, ss)
    pts = np.stack(np.broadcast_arrays(x, y, z), -1).reshape(-1, 3)
    rho = cloud.density(pts, noise=noise, threads=1, **FBM)[0].reshape(*shape[:3], ss**3)
    acc = np.zeros(shape[:3], np.float64)
    for k in range(ss**3):
        acc += rho[..., k].astype(np.float64)
    if ss == 1:
        return acc.astype(F32)
    return acc.astype(F32) * (F32(1.0) / F32(ss**3))


def _clouds() -> dict[str, cu.Cloud]:
    a = cu.gaussian_cumulus(centre=(0, 0, 0), n=12, seed=3)
    b = cu.gaussian_cumulus(centre=(2.5, 1.0, -1.5), n=9, seed=8)
    rng = np.random.default_rng(12)
    rotations = [np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(10)]
    rotations = [q * np.sign(np.linalg.det(q)) for q in rotations]  # proper rotations
    ellipsoids = cu.Cloud(
        centres=rng.uniform(-3.0, 3.0, (10, 3)),
        radii=rng.uniform(0.8, 2.5, (10, 3)),
        rotations=np.array(rotations),
    )
    return {
        "cumulus": a,
        "rotated ellipsoids": ellipsoids,
        "metaballs": cu.gaussian_cumulus(centre=(0, 0, 0), n=7, seed=5).with_model("metaball"),
        "overlapping": cu.merge([a, b]),
    }


CLOUDS = _clouds()


@pytest.mark.parametrize("version", [1, 2])
@pytest.mark.parametrize("name", sorted(CLOUDS))
def test_extinction_lattice_equals_the_scalar_path(name: str, version: int) -> None:
    cloud = CLOUDS[name]
    noise = cu.Noise(seed=11, size=32, version=version)
    lo, hi = (tuple(map(float, b)) for b in cloud.layer_box())
    # The layer box (samples up to the primitives' edges), one cutting through the cloud, and
    # one reaching past it (empty rows and cells).
    mid = tuple(0.5 * (a + b) for a, b in zip(lo, hi, strict=True))
    boxes = [(lo, hi), (lo, mid), (tuple(v - 3.0 for v in lo), tuple(v + 3.0 for v in hi))]
    for box in boxes:
        for res, ss in (((13, 9, 11), 2), ((17, 10, 12), 1)):
            expected = _scalar_grid(cloud, noise, *box, res, ss)
            assert expected.max() > 0.0
            for threads in (1, 2, 3):
                got = _bulk_grid(cloud, noise, *box, res, ss, threads)
                np.testing.assert_array_equal(got, expected)


def _scalar_depth(cloud, noise, scale, origins, d, step) -> np.ndarray:
    """The march of `Medium.optical_depth` through a one-sphere cloud written with the scalar
    density: segments of `step` from the ray's start inside the sphere (the last one cut at the
    sphere's exit, here in float64), σt at their midpoints, τ summed in float64."""
    c = np.asarray(cloud.centres[0], np.float64)
    r = float(cloud.radii[0][0]) * cloud.candidate_scale
    out = []
    for o in origins:
        oc = o.astype(np.float64) - c
        b = float(oc @ d)
        t_out = F32(-b + np.sqrt(b * b - (oc @ oc - r * r)))
        t, ss, lens = F32(0.0), [], []
        while t < t_out:
            end = min(F32(t + F32(step)), t_out)
            ss.append(F32(0.5) * (t + end))
            lens.append(end - t)
            t = end
        s = np.array(ss, F32)
        pts = o[None, :] + s[:, None] * d.astype(F32)[None, :]
        rho = cloud.density(pts, noise=noise, threads=1, **FBM)[0]
        tau = 0.0
        for sigma, length in zip(F32(scale) * rho, lens, strict=True):
            tau += float(sigma) * float(length)
        out.append(tau)
    return np.array(out)


@pytest.mark.parametrize("version", [1, 2])
@pytest.mark.parametrize("model", ["spheroid", "metaball"])
def test_sun_march_equals_the_scalar_path(model: str, version: int) -> None:
    cloud = cu.Cloud(centres=[(0.5, -0.25, 0.75)], radii=[3.0], model=model)
    noise = cu.Noise(seed=4, size=32, version=version)
    settings = cu.RenderSettings(lighting="physical")
    clouds, _ = cloud_core_args(cloud, settings)
    scale = clouds[0][6]
    rng = np.random.default_rng(6)
    # Origins inside the sphere (the march starts at t = 0 there), along the six axis directions.
    u = rng.normal(size=(40, 3))
    u *= (rng.uniform(0.0, 0.9, 40) / np.linalg.norm(u, axis=1))[:, None]
    origins = (np.asarray(cloud.centres[0]) + 3.0 * u).astype(F32)
    step = 0.1
    for axis in range(3):
        for sign in (1.0, -1.0):
            d = np.zeros(3)
            d[axis] = sign
            expected = _scalar_depth(cloud, noise, scale, origins, d, step)
            assert expected.max() > 1.0
            for threads in (1, 2, 3):
                got = _core.medium_optical_depth(
                    clouds, [], noise._core, *FBM.values(), origins, tuple(d), step, threads
                )
                # Only the last segment's end (the sphere's exit, computed here in float64)
                # may differ by a rounding: the sums agree to float32 precision.
                np.testing.assert_allclose(got, expected, rtol=2e-6, atol=1e-5)


def test_sun_lattice_is_the_same_on_every_simd_level_and_thread_count() -> None:
    """The whole light step's lattices (the sun's optical depth and the diffuse light) do not
    depend on which fBm kernel the bulk path runs, nor on the thread count."""
    base = cumulus_scene()
    scene = base.replace(
        clouds=[cu.gaussian_cumulus(seed=2), cu.gaussian_cumulus(seed=4).with_model("metaball")],
        noise=cu.Noise(seed=7, version=2),
        settings=cu.RenderSettings(physical_resolution=12),
    )
    results = []
    try:
        for level in simd_levels():
            set_simd_level(level)
            for threads in (1, 2, 3):
                lights = [physical_light(c, scene, threads) for c in scene.clouds]
                results.append([(pl.sun_depth, pl.grid) for pl in lights])
    finally:
        set_simd_level("auto")
    for r in results[1:]:
        for (depth, grid), (depth0, grid0) in zip(r, results[0], strict=True):
            np.testing.assert_array_equal(depth, depth0)
            np.testing.assert_array_equal(grid, grid0)
    assert all(d.max() > 0.0 for d, _ in results[0])
