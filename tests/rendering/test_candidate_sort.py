"""Candidate sorts of the marcher (settings.candidate_sort, the paper's §4.1 experiment).

Insertion sort, iterative quicksort and Batcher's odd-even mergesort are compile-time variants of
shaders/marcher/march.frag.glsl that must order candidates identically (by t_in, ties by primitive
index), so their images are bit-identical; "none" leaves them unsorted, changes the image where
intervals overlap, and the CPU marcher reproduces it.
"""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli.gl import with_defines
from cumuli.rendering.compositor import Renderer
from cumuli.settings import CANDIDATE_SORTS
from cumuli.testing import assert_image_close, only

W, H = 64, 48
SORTED = ("insertion", "quicksort", "oddeven")


def overlapping_scene(**settings) -> cu.Scene:
    """Many overlapping spheres along the view (long, unordered candidate lists per ray)."""
    rng = np.random.default_rng(4)
    n = 40
    centres = np.c_[rng.uniform(-3, 3, n), rng.uniform(-2, 2, n), rng.uniform(-6, 6, n)]
    radii = np.repeat(rng.uniform(1.0, 2.5, n)[:, None], 3, axis=1)
    # Primitive order opposite to depth order, so an unsorted list is far from sorted.
    order = np.argsort(-centres[:, 2])
    cloud = cu.Cloud(centres[order].astype(np.float32), radii[order].astype(np.float32))
    base = {"exact_noise": True, "absorption": 0.4}
    return cu.Scene(
        clouds=[cloud],
        sun=cu.Sun(direction=(0.3, 0.8, -0.4)),
        noise=cu.Noise(seed=3),
        settings=cu.RenderSettings(**{**base, **settings}),
    )


CAMERA = cu.Camera(position=(0.5, 0.3, -25.0), target=(0, 0, 0), fov=30.0)


def render(renderer: Renderer, **settings) -> np.ndarray:
    return renderer.render(overlapping_scene(**settings), CAMERA, W, H)


@pytest.mark.gl
@pytest.mark.parametrize("march", ["paper", "union"])
@pytest.mark.parametrize("cap", [64, 3])
def test_sorts_give_identical_images(renderer: Renderer, march: str, cap: int) -> None:
    # cap=3 exercises "keep the nearest cap candidates" when a ray meets more than that.
    images = {
        s: render(renderer, candidate_sort=s, march=march, max_candidates=cap) for s in SORTED
    }
    assert images["insertion"][..., 3].max() > 0.5, "the scene must cover the view"
    for sort in SORTED[1:]:
        np.testing.assert_array_equal(images[sort], images["insertion"], err_msg=sort)


@pytest.mark.gl
def test_unsorted_differs_and_matches_cpu(renderer: Renderer) -> None:
    sorted_img = render(renderer, candidate_sort="insertion")
    unsorted = render(renderer, candidate_sort="none")
    # Paper marching composites in candidate order: out of order, overlaps shade differently.
    assert np.abs(unsorted - sorted_img).max() > 0.05
    cpu = cu.render_cpu(overlapping_scene(candidate_sort="none"), CAMERA, W, H)
    assert_image_close(unsorted, cpu, **only(mean_abs=1e-3))
    cpu_sorted = cu.render_cpu(overlapping_scene(candidate_sort="oddeven"), CAMERA, W, H)
    assert_image_close(sorted_img, cpu_sorted, **only(mean_abs=1e-3))


def test_cpu_sorted_modes_identical_and_none_differs() -> None:
    images = {
        s: cu.render_cpu(overlapping_scene(candidate_sort=s), CAMERA, 32, 24)
        for s in CANDIDATE_SORTS
    }
    for sort in SORTED[1:]:
        np.testing.assert_array_equal(images[sort], images["insertion"])
    assert np.abs(images["none"] - images["insertion"]).max() > 0.05


def test_candidate_sort_validated_and_saved(tmp_path) -> None:
    with pytest.raises(ValueError, match="candidate_sort"):
        cu.RenderSettings(candidate_sort="bogo", lighting="paper")
    scene = overlapping_scene(candidate_sort="oddeven")
    path = scene.save(tmp_path / "scene.json")
    assert cu.load_scene(path).settings.candidate_sort == "oddeven"


def test_with_defines() -> None:
    src = "#version 430\nvoid main() {}\n"
    out = with_defines(src, {"CANDIDATE_SORT": 2})
    assert out.splitlines()[:2] == ["#version 430", "#define CANDIDATE_SORT 2"]
    with pytest.raises(ValueError, match="identifier"):
        with_defines(src, {"bad name": 1})
    with pytest.raises(TypeError, match="int"):
        with_defines(src, {"X": "1; junk"})
    with pytest.raises(ValueError, match="#version"):
        with_defines("void main() {}", {"X": 1})
