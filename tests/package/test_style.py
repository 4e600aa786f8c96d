"""The code style the developers' guide asks for, checked where CI runs: ruff on the Python,
clang-format (the repository's `.clang-format`) on the C++."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PYTHON_TREES = ["python", "tests", "benchmarks"]


def _run(args: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=300)


def test_python_is_ruff_clean_and_formatted() -> None:
    lint = _run([sys.executable, "-m", "ruff", "check", *PYTHON_TREES])
    assert lint.returncode == 0, lint.stdout + lint.stderr
    fmt = _run([sys.executable, "-m", "ruff", "format", "--check", *PYTHON_TREES])
    assert fmt.returncode == 0, fmt.stdout + fmt.stderr


def test_cpp_is_clang_formatted() -> None:
    sources = sorted(p for ext in ("*.cpp", "*.hpp") for p in (ROOT / "cpp").rglob(ext))
    assert len(sources) > 50  # cpp/src, cpp/include/cumuli, cpp/bindings
    # The test extra installs the pinned clang-format next to this interpreter.
    tool = Path(sys.executable).parent / "clang-format"
    assert tool.exists(), f"{tool} is missing: pip install -e '.[test]' installs it"
    done = _run([str(tool), "--dry-run", "-Werror", *map(str, sources)])
    assert done.returncode == 0, done.stderr[-4000:]
