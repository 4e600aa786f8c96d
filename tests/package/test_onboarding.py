"""The first hour: `cumuli --version`, progress bars on long steps (with an opt-out),
`make bench` writing to benchmarks/out/ unless asked to archive, the notebooks' numbering."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli._util import progress as _progress

ROOT = Path(__file__).resolve().parents[2]


def test_cumuli_version() -> None:
    for cmd in ([sys.executable, "-m", "cumuli", "--version"],):
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        assert done.stdout.strip() == f"cumuli {cu.__version__}"
    from cumuli.cli import main

    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0


# --- progress bars ----------------------------------------------------------------------------
@pytest.fixture
def bars_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """Bars shown from the first moment (they normally wait DELAY seconds)."""
    monkeypatch.setattr(_progress, "DELAY", 0.0)
    monkeypatch.delenv("CUMULI_PROGRESS", raising=False)


def _database() -> cu.VolumeDatabase:
    vols = np.random.default_rng(0).uniform(0, 1, (3, 6, 6, 6)).astype(np.float32)
    return cu.VolumeDatabase(vols, (0, 0, 0), (1, 1, 1))


def test_long_python_loops_show_a_bar_unless_told_not_to(
    bars_at_once: None, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    db = _database()
    args = {"sh_order": 2, "sh_samples": 2, "ms_points": 4}
    cu.VolumeLighting(db, cu.Sun(), **args)
    assert "volume light" in capsys.readouterr().err
    cu.VolumeLighting(db, cu.Sun(), progress=False, **args)
    assert capsys.readouterr().err == ""
    monkeypatch.setenv("CUMULI_PROGRESS", "0")
    cu.VolumeLighting(db, cu.Sun(), **args)
    assert capsys.readouterr().err == ""
    monkeypatch.delenv("CUMULI_PROGRESS")
    anim = cu.EndlessAnimation(db, crossfade_frames=1)
    anim.frames(3)
    assert "frames" in capsys.readouterr().err
    scene = cu.Scene(
        [cu.gaussian_cumulus(n=6, seed=s) for s in (1, 2)],
        settings=cu.RenderSettings(lighting="paper"),
    )
    cu.prepare_light(scene)
    assert "light" in capsys.readouterr().err
    with pytest.raises(TypeError, match="progress"):
        cu.VolumeLighting(db, cu.Sun(), progress="yes", **args)


def test_long_cpp_calls_show_a_bar_moved_by_their_loops(
    bars_at_once: None, capsys: pytest.CaptureFixture[str]
) -> None:
    from cumuli.demo import default_scene

    scene = default_scene(settings=cu.RenderSettings(lighting="paper"))
    lit = cu.prepare_light(scene, progress=False)
    capsys.readouterr()
    cu.render_cpu(lit, scene.default_camera(), 320, 240, threads=1)
    err = capsys.readouterr().err
    assert "render (cpu)" in err and "%" in err
    cu.render_cpu(lit, scene.default_camera(), 64, 48, progress=False)
    assert capsys.readouterr().err == ""
    cloud = cu.gaussian_cumulus(seed=1)
    cu.light_grid(cloud, cu.Sun(), cu.Noise(seed=1), resolution=40, threads=1)  # ≈ 0.25 s
    assert "light grid" in capsys.readouterr().err


@pytest.mark.gl
def test_gl_tiles_show_a_bar(bars_at_once: None, capsys: pytest.CaptureFixture[str]) -> None:
    scene = cu.Scene(
        [cu.gaussian_cumulus(n=6, seed=1)],
        noise=cu.Noise(seed=2, size=16),
        settings=cu.RenderSettings(lighting="paper"),
    )
    lit = cu.prepare_light(scene, progress=False)
    with cu.Renderer(tile=16) as r:
        r.render(lit, scene.default_camera(), 48, 32)
        assert "render (gl)" in capsys.readouterr().err
        r.render(lit, scene.default_camera(), 48, 32, progress=False)
        assert capsys.readouterr().err == ""


def test_quick_steps_stay_silent(capsys: pytest.CaptureFixture[str]) -> None:
    assert _progress.DELAY >= 1.0
    cu.VolumeLighting(_database(), cu.Sun(), sh_order=2, sh_samples=2, ms_points=0)
    assert capsys.readouterr().err == ""


# --- make bench -------------------------------------------------------------------------------
@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_make_bench_writes_to_out_and_archives_only_on_request() -> None:
    def plan(*extra: str) -> str:
        done = subprocess.run(
            ["make", "-n", "bench", "PY=python3", "STAMP=/dev/null", *extra],
            cwd=ROOT, capture_output=True, text=True, timeout=60,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        return done.stdout

    default = plan()
    assert "run_all.py --out benchmarks/out" in default
    assert "--archive" not in default and "report.py --run benchmarks/out" in default
    archive = plan("ARCHIVE=1")
    assert "report.py --archive benchmarks/out" in archive


def test_report_of_one_run_leaves_the_committed_results_alone(tmp_path: Path) -> None:
    committed = ROOT / "benchmarks" / "RESULTS.md"
    before = committed.read_text()
    run = tmp_path / "out"
    run.mkdir()
    source = ROOT / "benchmarks" / "results" / "llvmpipe"
    for name in ("noise.json", "speedups.json"):
        shutil.copy(source / name, run / name)
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "report.py"), "--run", str(run)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    text = (run / "RESULTS.md").read_text()
    assert "claimed speed-ups" in text and "this run" in text
    assert committed.read_text() == before
    assert json.loads((run / "noise.json").read_text())  # the run's files are untouched


# --- notebooks --------------------------------------------------------------------------------
def test_notebook_numbers_and_the_docs_agree() -> None:
    """Getting started (docs/index.md) lists every notebook and how to run it full size; the
    README points there."""
    readme = (ROOT / "README.md").read_text()
    guide = (ROOT / "docs" / "index.md").read_text()
    assert "docs/index.md" in readme
    books = sorted(p.name for p in (ROOT / "notebooks").glob("*.ipynb"))
    for name in books:
        assert f"notebooks/{name}" in guide, name
    numbers = sorted(name[:2] for name in books)
    assert len(set(numbers)) == len(numbers)  # one notebook per number
    assert "Harris" in readme and "Torchelsen" in readme
    assert "CUMULI_QUICK=1" in guide  # quick mode is the test runner's, full size the default
