"""``cumuli.testing``: the metrics, the failure message and images, golden files, and the user's
test file of docs/testing.md run by pytest as a user runs it."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
import cumuli.testing as cu_testing
from cumuli.testing import assert_image_close, compare_images, heat_map
from cumuli.testing.goldens import Settings

ROOT = Path(__file__).resolve().parents[2]


def cloud_image(h: int = 24, w: int = 32) -> np.ndarray:
    """A disc of 'cloud' (alpha 0.9) over a 'sky' gradient."""
    yy, xx = np.mgrid[0:h, 0:w]
    img = np.zeros((h, w, 4), np.float32)
    img[..., 2] = 0.3 + 0.4 * yy / h
    inside = (yy - h / 2) ** 2 + (xx - w / 2) ** 2 < (h / 3) ** 2
    img[inside, :3] = 0.8
    img[inside, 3] = 0.9
    return img


def test_equal_images_pass_and_each_metric_fails_on_its_own() -> None:
    ref = cloud_image()
    assert compare_images(ref, ref).ok
    cloudy = ref.copy()
    cloudy[ref[..., 3] > 0, 0] += 1e-3  # every cloud pixel a little brighter
    assert compare_images(cloudy, ref).failed == ["covered_mean"]
    sky = ref.copy()
    sky[0, 0, 1] += 1e-3  # one sky pixel
    m = compare_images(sky, ref)
    assert m.failed == ["background_max"] and m.where["background_max"] == (0, 0)
    spots = ref.copy()
    spots[12, 10:14, 0] += 0.2  # four outliers on ~200 cloud pixels: 2 allowed
    m = compare_images(spots, ref)
    assert m.failed == ["outliers"] and m["outliers"] == 4 and m.where["outliers"][0] == 12
    assert compare_images(spots, ref, outlier_share=0.05).ok
    assert compare_images(ref * 1.5, ref, block=4).failed[-3:] == [
        "block_rel_median", "block_rel_p90", "block_mean_ratio",
    ]  # fmt: skip


def test_block_metrics_forgive_noise_that_averages_out() -> None:
    ref = cloud_image(48, 64)
    noise = np.random.default_rng(0).normal(0, 0.05, ref.shape[:2])[..., None]
    noisy = ref.copy()
    noisy[..., :3] += noise * (ref[..., 3:] > 0)
    assert "covered_mean" in compare_images(noisy, ref).failed
    loose = {"covered_mean_abs": np.inf, "outlier_abs": np.inf, "mean_abs": np.inf}
    assert compare_images(noisy, ref, block=8, **loose).ok


def test_bad_input_is_refused() -> None:
    ref = cloud_image()
    with pytest.raises(ValueError, match="shape"):
        compare_images(ref[:10], ref)
    with pytest.raises(ValueError, match="NaN"):
        compare_images(ref * np.nan, ref)
    with pytest.raises(ValueError, match="block"):
        compare_images(ref, ref, block=0)


def test_failure_says_where_how_much_and_which_metric_and_leaves_images(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(Settings, "failures_dir", tmp_path / "fail")
    ref = cloud_image()
    img = ref.copy()
    img[5, 7, :3] += 1e-3  # a sky pixel
    with pytest.raises(AssertionError) as info:
        assert_image_close(img, ref, name="sky spot")
    text = str(info.value)
    assert re.search(r"background_max = 0\.001 > limit 0\.0001 — worst at row 5, column 7", text)
    names = sorted(p.name for p in (tmp_path / "fail").iterdir())
    assert names == [
        f"sky_spot_{k}" for k in ("actual.exr", "diff.exr", "expected.exr", "heat.png")
    ]
    np.testing.assert_allclose(cu.read_image(tmp_path / "fail" / "sky_spot_actual.exr"), img)
    heat = heat_map(img, ref)
    assert heat[5, 7, :3].tolist() == [1, 1, 1] and heat[0, 0, :3].tolist() == [0, 0, 0]


def test_goldens_are_written_on_request_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    golden = tmp_path / "g" / "cloud.exr"
    img = cloud_image()
    with pytest.raises(AssertionError, match="--cumuli-update-goldens"):
        assert_image_close(img, golden)
    assert not golden.exists()
    monkeypatch.setattr(Settings, "update_goldens", True)
    assert assert_image_close(img, golden).ok
    np.testing.assert_array_equal(cu.read_image(golden), img)  # alpha kept
    monkeypatch.setattr(Settings, "update_goldens", False)
    assert assert_image_close(img, golden).ok


def _user_test_file() -> str:
    text = (ROOT / "docs" / "testing.md").read_text(encoding="utf-8")
    match = re.search(r'^```python title="test_my_clouds\.py"\n(.*?)^```$', text, re.M | re.S)
    assert match, "docs/testing.md lost its user test file"
    return match.group(1)


def _pytest(folder: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """pytest in ``folder`` as a user runs it: the plugin from its entry point where cumuli is
    installed, else named with -p (an in-tree run)."""
    installed = any(ep.value == "cumuli.testing" for ep in metadata.entry_points(group="pytest11"))
    plugin = [] if installed else ["-p", "cumuli.testing"]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    env["CUMULI_PROGRESS"] = "0"
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *plugin, *args]
    return subprocess.run(cmd, cwd=folder, env=env, capture_output=True, text=True, timeout=300)


def test_the_documented_user_test_file_runs_under_pytest(tmp_path: Path) -> None:
    project = tmp_path / "project"
    (project / "tests").mkdir(parents=True)
    (project / "tests" / "test_my_clouds.py").write_text(_user_test_file(), encoding="utf-8")
    first = _pytest(project, "tests")
    assert first.returncode == 1, first.stdout
    assert "golden image" in first.stdout and "--cumuli-update-goldens" in first.stdout
    update = _pytest(project, "tests", "--cumuli-update-goldens")
    assert update.returncode == 0, update.stdout + update.stderr
    golden = project / "tests" / "goldens" / "cumulus.exr"
    assert golden.is_file()
    again = _pytest(project, "tests", "-rs")
    assert again.returncode == 0, again.stdout
    assert re.search(r"3 passed|2 passed, 1 skipped", again.stdout), again.stdout
    # A golden made with another extinction: the check fails, says how, leaves its images.
    scene = cu.Scene([cu.gaussian_cumulus(n=6, seed=1)], noise=cu.Noise(seed=2, size=16))
    denser = scene.replace(
        settings=scene.settings.replace(extinction_scale=1.1 * scene.settings.extinction_scale)
    )
    cu.write_image(golden, cu.render_cpu(denser, scene.default_camera(), 48, 36), "keep")
    failed = _pytest(project, "tests", "--cumuli-failures", "fails")
    assert failed.returncode == 1
    assert "covered_mean = " in failed.stdout and "worst at row" in failed.stdout
    assert (project / "fails" / "cumulus_heat.png").is_file()


def test_gl_tests_skip_with_the_reason_where_there_is_no_gl(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The `gl` marker's skip, as a user's suite sees it on a machine without EGL: a GL test
    is skipped with the reason, the others run."""
    (tmp_path / "conftest.py").write_text(
        "import cumuli.testing.plugin as plugin\n"
        "plugin._gl_status = lambda: (False, 'no EGL display (test)')\n",
        encoding="utf-8",
    )
    (tmp_path / "test_user.py").write_text(
        "import pytest\n\n"
        "@pytest.mark.gl\n"
        "def test_needs_gl(gl_context):\n    raise AssertionError('must not run')\n\n"
        "def test_plain():\n    assert True\n",
        encoding="utf-8",
    )
    done = _pytest(tmp_path, "-rs", ".")
    assert done.returncode == 0, done.stdout
    assert "1 passed, 1 skipped" in done.stdout
    assert "no headless OpenGL here: no EGL display (test)" in done.stdout


def test_cell_pattern_energy_sees_a_lattice_period() -> None:
    """A cloud stepped at every 8-pixel cell edge scores far above the same cloud smooth; a
    period of 2 pixels or less, or an image the cloud does not cover, is refused."""
    x = np.arange(128)
    smooth = np.exp(-(((x - 64) / 30.0) ** 2))
    cells = smooth * (1.0 + 0.2 * (x % 8) / 8.0)  # a step at every 8-pixel cell edge
    img = np.ones((16, 128, 4), np.float32)
    striped = img.copy()
    img[..., :3] = smooth[None, :, None]
    striped[..., :3] = cells[None, :, None]
    plain = cu_testing.cell_pattern_energy(img, 8.0)
    assert cu_testing.cell_pattern_energy(striped, 8.0) > 0.1 > 10 * plain
    with pytest.raises(ValueError, match="period"):
        cu_testing.cell_pattern_energy(img, 2.0)
    empty = img.copy()
    empty[..., 3] = 0.0
    with pytest.raises(ValueError, match="covers"):
        cu_testing.cell_pattern_energy(empty, 8.0)
