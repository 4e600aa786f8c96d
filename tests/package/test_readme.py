"""The README and the docs pages (docs/*.md) run: every ```python block is executed on its own
in an empty folder, every `cumuli ...` line of the ```sh blocks is run, and the size-limit table
(docs/conventions.md) matches the code. The README is a landing page of at most 200 lines.

Two kinds of ```python block are not run as scripts: a block headed ``title="test_….py"`` is a
pytest file (test_testing_plugin.py runs it under pytest), and a block on the line after an
``<!-- no-run -->`` comment is shown, not run (say why in the text around it).

(The `make` lines of the README are the suite's own entry points; test_makefile.py and
test_onboarding.py, beside this file, check them without recursing into them.)
"""

from __future__ import annotations

import importlib
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")
PAGES = {"README": README} | {
    f"docs-{p.stem}": p.read_text(encoding="utf-8") for p in sorted((ROOT / "docs").glob("*.md"))
}
#: The most lines the README may have: a landing page; the rest is in docs/.
README_MAX_LINES = 200

pytestmark = pytest.mark.gl  # the examples render with GL, as a reader's would


_FENCE = re.compile(
    r"^(#{1,4} [^\n]+)$|(<!-- no-run -->\n)?^```(\w*)([^\n]*)\n(.*?)^```$", re.M | re.S
)


def _blocks(language: str, pages: dict[str, str] = PAGES) -> list[tuple[str, str]]:
    """``(id, code)`` of every fenced block of ``language`` meant to run, named after its page
    and section."""
    out = []
    for page, text in pages.items():
        heading = "top"
        counts: dict[str, int] = {}
        for match in _FENCE.finditer(text):
            if match.group(1):
                heading = re.sub(r"\W+", "-", match.group(1).lstrip("# ").lower()).strip("-")
            elif match.group(3) == language:
                if match.group(2) or re.search(r'title="test_\w+\.py"', match.group(4)):
                    continue  # shown, not run; or a pytest file
                key = f"{page}-{heading}"
                counts[key] = counts.get(key, 0) + 1
                out.append((f"{key}-{counts[key]}", match.group(5)))
    return out


PYTHON = _blocks("python")
SHELL = [
    (f"{name}-{k}", line.split("#", 1)[0].strip())
    for name, code in _blocks("sh")
    for k, line in enumerate(code.splitlines())
    if line.startswith("cumuli ")
]


def _env() -> dict[str, str]:
    return {**os.environ, "CUMULI_PROGRESS": "0"}


def test_the_readme_and_docs_have_code_to_run() -> None:
    assert len(PYTHON) >= 8 and len(SHELL) >= 3
    assert any(name.startswith("README-") for name, _ in PYTHON)
    for name, code in PYTHON:
        assert "import cumuli" in code, f"{name} does not import cumuli: not self-contained"


def test_the_readme_is_a_landing_page() -> None:
    lines = README.splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines"
    first_screen = "\n".join(lines[:60])
    assert "make demo" in first_screen and "make test" in first_screen
    for link in re.findall(r"\]\((docs/[^)#]+)", README):
        assert (ROOT / link).is_file(), link
    pictures = re.findall(r"!\[[^\]]+\]\(([^)]+)\)", README)
    assert pictures, "the README shows a picture"
    for picture in pictures:
        assert (ROOT / picture).is_file() and (ROOT / picture).stat().st_size < 300_000, picture


def test_the_markers_are_understood() -> None:
    page = "# T\n<!-- no-run -->\n```python\nraise SystemExit(1)\n```\n\n```python\nx = 1\n```\n"
    pytest_file = '```python title="test_x.py"\ndef test_x(): ...\n```\n'
    assert _blocks("python", {"p": page + pytest_file}) == [("p-t-1", "x = 1\n")]


@pytest.mark.parametrize(("name", "code"), PYTHON, ids=[n for n, _ in PYTHON])
def test_python_block_runs_on_its_own(name: str, code: str, tmp_path: Path) -> None:
    script = tmp_path / "example.py"
    script.write_text(code, encoding="utf-8")
    done = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, env=_env(), capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, f"block {name} failed:\n{done.stderr[-3000:]}"


@pytest.mark.parametrize(("name", "line"), SHELL, ids=[n for n, _ in SHELL])
def test_cli_line_runs(name: str, line: str, tmp_path: Path) -> None:
    args = shlex.split(line)[1:]
    done = subprocess.run(
        [sys.executable, "-m", "cumuli", *args], cwd=tmp_path, env=_env(), capture_output=True,
        text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, f"line {line!r} ({name}) failed:\n{done.stderr[-3000:]}"
    if "-o" in args:
        assert (tmp_path / args[args.index("-o") + 1]).is_file()
    elif args[:1] == ["demo"]:
        assert (tmp_path / "out.png").is_file()


def _limit_rows() -> list[tuple[str, str, str]]:
    conventions = (ROOT / "docs" / "conventions.md").read_text(encoding="utf-8")
    section = conventions.split("## Size limits", 1)[1].split("\n## ", 1)[0]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 3 and cells[0] not in ("what", "---"):
            rows.append((cells[0], cells[1], cells[2]))
    return rows


def _resolve(path: str) -> object:
    key = None
    if match := re.fullmatch(r"(.+)\[\"(\w+)\"\]", path):
        path, key = match.group(1), match.group(2)
    module, _, name = path.rpartition(".")
    value = getattr(importlib.import_module(module), name)
    return value[key] if key is not None else value


def test_the_size_limit_table_matches_the_code() -> None:
    rows = _limit_rows()
    assert len(rows) >= 25
    checked = 0
    for what, limit, constant in rows:
        number = re.match(r"`([0-9_e<< ]+)`", limit)
        name = re.fullmatch(r"`([\w.]+(?:\[\"\w+\"\])?)`", constant)
        if number is None or name is None:
            assert "GL_MAX" in limit, what  # the limits the driver sets are described, not coded
            continue
        value = eval(number.group(1), {"__builtins__": {}})  # literals and << only
        assert _resolve(name.group(1)) == value, (what, limit, constant)
        checked += 1
    assert checked >= 25
