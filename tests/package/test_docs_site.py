"""The documentation site builds with ``mkdocs build --strict`` (broken links, missing pages and
docstring errors fail), every page is in its navigation, the API reference covers the public
names, and the Benchmarks page is the benchmark report, not typed figures.
(test_readme.py, beside this file, runs the pages' code blocks.)"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

import cumuli as cu

ROOT = Path(__file__).resolve().parents[2]
yaml = pytest.importorskip("yaml", reason="PyYAML comes with mkdocs (the docs extra)")


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    done = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-4000:]
    return out


def _nav_pages(nav: list[Any]) -> list[str]:
    pages: list[str] = []
    for entry in nav:
        value = next(iter(entry.values())) if isinstance(entry, dict) else entry
        pages += _nav_pages(value) if isinstance(value, list) else [value]
    return pages


def test_every_page_is_in_the_navigation() -> None:
    config = yaml.load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"), Loader=yaml.BaseLoader)
    listed = _nav_pages(config["nav"])
    on_disk = sorted(p.name for p in (ROOT / "docs").glob("*.md"))
    assert sorted(listed) == on_disk
    assert listed[0] == "index.md"


def test_the_site_builds_strictly_with_the_api_reference(site: Path) -> None:
    api = (site / "api" / "index.html").read_text(encoding="utf-8")
    for name in ("Scene", "Cloud", "render", "render_cpu", "Renderer", "prepare_light"):
        assert f'id="cumuli.{name}"' in api, name
    documented = set(re.findall(r'id="cumuli\.(\w+)"', api))
    public = {n for n in cu.__all__ if not n.startswith("_")}
    assert len(public & documented) >= 0.9 * len(public), sorted(public - documented)
    assert 'id="cumuli.testing.assert_image_close"' in api


def test_the_benchmarks_page_is_the_report(site: Path) -> None:
    page = (site / "benchmarks" / "index.html").read_text(encoding="utf-8")
    results = (ROOT / "benchmarks" / "RESULTS.md").read_text(encoding="utf-8")
    # A table row of the report (its first cell) and every plot it shows reach the page.
    row = next(line for line in results.splitlines() if line.startswith("| ") and "[" in line)
    assert row.split("|")[2].strip().split(" ")[0] in page
    for plot in re.findall(r"!\[[^\]]*\]\((results/[^)]+)\)", results):
        assert (site / "benchmarks" / plot).is_file() or (
            site / "benchmarks" / ".." / "benchmarks" / plot
        ).is_file()
        assert plot.rsplit("/", 1)[1] in page
    source = (ROOT / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    assert "<!-- include: benchmarks/RESULTS.md -->" in source
