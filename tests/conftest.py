"""Shared pytest fixtures: a GL context when EGL works here (tests marked `gl` skip otherwise)."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

import cumuli.gl as cgl

_GL_OK, _GL_INFO = cgl.available()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if _GL_OK:
        return
    skip = pytest.mark.skip(reason=f"no headless OpenGL here: {_GL_INFO}")
    for item in items:
        if "gl" in item.keywords:
            item.add_marker(skip)


def pytest_report_header(config: pytest.Config) -> str:
    return f"cumuli GL: {_GL_INFO if _GL_OK else 'unavailable — ' + _GL_INFO}"


@pytest.fixture(scope="session")
def gl_context() -> Iterator[cgl.GLContext]:
    """One GL context for the whole session (tests needing it are marked `gl`)."""
    with cgl.GLContext() as ctx:
        yield ctx


@pytest.fixture(scope="session")
def regen_references() -> bool:
    """True when reference images should be rewritten (CUMULI_REGEN=1)."""
    return os.environ.get("CUMULI_REGEN", "") == "1"
