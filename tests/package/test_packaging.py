"""What the package ships besides code: a licence, one version source, type information."""

from __future__ import annotations

import re
from pathlib import Path

import tomllib

import cumuli

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def test_licence_file_matches_the_declared_licence() -> None:
    assert PYPROJECT["project"]["license"] == {"text": "MIT"}
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License") and "WITHOUT WARRANTY OF ANY KIND" in text


def test_the_version_is_written_once() -> None:
    """pyproject declares the version dynamic and reads it from _version.py with a regex."""
    assert "version" not in PYPROJECT["project"]
    assert "version" in PYPROJECT["project"]["dynamic"]
    provider = PYPROJECT["tool"]["scikit-build"]["metadata"]["version"]
    assert provider["provider"] == "scikit_build_core.metadata.regex"
    source = (ROOT / provider["input"]).read_text(encoding="utf-8")
    (found,) = re.findall(r'^__version__ = "([^"]+)"$', source, re.M)
    assert found == cumuli.__version__
    assert re.fullmatch(r"\d+\.\d+\.\d+", found)
    # No other file of the package states a version number of its own.
    for path in (ROOT / "python" / "cumuli").rglob("*.py"):
        if path.name != "_version.py":
            assert "__version__ =" not in path.read_text(encoding="utf-8"), path


def test_the_package_is_marked_typed() -> None:
    assert (ROOT / "python" / "cumuli" / "py.typed").is_file()


def test_the_pytest_plugin_is_registered_by_entry_point() -> None:
    assert PYPROJECT["project"]["entry-points"]["pytest11"] == {"cumuli.testing": "cumuli.testing"}
