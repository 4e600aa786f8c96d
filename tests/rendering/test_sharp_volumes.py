"""Sharp volumes: the physical mode reads a VolumeCloud as a tricubic B-spline eroded by the
scene's fBm, with the mode's extinction; the paper mode is unchanged."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest

import cumuli as cu
from cumuli.rendering.volume_detail import detail_frequency, volume_detail
from cumuli.testing import cell_pattern_energy

SUN = cu.Sun(direction=(0.8, 0.6, 0.0), intensity=10.0)
LUMA = np.array([0.2126, 0.7152, 0.0722])


@cache
def frame(resolution: int) -> np.ndarray:
    """One endless-animation database volume of the docs' evolving cumulus, made with the
    paper's noise (version 1), on which this file's bounds were measured. (With the default
    hash noise the volume's own content differs: the cubic read's voxel-period energy is then
    0.60 of the trilinear read's instead of 0.39.)"""
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), seed=1)
    db = cu.evolving_cloud_volumes(
        cloud, cu.Noise(seed=7, version=1), 1, resolution, growth=0.25, wind=(0.08, 0.03, 0),
        density_scale=2.0, frequency=0.3, seed=3,
    )  # fmt: skip
    return db[0]


CUBE = ((-16.0, -16.0, -16.0), (16.0, 16.0, 16.0))


def side_camera(box: tuple) -> cu.Camera:
    lo, hi = np.array(box[0]), np.array(box[1])
    c = (lo + hi) / 2
    return cu.Camera(
        position=(c[0], c[1] + 2, c[2] + 1.3 * (hi - lo).max()), target=tuple(c), fov=40
    )


def render(volume: cu.VolumeCloud, camera: cu.Camera, w: int, h: int, **kw) -> np.ndarray:
    settings = kw.pop("settings", cu.RenderSettings())
    scene = cu.Scene([volume], sun=SUN, sky=cu.Sky(), settings=settings)
    return cu.render(scene, camera, w, h, **kw)


def test_the_fields_and_their_checks() -> None:
    dens = np.ones((4, 4, 4), np.float32)
    box = ((0, 0, 0), (4, 8, 2))
    v = cu.VolumeCloud(density=dens, box=box)
    assert (v.detail, v.detail_frequency, v.reconstruction, v.sigma_t) == (0.5, None, "cubic", None)
    # σt per unit density: the physical mode's extinction_scale, 1 in the paper mode, or sigma_t.
    assert v.extinction_per_density(cu.RenderSettings(extinction_scale=7.0)) == 7.0
    assert v.extinction_per_density(cu.RenderSettings(lighting="paper")) == 1.0
    assert (
        cu.VolumeCloud(density=dens, box=box, sigma_t=2.5).extinction_per_density(
            cu.RenderSettings()
        )
        == 2.5
    )
    # Half a lattice texel per voxel by default (the smallest voxel edge is 0.5).
    assert detail_frequency(v) == pytest.approx(1.0)
    assert detail_frequency(cu.VolumeCloud(density=dens, box=box, detail_frequency=3.0)) == 3.0
    scene = cu.Scene([v], settings=cu.RenderSettings(lighting="paper"))
    assert volume_detail(v, scene) is None
    for bad, match in (
        ({"detail": -0.1}, "detail"),
        ({"detail": 0.99}, "detail"),
        ({"detail": math.nan}, "detail"),
        ({"detail_frequency": 0.0}, "detail_frequency"),
        ({"reconstruction": "nearest"}, "reconstruction"),
    ):
        with pytest.raises(ValueError, match=match):
            cu.VolumeCloud(density=dens, box=box, **bad)
    # Scene files keep the fields (and sigma_t=None).
    w = cu.VolumeCloud(density=dens, box=box, detail=0.2, detail_frequency=2.0,
                       reconstruction="linear")  # fmt: skip
    back = cu.VolumeCloud.from_dict(w.to_dict())
    assert (back.detail, back.detail_frequency, back.reconstruction, back.sigma_t) == (
        0.2, 2.0, "linear", None,
    )  # fmt: skip


def test_the_paper_mode_is_unchanged() -> None:
    """The paper mode reads the voxels trilinearly with its own light volume, whatever the
    sharp-volume fields say."""
    dens = frame(16)
    box = ((-17.0, -10.0, -16.0), (17.0, 12.0, 17.0))
    paper = cu.RenderSettings(lighting="paper")
    cam = side_camera(box)
    sharp = cu.VolumeCloud(density=dens, box=box, lighting={"sh_samples": 4, "ms_points": 4})
    plain = cu.VolumeCloud(density=dens, box=box, sigma_t=1.0, detail=0.0, reconstruction="linear",
                           lighting={"sh_samples": 4, "ms_points": 4})  # fmt: skip
    a = render(sharp, cam, 48, 27, settings=paper)
    b = render(plain, cam, 48, 27, settings=paper)
    np.testing.assert_array_equal(a, b)


def test_a_64_cube_physical_frame_is_shaded() -> None:
    """Lit top, shaded sides: a wide luminance spread over the cloud. With σt = 1 per unit
    density (what a volume had before) the same frame is a flat white blob."""
    dens = frame(64)
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), seed=1)
    box = cu.evolving_cloud_volumes(cloud, None, 1, 4, growth=0.25, constant=1.0).box
    cam = side_camera(box)

    def spread(volume: cu.VolumeCloud) -> float:
        img = render(volume, cam, 160, 90)
        lum = img[..., :3] @ LUMA
        cover = img[..., 3] > 0.9
        assert cover.mean() > 0.1
        p5, p95 = np.percentile(lum[cover], [5, 95])
        return float(p95 / p5)

    shaded = spread(cu.VolumeCloud(density=dens, box=box))
    flat = spread(cu.VolumeCloud(density=dens, box=box, sigma_t=1.0, detail=0.0,
                                 reconstruction="linear"))  # fmt: skip
    assert shaded > 4.0 > flat, (shaded, flat)


def test_the_detail_carves_the_edges_not_the_core() -> None:
    dens = frame(32)
    cam = side_camera(CUBE)
    smooth = render(cu.VolumeCloud(density=dens, box=CUBE, detail=0.0), cam, 96, 54)
    carved = render(cu.VolumeCloud(density=dens, box=CUBE), cam, 96, 54)  # detail 0.5
    a0, a1 = smooth[..., 3], carved[..., 3]
    core = a0 > 0.999
    edge = (a0 > 0.02) & (a0 < 0.5)
    assert core.sum() > 200 and edge.sum() > 50
    # Erosion only removes density, most where it is low: thin edges lose coverage, the core
    # stays opaque.
    assert (a1 <= a0 + 1e-4).all()  # (up to where the rays stop, T < min_transmittance)
    change_core, change_edge = np.abs(a1 - a0)[core].mean(), np.abs(a1 - a0)[edge].mean()
    print(f"mean |Δalpha|: core {change_core:.4f}, thin edges {change_edge:.4f}")
    assert change_core < 0.02
    assert change_edge > 0.1


def test_the_cubic_reconstruction_hides_the_cells() -> None:
    """A 32³ volume at 640×360, seen from far along z with a narrow field of view so that a
    voxel spans the same ~10 pixels everywhere: the trilinear read's kinks on the cell faces
    put energy at that period; the tricubic B-spline (C² across the faces) much less."""
    dens = frame(32)
    width, height, dist = 640, 360, 400.0
    fov = math.degrees(2 * math.atan(18.0 / dist))  # 36 world units over the image height
    cam = cu.Camera(position=(0.0, 0.0, dist), target=(0.0, 0.0, 0.0), fov=fov)
    period = height / 36.0  # pixels per voxel (1 world unit)
    linear = render(cu.VolumeCloud(density=dens, box=CUBE, detail=0.0, reconstruction="linear"),
                    cam, width, height)  # fmt: skip
    cubic = render(cu.VolumeCloud(density=dens, box=CUBE, detail=0.0), cam, width, height)
    e_lin, e_cub = cell_pattern_energy(linear, period), cell_pattern_energy(cubic, period)
    print(f"voxel-period gradient energy: linear {e_lin:.4f}, cubic {e_cub:.4f}")
    assert e_cub < 0.5 * e_lin, (e_lin, e_cub)


def test_the_cpu_marcher_does_not_depend_on_the_thread_count() -> None:
    dens = frame(16)
    cam = side_camera(CUBE)
    lit = cu.prepare_light(cu.Scene([cu.VolumeCloud(density=dens, box=CUBE)], sun=SUN))
    np.testing.assert_array_equal(
        cu.render_cpu(lit, cam, 40, 24, threads=1), cu.render_cpu(lit, cam, 40, 24, threads=2)
    )


@pytest.mark.gl
def test_gl_matches_cpu_with_detail(gl_context) -> None:
    dens = frame(16)
    cam = side_camera(CUBE)
    settings = cu.RenderSettings(exact_noise=True, resolve=False)
    scene = cu.Scene([cu.VolumeCloud(density=dens, box=CUBE, detail=0.6)], sun=SUN,
                     sky=cu.Sky(), settings=settings)  # fmt: skip
    lit = cu.prepare_light(scene)
    cpu = cu.render_cpu(lit, cam, 64, 36)
    with cu.Renderer(context=gl_context) as r:
        gl = r.render(lit, cam, 64, 36)
    assert cpu[..., 3].mean() > 0.1
    diff = np.abs(gl - cpu)
    assert diff.mean(axis=(0, 1)).max() <= 1e-3, diff.mean(axis=(0, 1))
    assert (diff.max(-1) > 5e-2).mean() <= 0.01
    # The detail is drawn on both: without it the image differs.
    plain_cloud = cu.VolumeCloud(density=dens, box=CUBE, detail=0.0)
    plain = cu.render_cpu(scene.replace(clouds=[plain_cloud]), cam, 64, 36)
    assert np.abs(plain - cpu)[..., 3].mean() > 1e-3


def test_a_frame_of_an_animation_takes_the_modes_extinction() -> None:
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), seed=1)
    db = cu.evolving_cloud_volumes(cloud, None, 2, 6, constant=1.0)
    lighting = cu.VolumeLighting(db, SUN, cu.Sky(), sh_samples=4, ms_points=4)
    v = cu.VolumeCloud.from_frame(lighting, 0, detail=0.2)
    # The lighting's default σt = 1 is the paper mode's (its light was made with it) and the
    # physical mode's extinction_scale.
    assert v.sigma_t is None and v.detail == 0.2
    assert v.extinction_per_density(cu.RenderSettings(lighting="paper")) == lighting.sigma_t
    assert v.extinction_per_density(cu.RenderSettings()) == cu.RenderSettings().extinction_scale
    thick = cu.VolumeLighting(db, SUN, cu.Sky(), sigma_t=2.0, sh_samples=4, ms_points=4)
    assert cu.VolumeCloud.from_frame(thick, 1).sigma_t == 2.0


def test_sigma_t_none_is_checked_at_the_largest_extinction_scale() -> None:
    dens = np.full((2, 2, 2), 2e6, np.float32)
    with pytest.raises(ValueError, match="1e\\+06 × 2e\\+06"):
        cu.VolumeCloud(density=dens, box=((0, 0, 0), (1, 1, 1)))
    cu.VolumeCloud(density=dens, box=((0, 0, 0), (1, 1, 1)), sigma_t=1.0)


def test_gl_matches_cpu_with_detail_of_the_hash_noise(gl_context, monkeypatch) -> None:
    """Noise version 2 as the detail: the volume shader hashes the lattice corners (its lattice
    texture zeroed here, so GL matches the C++ only if it computes them)."""
    from cumuli.rendering import volume as volume_gl

    owner = next(
        c for c in vars(volume_gl).values() if isinstance(c, type) and "_noise_texture" in vars(c)
    )
    upload = owner._noise_texture

    def zeroed(self, noise):
        tex = upload(self, noise)
        tex.write(np.zeros(noise.size**3, dtype=np.float32).tobytes())
        return tex

    monkeypatch.setattr(owner, "_noise_texture", zeroed)
    dens = frame(16)
    cam = side_camera(CUBE)
    settings = cu.RenderSettings(exact_noise=True, resolve=False)
    scene = cu.Scene([cu.VolumeCloud(density=dens, box=CUBE, detail=0.6)], sun=SUN,
                     sky=cu.Sky(), settings=settings, noise=cu.Noise(7, version=2))  # fmt: skip
    lit = cu.prepare_light(scene)
    cpu = cu.render_cpu(lit, cam, 64, 36)
    with cu.Renderer(context=gl_context) as r:
        gl = r.render(lit, cam, 64, 36)
    diff = np.abs(gl - cpu)
    assert diff.mean(axis=(0, 1)).max() <= 1e-3, diff.mean(axis=(0, 1))
    assert (diff.max(-1) > 5e-2).mean() <= 0.01
    table_scene = scene.replace(noise=cu.Noise(7, version=1))
    table = cu.render_cpu(cu.prepare_light(table_scene), cam, 64, 36)
    assert np.abs(table - cpu)[..., 3].mean() > 1e-4
