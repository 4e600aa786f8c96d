"""The notebooks a person opens: full size unless the test runner asks for quick mode, committed
without outputs, each runnable at full size, and the viewer notebook covering every kind."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import cumuli as cu

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
FULL_BY_DEFAULT = {"02_shapes.ipynb"}  # the one that once failed at full size; quick at it


def _cells(path: Path) -> list[dict]:
    return json.loads(path.read_text(encoding="utf-8"))["cells"]


def _source(cell: dict) -> str:
    src = cell["source"]
    return src if isinstance(src, str) else "".join(src)


def test_notebooks_open_at_full_size() -> None:
    reading = re.compile(r"os\.environ\.get\(\"CUMULI_QUICK\", \"(\d)\"\) (==|!=) \"(\d)\"")
    users = 0
    for path in NOTEBOOKS:
        text = "\n".join(_source(c) for c in _cells(path))
        for default, op, value in reading.findall(text):
            users += 1
            # QUICK only when CUMULI_QUICK=1: unset means full size.
            assert (default, op, value) == ("0", "==", "1"), path.name
        assert "CUMULI_QUICK=0` for" not in text, f"{path.name} still asks for CUMULI_QUICK=0"
    assert users >= 9


def test_the_test_runner_sets_quick_mode() -> None:
    env = {k: v for k, v in os.environ.items() if k != "CUMULI_QUICK"}
    code = (
        "import os, runpy; runpy.run_path('notebooks/conftest.py'); "
        "print(os.environ['CUMULI_QUICK'])"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True,
                         text=True, check=True)  # fmt: skip
    assert out.stdout.strip() == "1"
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    assert "CUMULI_QUICK=1 $(PY) -m pytest -q tests --nbmake notebooks" in makefile


def test_notebooks_are_committed_without_outputs() -> None:
    for path in NOTEBOOKS:
        for cell in _cells(path):
            if cell["cell_type"] == "code":
                assert cell["outputs"] == [] and cell["execution_count"] is None, path.name


def _run(path: Path, tmp_path: Path, quick: bool, extra: str = "") -> list[str]:
    """Execute a copy of ``path`` (plus an ``extra`` last cell); the text it printed."""
    import nbformat
    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    if extra:
        nb.cells.append(nbformat.v4.new_code_cell(extra))
    env_before = os.environ.get("CUMULI_QUICK")
    os.environ["CUMULI_QUICK"] = "1" if quick else "0"
    try:
        NotebookClient(nb, timeout=1800, resources={"metadata": {"path": str(tmp_path)}}).execute()
    finally:
        if env_before is None:
            os.environ.pop("CUMULI_QUICK", None)
        else:
            os.environ["CUMULI_QUICK"] = env_before
    return [o.get("text", "") for c in nb.cells for o in c.get("outputs", []) if "text" in o]


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs_at_full_size(path: Path, tmp_path: Path) -> None:
    if path.name not in FULL_BY_DEFAULT and os.environ.get("CUMULI_NOTEBOOKS_FULL") != "1":
        pytest.skip("minutes at full size on llvmpipe: `make test-notebooks-full` runs it")
    _run(path, tmp_path, quick=False)


def test_the_viewer_notebook_shows_every_kind(tmp_path: Path) -> None:
    pytest.importorskip("anywidget", reason="the viewer needs anywidget (cumuli[jupyter])")
    probe = (
        "import gc\n"
        "def viewers():\n"
        "    for o in gc.get_objects():\n"
        "        try:\n"
        "            if isinstance(o, cu.Viewer):\n"
        "                yield o\n"
        "        except ReferenceError:  # a dead weak proxy\n"
        "            pass\n"
        "shown = {k for v in viewers() for k in v.session.scene().kinds}\n"
        "print('KINDS', sorted(shown))"
    )
    printed = "".join(_run(ROOT / "notebooks" / "11_viewer.ipynb", tmp_path, True, probe))
    kinds = eval(printed.split("KINDS", 1)[1].strip().splitlines()[0])  # a printed list
    assert set(kinds) == {k.name for k in cu.registry.kinds()}
