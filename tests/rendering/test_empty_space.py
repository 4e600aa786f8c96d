"""Less work per pixel in the 2018 marcher (RENDER_CONTRACT "Empty-space
skipping"): conservative occupancy grids, bit-exact skipping in both marchers and both lighting
modes, the early exit `min_transmittance`, and the fBm counts of the CPU twin."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.testing import assert_image_close, only

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

import bench_render_cpu  # noqa: E402

W, H = 96, 72
OFF = {"empty_space_skipping": False, "min_transmittance": 1e-6}
FAST = {"empty_space_skipping": True, "min_transmittance": 0.2}


def _with(scene: cu.Scene, **changes) -> cu.Scene:
    return scene.replace(settings=scene.settings.replace(**changes))


SCENES = bench_render_cpu.scenes()  # the benchmark's scenes, so the test checks what it measures


def _random_cloud(model: str, seed: int, n: int = 12) -> cu.Cloud:
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-3.0, 3.0, (n, 3)).astype(np.float32)
    radii = rng.uniform(0.3, 1.6, (n, 3)).astype(np.float32)
    rotations = np.empty((n, 3, 3), np.float32)
    for k in range(n):
        q, r = np.linalg.qr(rng.normal(size=(3, 3)))
        rotations[k] = q * np.sign(np.diag(r))
    return cu.Cloud(centres, radii, rotations, model=model)


@pytest.mark.parametrize("model", ["spheroid", "metaball"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_occupancy_grid_is_conservative(model, seed):
    cloud = _random_cloud(model, seed)
    cells, (lo, hi) = cu.occupancy_grid(cloud)
    assert cells.shape == (16, 16, 16) and cells.dtype == bool
    np.testing.assert_array_equal(lo, cloud.layer_box()[0])
    np.testing.assert_array_equal(hi, cloud.layer_box()[1])
    assert 0.0 < cells.mean() < 0.9  # it marks empty cells, and keeps the cloud
    rng = np.random.default_rng(seed + 10)
    pts = [rng.uniform(lo, hi, (200_000, 3))]
    # Points on and just inside every primitive's surface: where the support ends.
    u = rng.normal(size=(20_000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    j = rng.integers(0, cloud.n, 20_000)
    scale = rng.uniform(0.97, 1.0, (20_000, 1))
    local = u * cloud.radii[j] * scale
    pts.append(cloud.centres[j] + np.einsum("nij,nj->ni", cloud.rotations[j], local))
    pts = np.concatenate(pts).astype(np.float32)
    pts = pts[((pts >= lo) & (pts <= hi)).all(axis=1)]
    idx = np.clip(((pts - lo) / (hi - lo) * 16).astype(int), 0, 15)
    in_empty = ~cells[idx[:, 2], idx[:, 1], idx[:, 0]]
    noise = cu.Noise(seed=seed)
    # A tiny constant density passes eq. (2)'s gate wherever |q| ≤ 1: the support itself.
    support, _ = cloud.density(pts, constant=1e-6)
    fbm, _ = cloud.density(pts, noise=noise, frequency=0.3)
    assert (support > 0).sum() > 1000
    assert not (support[in_empty] > 0).any()
    assert not (fbm[in_empty] > 0).any()
    assert in_empty.sum() > 1000  # the test looked at empty cells


@pytest.mark.parametrize("seed", [4, 5])
@pytest.mark.parametrize("resolution", [7, 16, 33])
def test_spheroid_grid_is_its_bound_over_every_cell_and_primitive(seed, resolution):
    """The core visits only the cells each primitive's bounds can meet; the grid is still the
    bound's, tested for every cell and every primitive: a cell is occupied when some primitive's
    world bounds meet it and |q| at its centre, less its half-diagonal over r_min, is ≤ 1 (both
    with the core's relative margin 1e-3)."""
    cloud = _random_cloud("spheroid", seed, n=20)
    cells, (lo, hi) = cu.occupancy_grid(cloud, resolution)
    lo64, hi64 = lo.astype(np.float64), hi.astype(np.float64)
    size = (hi64 - lo64) / resolution
    ix = np.stack(np.meshgrid(*[np.arange(resolution)] * 3, indexing="ij"), -1)  # [z, y, x]
    centre = lo64 + (ix[..., ::-1] + 0.5) * size  # (x, y, z) of each cell
    half_diag = 0.5 * np.linalg.norm(size)
    m = 1e-3
    occupied = np.zeros(cells.shape, bool)
    for c, r, rot in zip(cloud.centres, cloud.radii, cloud.rotations, strict=True):
        half = np.sqrt(((rot * r[None, :]) ** 2).sum(axis=1)).astype(np.float32)
        b_lo, b_hi = (c - half).astype(np.float64), (c + half).astype(np.float64)
        meets = (
            (centre - 0.5 * size <= b_hi + m * size) & (centre + 0.5 * size >= b_lo - m * size)
        ).all(-1)
        q = np.einsum("ji,...j->...i", rot.astype(np.float64), centre - c) / r
        inv_rmin = np.float32(1.0) / np.float32(r.min())
        lower = np.linalg.norm(q, axis=-1) - half_diag * float(inv_rmin)
        occupied |= meets & (lower <= 1.0 + m)
    assert 0.0 < occupied.mean() < 0.9
    np.testing.assert_array_equal(cells, occupied)


def test_occupancy_grid_bad_input():
    with pytest.raises(TypeError, match="cloud"):
        cu.occupancy_grid("cloud")
    with pytest.raises(ValueError, match="resolution"):
        cu.occupancy_grid(_random_cloud("spheroid", 1), resolution=0)


@pytest.mark.parametrize("march", ["paper", "union"])
@pytest.mark.parametrize("name", sorted(SCENES))
def test_cpu_skipping_is_bit_exact_and_fast_setting_saves_fbm(name, march):
    scene = _with(SCENES[name], march=march)
    cam = scene.default_camera()
    off, s_off = cu.render_cpu(_with(scene, **OFF), cam, W, H, return_stats=True)
    skip, s_skip = cu.render_cpu(_with(scene, empty_space_skipping=True), cam, W, H,
                                 return_stats=True)  # fmt: skip
    fast, s_fast = cu.render_cpu(_with(scene, **FAST), cam, W, H, return_stats=True)
    # Skipping alone: the same image bit for bit, the same steps, the same fBm evaluations (the
    # density is only evaluated inside the support).
    np.testing.assert_array_equal(off, skip)
    assert s_skip.steps == s_off.steps and s_skip.fbm_evaluations == s_off.fbm_evaluations
    if name == "metaball_cumulus":
        assert s_skip.skipped > 0.2 * s_skip.steps  # most empty samples of the grown boxes
    # The early exit: the image bound on every benchmark scene, fewer fBm evaluations
    # (÷ 2 on the paper march, the benchmark; the union march exits a little later).
    assert_image_close(fast, off, **only(mean_abs=2e-3))
    ratio = s_off.fbm_evaluations / s_fast.fbm_evaluations
    assert ratio >= (2.0 if march == "paper" else 1.5), ratio


def test_stats_are_counts_independent_of_threads():
    scene = _with(SCENES["metaball_cumulus"], **FAST)
    cam = scene.default_camera()
    lit = cu.prepare_light(scene)
    a, sa = cu.render_cpu(lit, cam, W, H, threads=1, return_stats=True)
    b, sb = cu.render_cpu(lit, cam, W, H, threads=2, return_stats=True)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(sa.fbm_map, sb.fbm_map)
    assert (sa.fbm_evaluations, sa.steps, sa.skipped) == (sb.fbm_evaluations, sb.steps, sb.skipped)
    assert sa.fbm_map.shape == (H, W) and int(sa.fbm_map.sum()) == sa.fbm_evaluations
    assert sa.fbm_per_pixel == pytest.approx(sa.fbm_evaluations / (W * H))
    # Counting does not change the image.
    np.testing.assert_array_equal(a, cu.render_cpu(lit, cam, W, H))
    np.testing.assert_array_equal(a, cu.render(lit, cam, W, H, backend="cpu"))
    # Sky pixels cost no fBm; covered ones do.
    assert (sa.fbm_map[a[..., 3] == 0] == 0).all() and sa.fbm_map[a[..., 3] > 0.5].min() > 0


def test_skipping_keeps_the_step_budget_solids_and_physical_mode():
    base = SCENES["metaball_cumulus"]
    cam = base.default_camera()
    # A small max_steps: skipped samples count as steps, as the empty samples they replace.
    for changes in ({"max_steps": 7}, {"max_steps": 40, "march": "union"}):
        off = cu.render_cpu(_with(base, **changes, empty_space_skipping=False), cam, 48, 36)
        on = cu.render_cpu(_with(base, **changes), cam, 48, 36)
        np.testing.assert_array_equal(off, on)
    # A solid stops the rays (drawn through the compositor's layers).
    lo, hi = base.clouds[0].layer_box()
    solid = cu.Solid(centre=tuple(((lo + hi) / 2).tolist()), radius=1.0)
    with_solid = base.replace(solids=(solid,))
    off = cu.render_cpu(_with(with_solid, empty_space_skipping=False), cam, 48, 36)
    np.testing.assert_array_equal(off, cu.render_cpu(with_solid, cam, 48, 36))
    # The physical mode marches the same support.
    phys = _with(base, lighting="physical", physical_resolution=12)
    off = cu.render_cpu(_with(phys, empty_space_skipping=False), cam, 48, 36)
    np.testing.assert_array_equal(off, cu.render_cpu(phys, cam, 48, 36))


def test_settings_validation_and_scene_round_trip(tmp_path):
    s = cu.RenderSettings(lighting="paper")
    assert s.empty_space_skipping is True and s.min_transmittance == 1e-6
    with pytest.raises(TypeError, match="empty_space_skipping"):
        cu.RenderSettings(empty_space_skipping=1, lighting="paper")
    for bad in (-0.1, 1.0, float("nan")):
        with pytest.raises(ValueError, match="min_transmittance"):
            cu.RenderSettings(min_transmittance=bad, lighting="paper")
    with pytest.raises(TypeError, match="min_transmittance"):
        cu.RenderSettings(min_transmittance="0.1", lighting="paper")
    scene = _with(SCENES["gaussian_cumulus"], **FAST)
    path = tmp_path / "scene.json"
    scene.save(path)
    data = json.loads(path.read_text())
    assert data["settings"]["empty_space_skipping"] is True
    assert data["settings"]["min_transmittance"] == 0.2
    back = cu.load_scene(path)
    assert back.settings == scene.settings
    # A scene file from before the setting existed loads with the defaults.
    del data["settings"]["empty_space_skipping"], data["settings"]["min_transmittance"]
    path.write_text(json.dumps(data))
    assert cu.load_scene(path).settings.empty_space_skipping is True


def test_return_stats_bad_input():
    scene = SCENES["gaussian_cumulus"]
    cam = scene.default_camera()
    with pytest.raises(ValueError, match="backend='cpu'"):
        cu.render(scene, cam, 8, 6, backend="gl", return_stats=True)
    with pytest.raises(TypeError, match="return_stats"):
        cu.render_cpu(scene, cam, 8, 6, return_stats="yes")
    vol = cu.Scene(
        clouds=[
            scene.clouds[0],
            cu.VolumeCloud(np.ones((4, 4, 4), np.float32), ((0, 0, 0), (1, 1, 1))),
        ],
        settings=cu.RenderSettings(lighting="paper"),
    )
    with pytest.raises(ValueError, match="2018 clouds"):
        cu.render_cpu(vol, cam, 8, 6, return_stats=True)
    with pytest.raises(ValueError, match="min_transmittance"):
        args = _args(scene, cam)
        args["settings"].min_transmittance = 1.5
        _core.render_cpu(**args)


def _args(scene: cu.Scene, cam: cu.Camera) -> dict:
    from cumuli.rendering.marcher_cpu import render_cpu_args

    return render_cpu_args(scene, cam, 8, 6)


@pytest.mark.gl
@pytest.mark.parametrize("lighting", ["paper", "physical"])
@pytest.mark.parametrize("name", sorted(SCENES))
def test_gl_skipping_is_exact_and_matches_cpu(renderer, name, lighting):
    scene = _with(SCENES[name], exact_noise=True, lighting=lighting, physical_resolution=12)
    cam = scene.default_camera()
    off = renderer.render(_with(scene, empty_space_skipping=False), cam, W, H)
    on = renderer.render(scene, cam, W, H)
    assert_image_close(on, off, **only(mean_abs=2e-3))
    np.testing.assert_array_equal(on, off)  # measured: bit for bit on llvmpipe
    cpu = cu.render_cpu(scene, cam, W, H)
    diff = np.abs(on.astype(np.float64) - cpu)
    assert (diff.reshape(-1, 4).mean(0) <= 1e-3).all()  # test_gl_cpu_parity.py's tolerance
    assert ((diff > 5e-2).any(axis=-1)).sum() <= int(1e-3 * W * H)
    fast = _with(scene, **FAST)
    gl_fast = renderer.render(fast, cam, W, H)
    assert_image_close(gl_fast, off, **only(mean_abs=2e-3))
    assert np.abs(gl_fast.astype(np.float64) - cu.render_cpu(fast, cam, W, H)).mean() <= 1e-3


def _grazing_directions(cloud: cu.Cloud, origin: np.ndarray, rng, n: int) -> np.ndarray:
    """Random directions, half of them aimed at points on the primitives' grown surfaces (the
    rays the cull must not lose) and a few of those nudged by 1e-4 rad either way."""
    dirs = rng.normal(size=(n, 3))
    j = rng.integers(0, cloud.n, n // 2)
    u = rng.normal(size=(n // 2, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    surface = cloud.centres[j] + np.einsum("nij,nj->ni", cloud.rotations[j], u * cloud.radii[j])
    aim = surface - origin
    aim /= np.linalg.norm(aim, axis=1, keepdims=True)
    aim += rng.normal(scale=1e-4, size=aim.shape)
    dirs[: n // 2] = aim
    return (dirs / np.linalg.norm(dirs, axis=1, keepdims=True)).astype(np.float32)


@pytest.mark.parametrize("model", ["spheroid", "metaball"])
@pytest.mark.parametrize("distance", [0.0, 6.0, 40.0, 3000.0])
def test_camera_fan_culls_no_candidate(model, distance):
    """The camera rays' candidates (the fan culls each primitive by a cone around its bounding
    sphere) are those of testing every primitive, bit for bit: origins inside the cloud, near,
    far and very far, elongated primitives and rays grazing their surfaces."""
    rng = np.random.default_rng(int(distance) + 7)
    cloud = _random_cloud(model, 8, n=40)
    radii = cloud.radii * np.array([6.0, 1.0, 0.2], np.float32)  # up to 30:1 elongation
    cloud = cu.Cloud(cloud.centres, radii, cloud.rotations, model=model)
    direction = rng.normal(size=3)
    origin = (direction / np.linalg.norm(direction) * distance).astype(np.float32)
    dirs = _grazing_directions(cloud, origin, rng, 20_000)
    centres, radii, rotations, model_name = cloud.core_args()[:4]
    fan, each = _core.camera_candidates(
        centres, radii, rotations, model_name, tuple(map(float, origin)), dirs, 64
    )
    np.testing.assert_array_equal(fan, each)
    hits = (each[:, :, 0] >= 0).sum(axis=1)
    assert (hits > 0).mean() > 0.3  # the rays met primitives ...
    if distance >= 40.0:
        assert (hits < cloud.n).all() and (hits == 0).sum() > 1000  # ... and far ones were culled


@pytest.mark.parametrize("model", ["spheroid", "metaball"])
@pytest.mark.parametrize(
    "where, size, fov",
    [("far", (160, 120), 38.0), ("near", (97, 61), 70.0), ("inside", (64, 48), 90.0),
     ("wide", (800, 48), 12.0)],
)  # fmt: skip
def test_screen_tile_bins_lose_no_candidate(model, where, size, fov):
    """The marchers' fans sort the primitives into one bin per screen tile; every pixel's ray
    gets the candidates of testing every primitive, bit for bit: cameras far, near, inside the
    cloud, a wide strip (16-pixel tiles), elongated primitives. Far away, the bins hold a fraction
    of the primitives (the point of them)."""
    rng = np.random.default_rng(len(where) + 11)
    cloud = _random_cloud(model, 9, n=60)
    radii = cloud.radii * np.array([4.0, 1.0, 0.3], np.float32)
    cloud = cu.Cloud(cloud.centres, radii, cloud.rotations, model=model)
    lo, hi = (np.asarray(b, np.float64) for b in cloud.bounds())
    centre, extent = (lo + hi) / 2, float(np.linalg.norm(hi - lo))
    away = {"far": 2.0 * extent, "near": 0.6 * extent, "inside": 0.0, "wide": 1.2 * extent}[where]
    offset = rng.normal(size=3)
    position = centre + away * offset / np.linalg.norm(offset)
    target = centre if away > 0 else centre + offset
    camera = _core.CameraParams()
    camera.position, camera.target, camera.fov = tuple(position), tuple(target), fov
    centres, radii, rotations, model_name = cloud.core_args()[:4]
    binned, each, tested = _core.screen_candidates(
        centres, radii, rotations, model_name, _core.Viewport(camera, *size), 64
    )
    np.testing.assert_array_equal(binned, each)
    hits = (each[..., 0] >= 0).sum(axis=-1)
    assert (hits > 0).mean() > 0.02  # the rays met primitives
    assert (tested >= hits).all()
    if where == "far" and model == "spheroid":  # metaballs' candidates are grown by √n
        assert tested.mean() < 0.5 * cloud.n


def test_camera_candidates_bad_input():
    cloud = _random_cloud("spheroid", 1)
    centres, radii, rotations, model_name = cloud.core_args()[:4]
    with pytest.raises(ValueError, match="capacity"):
        _core.camera_candidates(
            centres, radii, rotations, model_name, (0, 0, 0), np.ones((2, 3)), 0
        )
    with pytest.raises((ValueError, TypeError), match="dirs"):
        _core.camera_candidates(centres, radii, rotations, model_name, (0, 0, 0), np.ones((2, 2)))
