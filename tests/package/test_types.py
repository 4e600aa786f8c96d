"""Types: the compiled module's stubs are current and type-check, and the public-API examples of
the README's quick start and of the docs, the `cumuli.testing` plugin and the tests that use the
public API most (the CLI, the image checks, the golden images) type-check against the package
(mypy)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
STUB = ROOT / "python" / "cumuli" / "_core.pyi"
#: Checked with the examples: the plugin users import, and tests written as users write them.
TYPED = [
    ROOT / "python" / "cumuli" / "testing",
    ROOT / "tests" / "conftest.py",
    *(ROOT / "tests" / "package" / f for f in (
        "test_cli.py", "test_testing_plugin.py", "test_packaging.py", "test_docs_site.py",
        "test_readme.py", "test_types.py", "test_wheel.py", "wheel_smoke.py",
    )),
    ROOT / "tests" / "rendering" / "test_render_gl.py",
    ROOT / "tests" / "rendering" / "test_mitsuba_reference.py",
]  # fmt: skip

pytest.importorskip("mypy", reason="mypy comes with the test extra")


def _mypy(*paths: Path) -> subprocess.CompletedProcess[str]:
    cmd = [
        sys.executable, "-m", "mypy", "--no-incremental", "--follow-imports=silent",
        "--ignore-missing-imports", "--python-version", "3.10", *map(str, paths),
    ]  # fmt: skip
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)


def _examples() -> dict[str, str]:
    """The README's quick start and every ```python block of docs/*.md, by name."""
    out: dict[str, str] = {}
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    quick = readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    for k, code in enumerate(re.findall(r"^```python\n(.*?)^```$", quick, re.M | re.S)):
        out[f"readme_quick_start_{k}"] = code
    for page in sorted((ROOT / "docs").glob("*.md")):
        text = page.read_text(encoding="utf-8")
        blocks = re.findall(r"^```python[^\n]*\n(.*?)^```$", text, re.M | re.S)
        for k, code in enumerate(blocks):
            out[f"docs_{page.stem}_{k}"] = code
    return out


def test_the_stubs_are_those_the_build_gives(tmp_path: Path) -> None:
    pytest.importorskip("pybind11_stubgen", reason="pybind11-stubgen comes with the test extra")
    cmd = [
        sys.executable, "-m", "pybind11_stubgen", "cumuli._core", "-o", str(tmp_path),
        "--ignore-invalid-expressions", "<.*object at 0x[0-9a-f]+>", "--exit-code",
    ]  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    fresh = (tmp_path / "cumuli" / "_core.pyi").read_text(encoding="utf-8")
    assert fresh == STUB.read_text(encoding="utf-8"), "python/cumuli/_core.pyi is stale: make stubs"
    import cumuli._core as core

    public = {n for n in dir(core) if not n.startswith("_")}
    assert public <= set(re.findall(r"^(?:class |def )?(\w+)", fresh, re.M)), "names missing"
    assert len(public) > 90


def test_the_examples_and_the_stubs_type_check(tmp_path: Path) -> None:
    examples = _examples()
    assert len(examples) >= 2 and any(n.startswith("readme") for n in examples)
    folder = tmp_path / "examples"
    folder.mkdir()
    for name, code in examples.items():
        (folder / f"{name}.py").write_text(code, encoding="utf-8")
    done = _mypy(folder, STUB, *TYPED)
    assert done.returncode == 0, done.stdout[-4000:]
    assert "Success" in done.stdout


def test_mypy_sees_a_wrong_call(tmp_path: Path) -> None:
    """The check has teeth: the stubs and annotations reject a misuse."""
    bad = tmp_path / "bad.py"
    bad.write_text(
        "import cumuli as cu\nimport cumuli._core as core\n"
        "cu.render(cu.Scene(), width='wide')\ncore.simd_level(3)\n",
        encoding="utf-8",
    )
    done = _mypy(bad)
    assert done.returncode == 1
    assert 'Argument "width" to "render"' in done.stdout
    assert '"simd_level"' in done.stdout
