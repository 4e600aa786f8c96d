"""The pytest side of ``cumuli.testing``: command-line options, the ``gl`` marker (tests marked
with it skip, with the reason, where no headless OpenGL context can be made) and the session's
``gl_context`` fixture."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from cumuli.testing.goldens import Settings


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("cumuli", "cumuli image checks")
    group.addoption(
        "--cumuli-update-goldens",
        action="store_true",
        default=False,
        help="rewrite the golden images given to assert_image_close from this run's renders",
    )
    group.addoption(
        "--cumuli-failures",
        default=None,
        metavar="DIR",
        help="folder for the images of failed comparisons (default: the ini option "
        "cumuli_failures, else _failures under the root folder)",
    )
    parser.addini("cumuli_failures", "folder for the images of failed comparisons", default="")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        "gl: needs an OpenGL context through EGL (skipped with a reason where none exists)",
    )
    Settings.update_goldens = bool(config.getoption("--cumuli-update-goldens"))
    folder = config.getoption("--cumuli-failures") or config.getini("cumuli_failures")
    Settings.failures_dir = Path(config.rootpath) / (folder or "_failures")


def _gl_status() -> tuple[bool, str]:
    from cumuli import gl

    return gl.available()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if not any("gl" in item.keywords for item in items):
        return
    ok, info = _gl_status()
    if ok:
        return
    skip = pytest.mark.skip(reason=f"no headless OpenGL here: {info}")
    for item in items:
        if "gl" in item.keywords:
            item.add_marker(skip)


def pytest_report_header(config: pytest.Config) -> str:
    ok, info = _gl_status()
    return f"cumuli GL: {info if ok else 'unavailable — ' + info}"


@pytest.fixture(scope="session")
def gl_context() -> Iterator[object]:
    """One headless GL context (a ``cumuli.gl.GLContext``) for the whole session; mark the tests
    that use it ``gl`` so that they skip where there is none."""
    from cumuli import gl

    with gl.GLContext() as ctx:
        yield ctx
