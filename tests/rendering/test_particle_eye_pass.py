"""Harris 2002 eye pass and the shared sprite pipeline (the
billboard mode of Torchelsen & Musse 2005): analytic single/overlapping particles, phase ratios,
the Fig. 9/10 statistic, GL vs CPU parity, culling and tiling."""

from __future__ import annotations

import math

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.gl.sprites import (
    SpriteLayerRenderer,
    Sprites,
    camera_dict,
    draw_sprites_cpu,
)
from cumuli.light.particles import ParticleLight, SpriteSettings, particle_light
from cumuli.model.particles import ParticleCloud, particle_cumulus
from cumuli.rendering.particles import draw_particles_cpu, draw_particles_gl, particle_sprites
from cumuli.testing import assert_image_close, only

EYE = cu.Camera((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), fov=60.0)
W = H = 33  # odd: the optical axis hits the centre of pixel (16, 16)


def hand_light(pc: ParticleCloud, values, suns) -> ParticleLight:
    dirs = np.array([s.direction for s in suns], np.float32)
    return ParticleLight(np.asarray(values, np.float32).reshape(pc.n, len(suns)), dirs)


BACKENDS = ["cpu", pytest.param("gl", marks=pytest.mark.gl)]


def draw(backend: str, *args, **kwargs) -> np.ndarray:
    """The particle layer by the CPU twin or the GL pipeline (same arguments)."""
    if backend == "gl":
        return draw_particles_gl(*args, **kwargs)
    return draw_particles_cpu(*args, **kwargs)


def kernel(kind: str, peak: float, d) -> np.ndarray:
    return _core.splat_kernel(kind, peak, np.asarray(d, np.float32))


@pytest.mark.parametrize("backend", BACKENDS)
def test_single_particle_centre_profile_and_footprint(backend: str) -> None:
    """§10.2.1: centre pixel = peak·C + (1 − peak·α)·sky; profile K(d); r_px = r(H/2)/(Z·th)."""
    sun = cu.Sun((0.0, 1.0, 0.0), colour=(1.0, 0.9, 0.8), intensity=2.0)
    pc = ParticleCloud([(0.0, 0.0, 10.0)], 1.0, 8.0, 0.9)
    light = hand_light(pc, [0.7], [sun])
    s = SpriteSettings(kernel="hermite", peak=0.8, ambient=(0.05, 0.05, 0.1))
    layer = draw(backend, pc, light, sun, EYE, W, H, s)
    c_k = np.array(s.ambient) + 0.9 * 8 / (4 * math.pi) * 0.7 * 0.75 * np.array(sun.radiance)
    alpha = 1 - math.exp(-8)
    assert layer[16, 16, :3] == pytest.approx(0.8 * c_k, rel=1e-6)
    assert layer[16, 16, 3] == pytest.approx(0.8 * alpha, rel=1e-6)
    sky = cu.Sky().colour(EYE.ray_directions(W, H), sun)
    rgb = layer[..., :3] + (1 - layer[..., 3:]) * sky
    assert rgb[16, 16] == pytest.approx(0.8 * c_k + (1 - 0.8 * alpha) * sky[16, 16], rel=1e-6)
    r_px = 1.0 * (H / 2) / (10 * math.tan(math.radians(30)))
    for k in range(4):  # along the row through the centre: d = k/r_px
        want = kernel("hermite", 0.8, [k / r_px])[0] * alpha
        assert layer[16, 16 + k, 3] == pytest.approx(want, rel=1e-5, abs=1e-7)
    nonzero = np.argwhere(layer[16, :, 3] > 0)[:, 0]
    assert nonzero.max() - 16 == math.floor(r_px - 1e-6)
    # Off-centre particles: the analytic projection.
    pts = np.array([(1.5, -2.0, 12.0), (-3.0, 1.0, 7.0)], np.float32)
    proj = _core.project_sprites(
        pts, np.ones((2, 2), np.float32), np.zeros(2, np.float32), camera_dict(EYE, 40, 30)
    )
    th = math.tan(math.radians(30))
    for (x, y, z), (jc, ic, hx, hy, depth, vis) in zip(pts.astype(float), proj, strict=True):
        # camera right = f × up = (0,0,1) × (0,1,0) = (−1, 0, 0)
        assert jc == pytest.approx(20 * (-x / (z * th * 40 / 30) + 1), rel=1e-5)
        assert ic == pytest.approx(15 * (1 - y / (z * th)), rel=1e-5)
        assert hx == hy == pytest.approx(15 / (z * th), rel=1e-5)
        assert depth == pytest.approx(z) and vis == 1


@pytest.mark.parametrize("backend", BACKENDS)
def test_alpha_is_one_minus_product_and_colour_is_over(backend: str) -> None:
    """§10.2.2: A = 1 − Π(1 − w_k α_k), C the back-to-front over of w_k C_k."""
    sun = cu.Sun((0.0, 1.0, 0.0))
    taus = np.array([0.3, 0.6, 1.1])
    pc = ParticleCloud([(0, 0, 14.0), (0, 0, 12.0), (0, 0, 10.0)], 1.0, taus, 0.9)
    light = hand_light(pc, [1.0, 0.5, 0.25], [sun])
    layer = draw(backend, pc, light, sun, EYE, W, H)
    alphas = 1 - np.exp(-taus)
    assert layer[16, 16, 3] == pytest.approx(1 - np.prod(1 - alphas), rel=1e-6)
    colour = 0.0
    for tau, a, i in zip(taus, alphas, (1.0, 0.5, 0.25), strict=True):  # back to front
        colour = 0.9 * tau / (4 * math.pi) * i * 0.75 + (1 - a) * colour
    assert layer[16, 16, 0] == pytest.approx(colour, rel=1e-5)


@pytest.mark.parametrize("backend", BACKENDS)
def test_over_depends_on_order_unless_disjoint(backend: str) -> None:
    """§10.2.3: swapping two overlapping sprites changes the image; disjoint ones do not."""

    def layer_of(order: list[int], centres: list[tuple]) -> np.ndarray:
        sp = Sprites(
            centres=np.array(centres)[order],
            half_sizes=np.full(2, 1.0),
            colours=np.array([(1, 0, 0), (0, 0, 1)], np.float32)[order],
            alpha=np.array([0.9, 0.5])[order],
        )
        if backend == "gl":
            with SpriteLayerRenderer() as r:
                return r.draw(sp, EYE, W, H)
        return draw_sprites_cpu(sp, EYE, W, H)

    overlapping = [(0.2, 0, 10), (-0.2, 0, 10)]
    assert not np.allclose(layer_of([0, 1], overlapping), layer_of([1, 0], overlapping))
    disjoint = [(2.5, 0, 10), (-2.5, 0, 10)]
    assert np.array_equal(layer_of([0, 1], disjoint), layer_of([1, 0], disjoint))
    # The analytic over at the centre of the overlap: blue (α 0.5) over red (α 0.9).
    img = layer_of([0, 1], [(0, 0, 10), (0, 0, 10)])
    assert img[16, 16, :3] == pytest.approx([0.5 * 1, 0, 1.0], rel=1e-6)
    assert img[16, 16, 3] == pytest.approx(1 - 0.1 * 0.5, rel=1e-6)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("phase, g", [("rayleigh", 0.0), ("isotropic", 0.0), ("hg", 0.6)])
def test_phase_ratio_forward_vs_side(phase: str, g: float, backend: str) -> None:
    """§10.2.4 ([H] Figs. 11/12): an isolated particle lit with i = 1 seen at 0° and 90°."""
    pc = ParticleCloud([(0, 0, 10.0)], 1.0, 8.0, 0.9)
    s = SpriteSettings(phase=phase, hg_g=g, solid_angle=0.05)
    centre = []
    for sun in (cu.Sun((0, 0, 1)), cu.Sun((0, 1, 0))):  # cos θ = 1 (into the sun), 0
        layer = draw(backend, pc, hand_light(pc, [1.0], [sun]), sun, EYE, W, H, s)
        centre.append(layer[16, 16, 0])
    want = {
        "rayleigh": 2.0,
        "isotropic": 1.0,
        "hg": ((1 + g) / (1 - g) ** 2) / ((1 - g * g) / (1 + g * g) ** 1.5),
    }[phase]
    assert centre[0] / centre[1] == pytest.approx(want, rel=1e-5)


def test_multiple_forward_scattering_brightens_shadowed_particles() -> None:
    """§10.2.5 (Fig. 9 vs 10): particles read back under ≥ 3 earlier footprints get more than
    twice the light with forward scattering than without."""
    pc = particle_cumulus(n_particles=200, seed=0)
    sun = cu.Sun()
    s = SpriteSettings()
    geom, index, *_ = _core.particle_light_splats(
        *pc.core_args(), np.array([sun.direction], np.float32), s.light_dict()
    )
    g = geom[0]
    count = np.zeros(pc.n, int)
    for k in range(pc.n):
        px = np.floor(g[k, :2]) + 0.5
        count[index[0, k]] = int((np.hypot(*(px - g[:k, :2]).T) < g[:k, 2]).sum())
    deep = count >= 3
    with_fwd = particle_light(pc, sun, s).light[deep, 0].mean()
    without = particle_light(pc, sun, SpriteSettings(forward=False)).light[deep, 0].mean()
    print(
        f"{deep.sum()} particles under ≥ 3 footprints: mean i {with_fwd:.4g} vs {without:.4g}"
        f" (×{with_fwd / without:.3g})"
    )
    assert deep.sum() >= 10 and with_fwd > 2 * without


def test_texture_mode_matches_numpy_reference() -> None:
    """Billboard mode: bilinear atlas cell (texel centres, clamp to the cell), barycentric vertex
    colours over (v0,v1,v2)/(v0,v2,v3), rgb = colour·tex.rgb·a, a = tex.a·alpha."""
    rng = np.random.default_rng(3)
    atlas = rng.random((8, 12, 4)).astype(np.float32)  # 3 × 2 cells of 4 × 4 texels
    colours = rng.random((1, 4, 3)).astype(np.float32)
    sp = Sprites(
        centres=[(0.3, -0.2, 10.0)],
        half_sizes=[(3.0, 2.0)],
        colours=colours,
        alpha=[0.7],
        rotation=[30.0],
        texture=[4],
    )
    layer = draw_sprites_cpu(sp, EYE, W, H, atlas=atlas, atlas_grid=(3, 2))
    jc, ic, hx, hy, _, _ = _core.project_sprites(
        sp.centres, sp.half_sizes, sp.radians(), camera_dict(EYE, W, H)
    )[0]
    cr, sr = math.cos(math.radians(30)), math.sin(math.radians(30))
    checked = 0
    for i in range(H):
        for j in range(W):
            dx, dy = j + 0.5 - jc, i + 0.5 - ic
            s, t = (dx * cr - dy * sr) / hx, (-dx * sr - dy * cr) / hy
            if max(abs(s), abs(t)) > 1:
                assert not layer[i, j].any()
                continue
            if max(abs(s), abs(t)) > 0.999:  # the float32 edge test may go either way here
                continue
            c0, c1, c2, c3 = colours[0].astype(np.float64)
            col = (
                c0 * (1 - s) / 2 + c1 * (s - t) / 2 + c2 * (t + 1) / 2
                if s >= t
                else c0 * (1 - t) / 2 + c2 * (s + 1) / 2 + c3 * (t - s) / 2
            )
            tx, ty = 4 + (s + 1) / 2 * 4, 4 + (1 - t) / 2 * 4  # cell 4: column 1, row 1
            u, v = tx - 0.5, ty - 0.5
            x0, y0 = math.floor(u), math.floor(v)
            wx, wy = u - x0, v - y0
            xs = [min(max(x, 4), 7) for x in (x0, x0 + 1)]
            ys = [min(max(y, 4), 7) for y in (y0, y0 + 1)]
            a64 = atlas.astype(np.float64)
            top = a64[ys[0], xs[0]] * (1 - wx) + a64[ys[0], xs[1]] * wx
            bot = a64[ys[1], xs[0]] * (1 - wx) + a64[ys[1], xs[1]] * wx
            tex = top * (1 - wy) + bot * wy
            a = tex[3] * 0.7
            assert layer[i, j, 3] == pytest.approx(a, abs=2e-6)
            assert layer[i, j, :3] == pytest.approx(col * tex[:3] * a, abs=2e-6)
            checked += 1
    assert checked > 100


def test_corners_follow_the_raster_convention() -> None:
    """Sprites.corners: v0..v3 project to the rectangle the rasteriser fills, (s, t) = (±1, ±1)."""
    sp = Sprites(centres=[(0.5, 0.3, 12.0)], half_sizes=[(2.0, 1.0)], colours=[(1, 1, 1)],
                 alpha=[1.0], rotation=[25.0])  # fmt: skip
    corners = sp.corners(EYE)[0]
    cam = camera_dict(EYE, W, H)
    jc, ic, hx, hy, *_ = _core.project_sprites(sp.centres, sp.half_sizes, sp.radians(), cam)[0]
    tiny = np.full((4, 2), 1e-3, np.float32)
    proj = _core.project_sprites(corners.astype(np.float32), tiny, np.zeros(4, np.float32), cam)
    c, s_ = math.cos(math.radians(25)), math.sin(math.radians(25))
    for (s, t), (j, i) in zip([(-1, -1), (1, -1), (1, 1), (-1, 1)], proj[:, :2], strict=True):
        # screen offset of (s, t): s·hx·(cos ψ, −sin ψ) + t·hy·(−sin ψ, −cos ψ)
        assert j == pytest.approx(jc + s * hx * c - t * hy * s_, abs=1e-3)
        assert i == pytest.approx(ic - s * hx * s_ - t * hy * c, abs=1e-3)


def test_culling_and_threads_change_nothing() -> None:
    """§10.2.8 (CPU): culling never changes a pixel; the thread count neither."""
    pc = particle_cumulus(n_particles=400, seed=2)
    sun = cu.Sun()
    light = particle_light(pc, sun)
    cam = cu.Camera((8, 4, -30), (3, 2, 0), fov=35)  # part of the cloud off screen
    sprites = particle_sprites(pc, light, sun, cam, 64, 48)
    assert 0 < len(sprites) < pc.n
    culled = draw_particles_cpu(pc, light, sun, cam, 64, 48)
    full = draw_particles_cpu(pc, light, sun, cam, 64, 48, cull=False, threads=1)
    assert np.array_equal(culled, full) and culled[..., 3].max() > 0.5
    away = cu.Camera((0, 0, -40), (0, 0, -80))
    assert len(particle_sprites(pc, light, sun, away, 64, 48)) == 0
    assert not draw_particles_cpu(pc, light, sun, away, 64, 48).any()
    inside = cu.Camera((0, 2, 0), (0, 2, 5), fov=80)  # eye inside the cloud: near plane culls
    a = draw_particles_cpu(pc, light, sun, inside, 40, 30)
    b = draw_particles_cpu(pc, light, sun, inside, 40, 30, cull=False)
    assert np.array_equal(a, b)


def test_sort_keys() -> None:
    pc = ParticleCloud([(5, 0, 9.0), (0, 0, 10.0), (0, 0, 5.0)], 0.5)
    sun = cu.Sun()
    light = hand_light(pc, [1, 1, 1], [sun])
    dist = particle_sprites(pc, light, sun, EYE, W, H, SpriteSettings(sort="distance"))
    depth = particle_sprites(pc, light, sun, EYE, W, H, SpriteSettings(sort="depth"))
    assert dist.centres[:, 2].tolist() == [9.0, 10.0, 5.0]  # |(5, 0, 9)| = 10.3 > 10
    assert depth.centres[:, 2].tolist() == [10.0, 9.0, 5.0]


def test_eye_pass_bad_input() -> None:
    pc = particle_cumulus(n_particles=30, seed=1)
    sun = cu.Sun()
    light = particle_light(pc, sun)
    with pytest.raises(ValueError, match="lights"):
        draw_particles_cpu(pc, light, [sun, sun], EYE, 8, 8)
    with pytest.raises(ValueError, match="relight"):
        draw_particles_cpu(pc, light, cu.Sun((0, 1, 0)), EYE, 8, 8)
    with pytest.raises(ValueError, match="rows"):
        draw_particles_cpu(particle_cumulus(n_particles=31, seed=1), light, sun, EYE, 8, 8)
    with pytest.raises(TypeError, match="camera"):
        draw_particles_cpu(pc, light, sun, "eye", 8, 8)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="width"):
        draw_particles_cpu(pc, light, sun, EYE, 0, 8)
    with pytest.raises(ValueError, match="ambient"):
        draw_particles_cpu(pc, light, sun, EYE, 8, 8, ambient=(-1, 0, 0))
    ok = {"centres": [(0, 0, 5)], "half_sizes": [1.0], "colours": [(1, 1, 1)], "alpha": [0.5]}
    for change, error, match in (
        ({"half_sizes": [0.0]}, ValueError, "half_sizes"),
        ({"alpha": [1.5]}, ValueError, "alpha"),
        ({"colours": [(1, 1)]}, ValueError, "colours"),
        ({"texture": [-2]}, ValueError, "texture"),
        ({"texture": [0.5]}, TypeError, "texture"),
        ({"rotation": [float("inf")]}, ValueError, "rotation"),
    ):
        with pytest.raises(error, match=match):
            Sprites(**(ok | change))
    textured = Sprites(**(ok | {"texture": [3]}))
    with pytest.raises(ValueError, match="atlas"):
        draw_sprites_cpu(textured, EYE, 8, 8)
    with pytest.raises(ValueError, match="atlas"):
        draw_sprites_cpu(textured, EYE, 8, 8, atlas=np.ones((4, 4, 4)), atlas_grid=(2, 1))
    with pytest.raises(ValueError, match="atlas_grid"):
        draw_sprites_cpu(textured, EYE, 8, 8, atlas=np.ones((4, 6, 4)), atlas_grid=(4, 4))
    with pytest.raises(ValueError, match="kernel"):
        draw_sprites_cpu(Sprites(**ok), EYE, 8, 8, kernel="box")


# --- GL ------------------------------------------------------------------------------------------
def assert_parity(gl: np.ndarray, cpu: np.ndarray) -> None:
    diff = np.abs(gl.astype(np.float64) - cpu)
    assert diff.reshape(-1, 4).mean(axis=0).max() <= 1e-5
    assert diff.max() <= 1e-4


@pytest.mark.gl
@pytest.mark.parametrize("preset", ["paper", "skyworks"])
def test_particles_gl_matches_cpu(gl_context, preset: str) -> None:
    """§10.2.7: mean |Δ| ≤ 1e−5 per channel, max ≤ 1e−4."""
    pc = particle_cumulus(n_particles=600, seed=3)
    lights = [cu.Sun(), cu.Sun((-0.6, 0.4, 0.2), colour=(1.0, 0.6, 0.7), intensity=0.5)]
    s = SpriteSettings.preset(preset, phase="hg", hg_g=0.3, solid_angle=0.09)
    light = particle_light(pc, lights, s)
    cam = cu.Camera((5, 6, -40), (0, 3, 0), fov=40)
    cpu = draw_particles_cpu(pc, light, lights, cam, 96, 72, s)
    with SpriteLayerRenderer(gl_context) as r:
        gl = draw_particles_gl(pc, light, lights, cam, 96, 72, s, renderer=r)
        assert r.sprites_drawn == len(particle_sprites(pc, light, lights, cam, 96, 72, s))
    assert cpu[..., 3].mean() > 0.05
    assert_parity(gl, cpu)


@pytest.mark.gl
def test_billboards_gl_matches_cpu(gl_context) -> None:
    """The Torchelsen mode: rotated textured quads with per-vertex colours (exact texelFetch)."""
    rng = np.random.default_rng(0)
    n = 80
    atlas = rng.random((64, 64, 4)).astype(np.float32)
    atlas[..., 3] *= (
        np.hanning(18)[1:17][None, :]
        .repeat(16, 0)
        .reshape(16, 16)
        .clip(0)[np.arange(64)[:, None] % 16, np.arange(64)[None, :] % 16]
    )  # α → 0 at every cell border
    sp = Sprites(
        centres=rng.normal(size=(n, 3)) * 3,
        half_sizes=rng.uniform(0.5, 2, (n, 2)),
        colours=rng.random((n, 4, 3)),
        alpha=rng.random(n),
        rotation=rng.uniform(0, 360, n),
        texture=rng.integers(-1, 16, n),
    )
    cam = cu.Camera((0, 0, -20), (0, 0, 0), fov=40)
    cpu = draw_sprites_cpu(sp, cam, 120, 90, atlas=atlas, atlas_grid=(4, 4), kernel="hermite")
    with SpriteLayerRenderer(gl_context) as r:
        gl = r.draw(sp, cam, 120, 90, atlas=atlas, atlas_grid=(4, 4), kernel="hermite")
        fast = r.draw(
            sp, cam, 120, 90, atlas=atlas, atlas_grid=(4, 4), kernel="hermite", exact=False
        )
    assert cpu[..., 3].mean() > 0.1
    assert_parity(gl, cpu)
    assert_image_close(fast, cpu, **only(mean_abs=1e-2))  # hardware filter: close, not exact


@pytest.mark.gl
def test_gl_tiling_and_culling_change_nothing(gl_context) -> None:
    """§10.2.8 (GL): tiles of any size and culling give the same image bit for bit."""
    pc = particle_cumulus(n_particles=300, seed=4)
    sun = cu.Sun()
    light = particle_light(pc, sun)
    cam = cu.Camera((3, 4, -35), (0, 3, 0), fov=45)
    with SpriteLayerRenderer(gl_context) as big, SpriteLayerRenderer(gl_context, tile=24) as small:
        a = draw_particles_gl(pc, light, sun, cam, 70, 50, renderer=big)
        b = draw_particles_gl(pc, light, sun, cam, 70, 50, renderer=small)
        c = draw_particles_gl(pc, light, sun, cam, 70, 50, renderer=small, cull=False)
    assert np.array_equal(a, b) and np.array_equal(a, c) and a[..., 3].max() > 0.5


@pytest.mark.gl
def test_renderer_release(gl_context) -> None:
    r = SpriteLayerRenderer(gl_context)
    r.release()
    r.release()
    sp = Sprites(centres=[(0, 0, 5)], half_sizes=[1.0], colours=[(1, 1, 1)], alpha=[0.5])
    with pytest.raises(ValueError, match="released"):
        r.draw(sp, EYE, 8, 8)
