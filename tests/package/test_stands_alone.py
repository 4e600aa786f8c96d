"""The repository stands on its own: its code and docs cite the papers and the project's own
documents, never files outside the repository or issue numbers a user cannot see."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = ("python", "cpp", "shaders", "benchmarks", "tests", "notebooks", "docs")
SUFFIXES = {".py", ".hpp", ".cpp", ".glsl", ".md", ".ipynb", ".toml"}
#: What a reader of the repository cannot open.
OUTSIDE = re.compile(r"shared/|DESIGN\.md|\b(?:harris|torchelsen)\.md|\bissue \d+")


def offenders(files: list[Path]) -> list[str]:
    found = []
    for path in files:
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if OUTSIDE.search(line):
                found.append(f"{path.relative_to(ROOT)}:{n}")
    return found


def project_files() -> list[Path]:
    files = [p for p in ROOT.glob("*.md")]
    for folder in FOLDERS:
        files += [
            p for p in (ROOT / folder).rglob("*")
            if p.suffix in SUFFIXES and p.is_file() and "_failures" not in p.parts
            and p != Path(__file__).resolve()
        ]  # fmt: skip
    return files


def test_no_file_cites_what_a_reader_cannot_open() -> None:
    assert offenders(project_files()) == []


def test_the_check_sees_a_citation(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(f"{__name__}.ROOT", tmp_path)
    bad = tmp_path / "a.py"
    bad.write_text("x = 1\n# see spec harris.md §3 (issue 14)\n", encoding="utf-8")
    assert offenders([bad]) == ["a.py:2"]
