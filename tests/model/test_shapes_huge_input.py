"""Finite but huge generator input is refused up front, naming the parameter (MAX_COORD = 1e15).

Without the bound, float32 arithmetic in the core overflowed: ``sigma=(3e38, 1, 1)`` gave inf
centres and vertices near 3e38 gave inf radii, and the error (if any) named the output.
"""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli._util.validate import MAX_COORD, direction, points3, vec3
from cumuli.io import meshes

HUGE = 3e38  # finite in float32 (max 3.4e38)


def _finite(*arrays: np.ndarray) -> bool:
    return all(np.isfinite(a).all() for a in arrays)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"sigma": (HUGE, 1.0, 1.0)}, "sigma"),
        ({"sigma": (1.0, 2e15, 1.0)}, "sigma"),
        ({"mu": (0.0, 0.0, HUGE)}, "mu"),
        ({"mu": (-2e15, 0.0, 0.0)}, "mu"),
        ({"centre": (HUGE, 0.0, 0.0)}, "centre"),
        ({"centre": (0.0, -1.5e15, 0.0)}, "centre"),
        ({"epsilon": HUGE}, "epsilon"),
        ({"epsilon": (1.0, 2e15)}, "epsilon"),
        ({"radius_scale": HUGE}, "radius_scale"),
        ({"radius_model": "uniform", "radius_range": (1.0, HUGE)}, "radius_range"),
        ({"clamps": ((-HUGE, 2.0), (0.0, 2.0), (-2.0, 2.0))}, "clamps"),
        ({"hollow_box": (HUGE, 0.3, 0.75)}, "hollow_box"),
        # Each in range, but their products are not.
        ({"sigma": (1e14, 1.0, 1.0), "clamps": ((-20.0, 20.0), (0, 2), (-2, 2))}, "sigma"),
        ({"centre": (9e14, 0, 0), "sigma": (1e14, 1, 1)}, "clamps"),
        ({"epsilon": 1e10, "radius_scale": 1e10}, "epsilon"),
        (
            {"radius_model": "uniform", "radius_range": (1.0, 1e8), "radius_scale": 1e8},
            "radius_range",
        ),
    ],
)
def test_gaussian_cumulus_refuses_huge_parameters_by_name(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        cu.gaussian_cumulus(**kwargs)


def test_gaussian_cumulus_near_the_bound_stays_finite() -> None:
    cloud = cu.gaussian_cumulus(
        centre=(4e14, -4e14, 4e14), sigma=(1e14, 1e14, 1e14), epsilon=1e14, radius_scale=9.0
    )
    assert _finite(cloud.centres, cloud.radii, *cloud.bbox)
    assert np.abs(cloud.centres).max() <= MAX_COORD
    assert cloud.radii.max() <= MAX_COORD


def test_metaball_cumulus_refuses_huge_sigma() -> None:
    with pytest.raises(ValueError, match="sigma"):
        cu.metaball_cumulus(sigma=(HUGE, 1.0, 1.0))


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"start": (HUGE, 0.0, 0.0)}, "start"),
        ({"radius": (1.0, HUGE)}, "radius"),
        ({"step": (1.0, HUGE)}, "step"),
        # 128 placements of up to 1e13 · 1e3 each: 1.28e18 from the origin.
        ({"radius": (1.0, 1e13), "step": (1.0, 1e3)}, "radius"),
        ({"start": (9.9e14, 0, 0), "radius": (1.0, 1e12)}, "step"),
    ],
)
def test_lsystem_cloud_refuses_huge_parameters_by_name(kwargs: dict, name: str) -> None:
    with pytest.raises(ValueError, match=name):
        cu.lsystem_cloud(**kwargs)


def test_lsystem_cloud_at_large_but_bounded_sizes_stays_finite() -> None:
    cloud = cu.lsystem_cloud(iterations=5, radius=(1e12, 1e12), step=(1.0, 1.0), start=(1e14, 0, 0))
    assert _finite(cloud.centres, cloud.radii)
    assert np.abs(cloud.centres).max() <= MAX_COORD


@pytest.mark.parametrize("value", [HUGE, -HUGE, 2e15])
def test_ellipsoids_from_mesh_refuses_huge_vertices(value: float) -> None:
    v, f = meshes.icosphere(1)
    v = v.copy()
    v[3] = (value, 0.0, 0.0)
    with pytest.raises(ValueError, match="vertices"):
        cu.ellipsoids_from_mesh(v, f)
    with pytest.raises(ValueError, match="vertices"):
        cu.mesh_cloud((v, f))


def test_ellipsoids_from_mesh_refuses_huge_min_radius() -> None:
    v, f = meshes.icosphere(1)
    with pytest.raises(ValueError, match="min_radius"):
        cu.ellipsoids_from_mesh(v, f, min_radius=HUGE)
    with pytest.raises(ValueError, match="min_radius"):
        cu.mesh_cloud((v, f), min_radius=HUGE)


def test_ellipsoids_from_mesh_at_the_bound_stays_finite() -> None:
    # The worst case allowed: vertices at ±1e15 scaled by 2 about the barycentre.
    v, f = meshes.icosphere(1)
    v = (v * np.float32(MAX_COORD)).astype(np.float32)
    centres, radii, rotations = cu.ellipsoids_from_mesh(v, f, scale=2.0)
    assert _finite(centres, radii, rotations)
    assert (radii > 0).all()


def test_load_mesh_refuses_a_file_with_huge_vertices(tmp_path) -> None:
    path = tmp_path / "huge.obj"
    path.write_text("v 0 0 0\nv 3e38 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match=r"huge\.obj.*vertices"):
        meshes.load_mesh(path)


def test_validate_helpers_bound_components() -> None:
    assert vec3((1e15, -1e15, 0), "p", bound=MAX_COORD) == (1e15, -1e15, 0.0)
    with pytest.raises(ValueError, match="p must have components within"):
        vec3((1e15, -1.01e15, 0), "p", bound=MAX_COORD)
    assert vec3((HUGE, 0, 0), "p") == (HUGE, 0.0, 0.0)  # no bound asked: unchanged behaviour
    pts = np.array([[1e15, 0, 0]], dtype=np.float64)
    assert points3(pts, "pts", bound=MAX_COORD).dtype == np.float32
    with pytest.raises(ValueError, match="pts has a component of magnitude"):
        points3(pts * 2, "pts", bound=MAX_COORD)
    assert points3(np.zeros((0, 3)), "pts", bound=MAX_COORD).shape == (0, 3)


def test_direction_of_a_huge_vector_is_normalised_not_an_overflow() -> None:
    # Squaring 1e200 overflows float64 (an OverflowError from **, inf from *).
    d = direction((1e200, 1e200, 0.0), "heading")
    assert d == pytest.approx((2**-0.5, 2**-0.5, 0.0))
    assert direction((0.0, 3e38, 0.0), "up") == (0.0, 1.0, 0.0)
    cloud = cu.lsystem_cloud(iterations=2, heading=(1e300, 0.0, 0.0), up=(0.0, 1e300, 0.0))
    assert _finite(cloud.centres)
