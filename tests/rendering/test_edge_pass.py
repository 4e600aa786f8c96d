"""The physical mode's edge pass: the outline's pixels marched again with two rays (the
sub-pixels on their diagonal, in an image twice the size) and kept out of the resolve's tent, on
both backends; the rest of the image and the paper mode unchanged."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.rendering.edges import EDGE_RANGE, RAYS, SUB, edge_mask, supersample_edges
from cumuli.rendering.marcher_cpu import combined_stats, edged_args, render_cpu_args
from cumuli.rendering.resolve import tent_filter

W, H = 48, 36


def small_scene(**settings) -> tuple[cu.Scene, cu.Camera]:
    cloud = cu.gaussian_cumulus(seed=3, n=40)
    scene = cu.Scene(
        [cloud], sun=cu.Sun(direction=(0.4, 0.7, 0.3), intensity=6.0),
        settings=cu.RenderSettings(haze=0.0, air_extinction=0.0, physical_resolution=16,
                                   **settings),
    )  # fmt: skip
    lo, hi = (np.asarray(b) for b in cloud.bbox)
    centre = 0.5 * (lo + hi)
    size = float(np.max(hi - lo))
    cam = cu.Camera(position=centre + (0.0, 0.1 * size, -1.6 * size), target=centre, fov=45)
    return scene, cam


def test_the_edge_mask_marks_the_pixels_beside_a_step_in_coverage() -> None:
    alpha = np.zeros((5, 8), np.float32)
    alpha[:, 4:] = 1.0
    mask = edge_mask(alpha)
    # Columns 3 and 4 see both sides of the step in their 3×3 neighbourhood; no others do.
    assert mask[:, [3, 4]].all() and not mask[:, [0, 1, 2, 5, 6, 7]].any()
    # A span at the threshold is not an edge; just above it is.
    assert not edge_mask(np.where(alpha > 0, EDGE_RANGE, 0.0)).any()
    assert edge_mask(np.where(alpha > 0, EDGE_RANGE + 1e-3, 0.0)).any()


def reference_edges(alpha: np.ndarray) -> np.ndarray:
    """edge_mask by its definition: max − min over the nine shifted windows of the padded image."""
    p = np.pad(alpha, 1, mode="edge")
    h, w = alpha.shape
    windows = [p[dy : dy + h, dx : dx + w] for dy in range(3) for dx in range(3)]
    return (np.max(windows, axis=0) - np.min(windows, axis=0)) > EDGE_RANGE


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (6, 1), (2, 2), (37, 53)])
def test_the_edge_mask_is_the_neighbourhoods_span(shape: tuple[int, int]) -> None:
    rng = np.random.default_rng(sum(shape))
    alpha = np.where(rng.random(shape) < 0.5, rng.random(shape), 0.0).astype(np.float32)
    np.testing.assert_array_equal(edge_mask(alpha), reference_edges(alpha))
    # Any thread count gives the same mask; a strided view is read as its values.
    np.testing.assert_array_equal(_core.coverage_edges(alpha, EDGE_RANGE, 1), edge_mask(alpha))
    rgba = np.repeat(alpha[..., None], 4, axis=2)
    np.testing.assert_array_equal(edge_mask(rgba[..., 3]), edge_mask(alpha))


def test_the_edge_mask_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="alpha must be an"):
        edge_mask(np.zeros((3, 3, 1), np.float32))
    with pytest.raises(ValueError, match="non-empty"):
        edge_mask(np.zeros((0, 3), np.float32))
    with pytest.raises(ValueError, match="range must be finite"):
        _core.coverage_edges(np.zeros((2, 2), np.float32), np.nan)


def listed_pixels() -> np.ndarray:
    """Some pixels of the small image, out of order and one twice."""
    rows, cols = np.mgrid[10:20, 5:40:3]
    pixels = np.stack([rows.ravel(), cols.ravel()], axis=1)[::-1]
    return np.concatenate([pixels, pixels[:1]]).astype(np.int32)


def test_the_cpu_marcher_marches_a_list_of_pixels() -> None:
    scene, cam = small_scene(resolve=False)
    args = render_cpu_args(scene, cam, W, H)
    full, stats = _core.render_cpu(**args, return_stats=True)
    pixels = listed_pixels()
    part, part_stats = _core.render_cpu(**args, pixels=pixels, return_stats=True)
    assert part.shape == (len(pixels), 4)
    # The same rays as in the whole image, bit for bit, and their work counted per pixel.
    np.testing.assert_array_equal(part, full[pixels[:, 0], pixels[:, 1]])
    np.testing.assert_array_equal(
        part_stats["fbm_map"], stats["fbm_map"][pixels[:, 0], pixels[:, 1]]
    )
    assert part_stats["fbm_evaluations"] == int(part_stats["fbm_map"].sum())
    # Any thread count gives the same values and totals.
    one = _core.render_cpu(**{**args, "threads": 1}, pixels=pixels, return_stats=True)
    np.testing.assert_array_equal(one[0], part)
    assert one[1]["steps"] == part_stats["steps"]
    assert _core.render_cpu(**args, pixels=np.zeros((0, 2), np.int64)).shape == (0, 4)
    with pytest.raises(ValueError, match="pixels must be an"):
        _core.render_cpu(**args, pixels=np.zeros((3, 3), np.int32))
    with pytest.raises(TypeError, match="pixels must be an integer"):
        _core.render_cpu(**args, pixels=np.zeros((3, 2), np.float32))
    for bad in ([H, 0], [0, W], [-1, 0], [0, 2**40]):
        with pytest.raises(ValueError, match="pixels must lie in the image"):
            _core.render_cpu(**args, pixels=np.array([bad], np.int64))


@pytest.mark.gl
@pytest.mark.parametrize("list_width", [1024, 7])
def test_the_gl_marcher_marches_a_list_of_pixels(
    list_width: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    from cumuli.light.prepare import prepare_light
    from cumuli.rendering import marcher
    from cumuli.rendering.compositor import shared_renderer

    # The pixels are drawn as a list; 7 wide, it wraps over rows and ends in padding.
    monkeypatch.setattr(marcher, "LIST_WIDTH", list_width)

    scene, cam = small_scene(resolve=False)
    lit = prepare_light(scene)
    drawer = shared_renderer().drawer("cloud")
    full = drawer.draw(lit, [0], cam, W, H, True)
    pixels = listed_pixels()
    part = drawer.draw(lit, [0], cam, W, H, True, pixels=pixels)
    assert part.shape == (len(pixels), 4)
    np.testing.assert_allclose(part, full[pixels[:, 0], pixels[:, 1]], atol=1e-5)
    assert drawer.draw(lit, [0], cam, W, H, True, pixels=np.zeros((0, 2), int)).shape == (0, 4)
    with pytest.raises(ValueError, match="pixels must lie in the image"):
        drawer.draw(lit, [0], cam, W, H, True, pixels=np.array([[H, 0]]))
    with pytest.raises(TypeError, match="pixels must be an integer"):
        drawer.draw(lit, [0], cam, W, H, True, pixels=np.zeros((1, 2)))


def test_finish_keeps_the_unfiltered_pixels_out_of_the_tent() -> None:
    from cumuli.rendering.air import finish

    scene, cam = small_scene()
    rng = np.random.default_rng(1)
    image = rng.random((H, W, 4), dtype=np.float32)
    keep = rng.random((H, W)) < 0.2
    out = finish(image, scene, cam, unfiltered=keep)
    tented = tent_filter(image)
    np.testing.assert_array_equal(out[keep], image[keep])
    np.testing.assert_array_equal(out[~keep], tented[~keep])
    with pytest.raises(ValueError, match="unfiltered must be an"):
        finish(image, scene, cam, unfiltered=keep[:-1])


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_a_physical_render_supersamples_its_outline(backend: str) -> None:
    scene, cam = small_scene()
    img = cu.render(scene, cam, W, H, backend=backend)
    raw_scene = scene.replace(settings=scene.settings.replace(resolve=False))
    raw = cu.render(raw_scene, cam, W, H, backend=backend)
    fine = cu.render(raw_scene, cam, SUB * W, SUB * H, backend=backend)
    blocks = fine.reshape(H, SUB, W, SUB, 4)
    box = np.mean([blocks[:, dy, :, dx] for dy, dx in RAYS], axis=0)
    edges = edge_mask(raw[..., 3])
    assert 0.02 < edges.mean() < 0.5  # the cloud's outline, not the whole image
    # The outline: the mean of the pixel's diagonal rays, untouched by the tent.
    np.testing.assert_allclose(img[edges], box[edges], atol=2e-5)
    # Elsewhere: the tent over the image of one ray per pixel, with the outline's new values.
    expected = tent_filter(np.where(edges[..., None], box, raw).astype(np.float32))
    np.testing.assert_allclose(img[~edges], expected[~edges], atol=2e-5)


def test_supersample_edges_leaves_an_image_without_edges_alone() -> None:
    flat = np.full((6, 5, 4), 0.5, np.float32)

    def march(pixels: np.ndarray) -> np.ndarray:
        raise AssertionError("nothing to march")

    out, edges = supersample_edges(flat, march)
    assert out is flat and edges is None


def test_supersample_edges_spends_a_writable_image_only_when_told() -> None:
    image = np.zeros((6, 8, 4), np.float32)
    image[:, 4:] = 1.0

    def march(pixels: np.ndarray) -> np.ndarray:
        return np.full((len(pixels), 4), 0.5, np.float32)

    kept = image.copy()
    out, edges = supersample_edges(image, march)
    assert out is not image and np.array_equal(image, kept)
    assert edges is not None and (out[edges] == 0.5).all()
    spent, _ = supersample_edges(image, march, writable=True)
    assert spent is image and np.array_equal(spent, out)


def test_the_paper_mode_has_no_edge_pass() -> None:
    scene, cam = small_scene(lighting="paper")
    calls: list[int] = []

    import cumuli.rendering.painters as painters

    original = painters.CPUPainter.edged

    def spy(self, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        calls.append(1)
        return original(self, *args, **kwargs)

    painters.CPUPainter.edged = spy  # type: ignore[method-assign]
    try:
        cu.render(scene, cam, W, H, backend="cpu")
        assert not calls
        cu.render(small_scene()[0], cam, W, H, backend="cpu")
        assert calls  # the physical mode's render does call it
    finally:
        painters.CPUPainter.edged = original  # type: ignore[method-assign]


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("size", [(W, H), (31, 17)])
def test_the_one_call_edge_pass_equals_the_two_call_route(
    threads: int, size: tuple[int, int]
) -> None:
    """The CPU twin marches the image and its outline in one core call (grids and fans built
    once); its image, outline and counted work are those of the march, the mask and the list
    march taken one after the other (the GL painter's route), bit for bit."""
    from cumuli.light.prepare import prepare_light
    from cumuli.light.view import seen_from
    from cumuli.rendering.edges import core_pass
    from cumuli.rendering.painters import CountingCPUPainter, CPUPainter

    scene, cam = small_scene()
    lit = seen_from(prepare_light(scene), cam)
    w, h = size
    painter = CPUPainter(threads)
    layer = painter.layer(lit, "cloud", [0], cam, w, h, True)
    two, two_edges = supersample_edges(
        layer, lambda m: painter.marched(lit, [0], cam, SUB * w, SUB * h, m)
    )
    one, one_edges = painter.edged(lit, [0], cam, w, h)
    assert two_edges is not None and one_edges is not None and two_edges.any()
    np.testing.assert_array_equal(one_edges, two_edges)
    np.testing.assert_array_equal(one.view(np.uint32), two.view(np.uint32))
    # The work, counted per pixel.
    split, whole = CountingCPUPainter(threads), CountingCPUPainter(threads)
    layer = split.layer(lit, "cloud", [0], cam, w, h, True)
    supersample_edges(layer, lambda m: split.marched(lit, [0], cam, SUB * w, SUB * h, m))
    whole.edged(lit, [0], cam, w, h)
    a, b = combined_stats(split.passes, w, h), combined_stats(whole.passes, w, h)
    assert (a.fbm_evaluations, a.steps, a.skipped) == (b.fbm_evaluations, b.steps, b.skipped)
    np.testing.assert_array_equal(a.fbm_map, b.fbm_map)
    # An image with no outline, or too long an outline, keeps the single march and no mask.
    args = render_cpu_args(lit, cam, w, h, threads)
    flat = (1e9, SUB, RAYS, 1 << 24, 1 << 14)
    image, mask = _core.render_cpu_edged(**edged_args(args), edges=flat)
    assert mask is None and np.array_equal(image, _core.render_cpu(**args))
    image, mask = _core.render_cpu_edged(**edged_args(args), edges=core_pass()[:3] + (1, 1 << 14))
    assert mask is None and np.array_equal(image, _core.render_cpu(**args))


def test_the_one_call_edge_pass_rejects_bad_input() -> None:
    from cumuli.light.prepare import prepare_light

    scene, cam = small_scene()
    full = render_cpu_args(prepare_light(scene), cam, W, H)
    args = edged_args(full)
    bad = {
        "range must be finite": (float("nan"), SUB, RAYS, 1 << 24, 1 << 14),
        "sub must be in": (EDGE_RANGE, 0, RAYS, 1 << 24, 1 << 14),
        "at least one ray": (EDGE_RANGE, SUB, (), 1 << 24, 1 << 14),
        "must be sub-pixels": (EDGE_RANGE, SUB, ((0, 2),), 1 << 24, 1 << 14),
        "max_rays must be": (EDGE_RANGE, SUB, RAYS, -1, 1 << 14),
        "max_sub_edge must be": (EDGE_RANGE, SUB, RAYS, 1 << 24, 0),
    }
    for message, edges in bad.items():
        with pytest.raises(ValueError, match=message):
            _core.render_cpu_edged(**args, edges=edges)
    for edges in ((EDGE_RANGE, SUB), None):
        with pytest.raises(TypeError, match="edges must be a tuple"):
            _core.render_cpu_edged(**args, edges=edges)
    from cumuli.rendering.marcher_cpu import draw_clouds_cpu

    with pytest.raises(ValueError, match="pixels or edges, not both"):
        draw_clouds_cpu(
            prepare_light(scene), [0], cam, W, H, True, pixels=np.zeros((1, 2), np.int32),
            edges=True,
        )  # fmt: skip
    with pytest.raises(ValueError, match="without solids"):
        edged_args(full | {"solids": np.zeros((1, 4), np.float32)})


def test_return_stats_counts_the_edge_pass_in_its_pixels() -> None:
    from cumuli.light.prepare import prepare_light
    from cumuli.light.view import seen_from

    scene, cam = small_scene()
    lit = prepare_light(scene)
    image, stats = cu.render_cpu(lit, cam, W, H, return_stats=True)
    np.testing.assert_array_equal(image, cu.render_cpu(lit, cam, W, H))
    first_image, first = _core.render_cpu(
        **render_cpu_args(seen_from(lit, cam), cam, W, H), return_stats=True
    )
    edges = edge_mask(first_image[..., 3])
    extra = stats.fbm_map.astype(np.int64) - first["fbm_map"]
    assert stats.fbm_evaluations == int(stats.fbm_map.sum())
    assert not extra[~edges].any() and extra[edges].sum() > 0
    assert stats.steps > int(first["steps"])
