"""Dynamic impostors for every kind of cloud (Harris 2002 §3–§4): display against direct rendering,
exact GL/CPU parity, popping against the tolerance, screen impostors, invalidation, culling, the
texture pool, statistics, marched clouds and volumes through impostors, and
`render_frames(impostors=True)`."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.testing import assert_image_close, only

W, H = 96, 72
SUN = cu.Sun(direction=(0.4, 0.8, -0.3), intensity=2.0)
CAMERA = cu.Camera((10.0, 8.0, -70.0), (0.0, 2.0, 0.0), fov=35)
INSIDE = cu.Camera((0.0, 2.0, -3.0), (0.0, 2.0, 10.0), fov=60)


def puff(seed: int = 5, centre: tuple[float, float, float] = (0, 2, 0)) -> cu.ParticleCloud:
    return cu.particle_cumulus(centre, 300, seed=seed, radius=(2.0, 3.5))


def scene(**impostor: object) -> cu.Scene:
    return cu.Scene(
        [puff()], sun=SUN, sprite_settings=cu.SpriteSettings(ambient=(0.1, 0.1, 0.1)),
        impostor_settings=cu.ImpostorSettings(**impostor),
    settings=cu.RenderSettings(lighting="paper"))  # fmt: skip


def test_display_at_the_generation_viewpoint_is_a_resampling() -> None:
    """§10.3.1: from the eye it was made at, an impostor differs from direct rendering only by
    resampling: mean |Δ| ≤ 1e−2 at res = f_px·2R/d, decreasing as the resolution doubles."""
    direct = cu.render(scene(), CAMERA, W, H, backend="cpu")
    errors = []
    for res_scale in (1.0, 2.0, 4.0):
        cache = cu.ImpostorCache()
        img = cu.render(scene(res_scale=res_scale), CAMERA, W, H, backend="cpu", impostors=cache)
        assert cache.history[-1]["updates"] == {"missing": 1}
        errors.append(float(np.abs(img - direct).mean()))
    assert errors[0] <= 1e-2 and errors[0] > errors[1] > errors[2]


@pytest.mark.gl
def test_exact_display_gl_and_cpu_agree(exact_impostors_agree: Callable) -> None:
    """§10.3.1: exact mode (texelFetch blends) GL against the C++ display ≤ 1e−5, both at the
    generation viewpoint and from a moved eye that reuses the impostor; the hardware filter is
    close too."""
    sc = scene(exact=True, tolerance=1.0)
    moved = cu.Camera((10.6, 8.2, -69.5), (0.0, 2.0, 0.0), fov=35)
    with cu.Renderer() as r:
        _, gl_cache, _ = exact_impostors_agree(r, sc, [CAMERA, moved], W, H)
        assert gl_cache.history[-1]["updates"] == {}  # reused from the moved eye
        fast = r.render(scene(tolerance=1.0), moved, W, H, impostors=cu.ImpostorCache())
    fresh = cu.render_cpu(scene(tolerance=1.0), moved, W, H, impostors=cu.ImpostorCache())
    assert_image_close(fast, fresh, **only(mean_abs=1e-3))


def popping(tolerance: float) -> float:
    """§10.3.4: mean over the impostor-update frames of max|f_t − f_{t−1}|, minus the same for
    direct rendering, along a slow orbit."""
    sc = scene(tolerance=tolerance)
    cache = cu.ImpostorCache()
    cams = cu.orbit((0, 2, 0), 70, 40, height=6, degrees=20)
    prev = prev_direct = None
    pops = []
    for cam in cams:
        img = cu.render(sc, cam, 64, 48, backend="cpu", impostors=cache)
        direct = cu.render(sc, cam, 64, 48, backend="cpu")
        if prev is not None and cache.history[-1]["updates"]:
            pops.append(np.abs(img - prev).max() - np.abs(direct - prev_direct).max())
        prev, prev_direct = img, direct
    return float(np.mean(pops))


def test_popping_grows_with_the_tolerance() -> None:
    p = [popping(t) for t in (0.15, 0.5, 1.0)]
    assert p[0] < p[1] < p[2]


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_screen_impostors_inside_the_cloud(backend: str) -> None:
    """§10.3.7: with the eye inside, a ⌈W/4⌉×⌈H/4⌉ screen impostor regenerated every frame; the
    error against direct rendering grows as the resolution drops (1/2, 1/4, 1/8)."""
    direct = cu.render(scene(), INSIDE, W, H, backend=backend)
    errors = []
    for factor in (2, 4, 8):
        cache = cu.ImpostorCache()
        for _ in range(3):
            img = cu.render(scene(inside_factor=factor), INSIDE, W, H, backend=backend,
                            impostors=cache)  # fmt: skip
        assert [h["updates"] for h in cache.history] == [{"missing": 1}] + [{"screen": 1}] * 2
        assert cache.history[-1]["screen"] == 1
        assert cache.entries[0].image.shape == (-(-H // factor), -(-W // factor), 4)
        errors.append(float(np.abs(img - direct).mean()))
    assert errors[0] < errors[1] < errors[2] and errors[1] < 5e-3


def test_changes_invalidate_and_translation_keeps_the_impostor() -> None:
    """§10.3.8: never reused after the light or the cloud changed; a pure translation (wind)
    keeps it, displayed moved with the cloud."""
    sc = scene()
    cache = cu.ImpostorCache()
    first = cu.render(sc, CAMERA, W, H, backend="cpu", impostors=cache)
    cu.render(sc, CAMERA, W, H, backend="cpu", impostors=cache)
    assert cache.history[-1]["updates"] == {}
    off = (3.3, 0.7, -2.1)
    moved_scene = sc.replace(clouds=[sc.clouds[0].translated(off)])
    moved_cam = cu.Camera(tuple(np.add(CAMERA.position, off)), tuple(np.add(CAMERA.target, off)),
                          fov=35)  # fmt: skip
    moved = cu.render(moved_scene, moved_cam, W, H, backend="cpu", impostors=cache)
    assert cache.history[-1]["updates"] == {}
    np.testing.assert_allclose(moved, first, atol=1e-5)
    # The same translation seen from the old eye is a lateral move: α_trans decides.
    cu.render(moved_scene, CAMERA, W, H, backend="cpu", impostors=cache)
    assert cache.history[-1]["updates"] == {"translation": 1}
    cu.render(sc.replace(clouds=[puff(seed=6)]), CAMERA, W, H, backend="cpu", impostors=cache)
    assert cache.history[-1]["updates"] == {"cloud": 1}
    for changed in (
        sc.replace(clouds=[puff(seed=6)], sun=cu.Sun(SUN.direction, (1.0, 0.5, 0.2), 2.0)),
        sc.replace(clouds=[puff(seed=6)], sun=cu.Sun((0.0, 1.0, 0.0), intensity=2.0)),
        sc.replace(clouds=[puff(seed=6)], sprite_settings=cu.SpriteSettings(phase="isotropic")),
    ):
        img = cu.render(changed, CAMERA, W, H, backend="cpu", impostors=cache)
        assert cache.history[-1]["updates"] == {"light": 1}
        direct = cu.render(changed, CAMERA, W, H, backend="cpu")
        assert_image_close(img, direct, **only(mean_abs=1e-2))


def field() -> cu.Scene:
    clouds = [puff(seed=k, centre=(40.0 * (k % 3) - 40, 0, 30.0 * (k // 3))) for k in range(6)]
    return cu.Scene(
        clouds,
        sun=SUN,
        impostor_settings=cu.ImpostorSettings(release_after=3),
        settings=cu.RenderSettings(lighting="paper"),
    )


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_culling_never_changes_the_image_and_releases_after_n_frames(backend: str) -> None:
    sc = field()
    # Turning on the spot in the middle of the field: clouds leave and enter the view.
    eye = np.array([0.0, 5.0, 15.0])
    cams = [
        cu.Camera(tuple(eye), tuple(eye + (np.cos(a), -0.1, np.sin(a))), fov=40)
        for a in np.linspace(0, 2 * np.pi, 10, endpoint=False)
    ]
    culled = []
    with cu.Renderer() if backend == "gl" else _nothing() as r:
        on, off = cu.ImpostorCache(), cu.ImpostorCache()
        no_cull = sc.replace(impostor_settings=cu.ImpostorSettings(release_after=3, cull=False))
        for cam in cams:
            if r is None:
                a = cu.render_cpu(sc, cam, 64, 48, impostors=on)
                b = cu.render_cpu(no_cull, cam, 64, 48, impostors=off)
            else:
                a = r.render(sc, cam, 64, 48, impostors=on)
                b = r.render(no_cull, cam, 64, 48, impostors=off)
            np.testing.assert_array_equal(a, b)
            culled.append(on.history[-1]["culled"])
        assert max(culled) > 0 and off.history[-1]["culled"] == 0
        # Looking away for more than release_after frames drops the impostors (GL: textures go
        # back to the pool).
        away = cu.Camera((0, 200, 15), (0, 300, 35), fov=30)  # above the field, looking up
        for _ in range(5):
            img = (
                r.render(sc, away, 64, 48, impostors=on)
                if r
                else cu.render_cpu(sc, away, 64, 48, impostors=on)
            )
        assert on.stats["impostors"] == 0 and sum(h["released"] for h in on.history) >= 6
        assert img[..., 3].max() == 0.0
        if r is not None:
            assert r.extra("impostors", None).pool.free >= 1


class _nothing:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


def test_stats_count_updates_texels_splats_and_culled() -> None:
    sc = field()
    cache = cu.ImpostorCache()
    cu.render_cpu(sc, CAMERA, 64, 48, impostors=cache)
    s = cache.stats
    assert s["frames"] == 1 and s["updates"]["missing"] == s["impostors"] > 0
    assert s["impostors"] + s["culled"] == 6
    assert s["texels"] == sum(e.image.shape[0] * e.image.shape[1] for e in cache.entries.values())
    # Each generated impostor splats its cloud once (particles off its image are culled).
    assert 0 < s["splats"] <= sum(sc.clouds[k].n for k in cache.entries)
    cu.render_cpu(sc, CAMERA, 64, 48, impostors=cache)
    assert cache.stats["frames"] == 2 and cache.history[-1]["splats"] == 0
    assert cache.stats["updates_per_frame"] == s["impostors"] / 2


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_impostors_for_marched_clouds_and_volumes(backend: str) -> None:
    # Every kind the compositor draws goes through the same cache: a 2018 cumulus (marched), a
    # Gaussian-blob volume and a particle cloud, first frame and a slightly moved eye.
    density, box = puff(seed=9, centre=(-6, 0, 35)).to_volume(16)
    volume = cu.VolumeCloud(density=density, box=box, sigma_t=0.6, albedo=0.9, g=0.2)
    sc = cu.Scene(
        [cu.gaussian_cumulus(centre=(-4.0, 0.0, 0.0), seed=1), volume, puff(seed=8,
         centre=(8, 2, 20))], sun=SUN, noise=cu.Noise(seed=7, size=32),
        settings=cu.RenderSettings(exact_noise=True, absorption=3.0, lighting="paper"),
    )  # fmt: skip
    cache = cu.ImpostorCache()
    for cam in (CAMERA, cu.Camera((10.3, 8.1, -70.0), (0.0, 2.0, 0.0), fov=35)):
        img = cu.render(sc, cam, W, H, backend=backend, impostors=cache)
        direct = cu.render(sc, cam, W, H, backend=backend)
        # Resampling the marched cumulus's pixel-sharp fBm detail costs most (~1e−2 at
        # res = f_px·2R/d, half that at twice the resolution); particles and volume ~6e−4.
        assert_image_close(img, direct, **only(mean_abs=2e-2))
    assert cache.stats["impostors"] == 3 and cache.history[0]["updates"] == {"missing": 3}
    assert cache.history[-1]["updates"].get("missing", 0) == 0


def test_render_frames_with_impostors(tmp_path: Path) -> None:
    sc = scene()
    cams = cu.orbit((0, 2, 0), 70, 4, height=6, degrees=2)
    cache = cu.ImpostorCache()
    paths = cu.render_frames(sc, cams, tmp_path, 48, 36, backend="cpu", progress=False,
                             impostors=cache)  # fmt: skip
    assert len(paths) == 4 and all(p.is_file() for p in paths)
    assert cache.stats["frames"] == 4 and cache.stats["updates"]["missing"] == 1
    assert cu.render_frames(sc, cams[:1], tmp_path / "b", 16, 12, backend="cpu", progress=False,
                            impostors=True)  # fmt: skip


def test_bad_input() -> None:
    with pytest.raises(TypeError, match="impostors"):
        cu.render_cpu(scene(), CAMERA, 16, 12, impostors="yes")
    with pytest.raises(TypeError, match="impostors"):
        cu.render_frames(scene(), [CAMERA], "/tmp/never", impostors=3)
    with pytest.raises(TypeError, match="exact"):
        cu.ImpostorSettings(exact=1)
    with pytest.raises(ValueError, match="tolerance"):
        cu.ImpostorSettings(tolerance=0)
    with pytest.raises(ValueError, match="client"):
        cu.render_frames(scene(), [CAMERA], "/tmp/never", impostors=True, client=object())


@pytest.mark.gl
def test_a_cache_belongs_to_one_renderer() -> None:
    cache = cu.ImpostorCache()
    with cu.Renderer() as a, cu.Renderer() as b:
        a.render(scene(), CAMERA, 16, 12, impostors=cache)
        with pytest.raises(ValueError, match="another Renderer"):
            b.render(scene(), CAMERA, 16, 12, impostors=cache)
        # True: the renderer's own cache, kept across calls.
        b.render(scene(), CAMERA, 16, 12, impostors=True)
        b.render(scene(), CAMERA, 16, 12, impostors=True)
        assert b.impostor_cache.stats["frames"] == 2
    # Once its renderer is closed, a cache moves on to another one and keeps its impostors.
    with cu.Renderer() as c:
        c.render(scene(), CAMERA, 16, 12, impostors=cache)
        assert cache.history[-1]["updates"] == {} and cache.renderer is c
