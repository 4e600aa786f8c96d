"""mkdocs hook: the Benchmarks page shows ``benchmarks/RESULTS.md`` as it is in the repository.

The page's ``<!-- include: benchmarks/RESULTS.md -->`` line is replaced by that file, its
headings moved one level down and its plots (``results/<machine>/*.png``) added to the site, so
that every measured figure on the site comes from the report the benchmarks wrote.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[2]
MARKER = "<!-- include: benchmarks/RESULTS.md -->"
RESULTS = ROOT / "benchmarks" / "RESULTS.md"


def _plots() -> list[str]:
    """The plots RESULTS.md shows, as paths relative to the repository."""
    text = RESULTS.read_text(encoding="utf-8")
    return [f"benchmarks/{p}" for p in re.findall(r"!\[[^\]]*\]\((results/[^)]+)\)", text)]


def on_files(files: Files, config: Any) -> Files:
    for path in _plots():
        if not (ROOT / path).is_file():
            raise FileNotFoundError(f"benchmarks/RESULTS.md shows {path}, which does not exist")
        files.append(File(path, str(ROOT), config["site_dir"], config["use_directory_urls"]))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    if MARKER not in markdown:
        return markdown
    text = RESULTS.read_text(encoding="utf-8")
    text = text.split("\n", 1)[1]  # its title: the page has its own
    text = re.sub(r"^(#{1,5}) ", r"#\1 ", text, flags=re.M)
    text = text.replace("](results/", "](benchmarks/results/")
    return markdown.replace(MARKER, text)
