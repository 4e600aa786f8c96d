"""The metaball density model (eqs. 19–21) on any cloud, against a numpy reference."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli


def _field(cloud: cumuli.Cloud, p: np.ndarray) -> np.ndarray:
    """Σ 1/|q_i|² with q the unit-sphere frame coordinates (Σ r²/d² for spheres)."""
    d = p[:, None, :].astype(np.float64) - cloud.centres[None].astype(np.float64)
    q = np.einsum("nji,mnj->mni", cloud.rotations.astype(np.float64), d) / cloud.radii
    return (1.0 / (q**2).sum(axis=2)).sum(axis=1)


@pytest.mark.parametrize(
    "make",
    [
        lambda: cumuli.metaball_cumulus(seed=4),
        lambda: cumuli.gaussian_cumulus(seed=1).with_model("metaball"),
        lambda: cumuli.lsystem_cloud(iterations=5, angle=(50, 100), seed=3).with_model("metaball"),
        lambda: cumuli.mesh_cloud(cumuli.io.meshes.torus(sections=8)).with_model("metaball"),
    ],
)
def test_metaball_inside_matches_reference(make) -> None:
    cloud = make()
    assert cloud.model == "metaball"
    lo, hi = cloud.bbox
    rng = np.random.default_rng(0)
    # Many overlapping primitives swell the iso-surface well beyond the bounding box: sample
    # directions from the centre at log-uniform distances from 0.05 to 20 box extents.
    ext = float(np.max(hi - lo))
    u = rng.normal(size=(4000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    dist = ext * np.exp(rng.uniform(np.log(0.05), np.log(20.0), size=(4000, 1)))
    pts = (cloud.centre + u * dist).astype(np.float32)
    rho, gamma = cloud.density(pts, constant=0.5)
    f = _field(cloud, pts)
    clear = np.abs(f - 1) > 1e-3  # away from the iso-surface, where float32 could flip
    inside = f >= 1
    assert 0.05 < inside.mean() < 0.95
    np.testing.assert_array_equal((rho > 0)[clear], inside[clear])
    np.testing.assert_allclose(rho[inside & clear], 0.5 * cloud.mean_r2 * cloud.phi, rtol=1e-5)
    assert (gamma[inside & clear] == 1).all()


def test_spheroid_density_and_noise_source() -> None:
    cloud = cumuli.gaussian_cumulus(seed=2)
    noise = cumuli.Noise(seed=1, size=16)
    rho, gamma = cloud.density(cloud.centres, noise=noise, frequency=0.5)
    assert np.isfinite(rho).all() and (rho >= 0).all() and (gamma > 0).all()
    far = np.array([[1e4, 0, 0]], np.float32)
    assert cloud.density(far, constant=0.3)[0][0] == 0
    with pytest.raises(ValueError, match="noise or constant"):
        cloud.density(far)
    with pytest.raises(TypeError, match="Noise"):
        cloud.density(far, noise="x")
