"""`cumuli.gl` without a GL context: shader loading and its errors, the GL-unavailable error.

Not marked `gl`: these run everywhere, also where no EGL device exists.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import moderngl
import pytest

import cumuli.gl.context as cgl


@pytest.fixture
def shader_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """``load_shader`` reading from an empty temporary folder (its cache cleared around)."""
    monkeypatch.setattr(cgl, "shader_dir", lambda: tmp_path)
    cgl.load_shader.cache_clear()
    yield tmp_path
    cgl.load_shader.cache_clear()


def test_shader_includes_are_expanded() -> None:
    cgl.load_shader.cache_clear()
    src = cgl.load_shader("noise/fbm_points.comp.glsl")
    assert "#include" not in src
    assert "float fbm(vec3 p, bool exact)" in src
    assert src.lstrip().startswith("#version 430")


def test_nested_includes_expand_once_in_place(shader_folder: Path) -> None:
    (shader_folder / "main.glsl").write_text(
        '#version 430\n#include "a.glsl"\n#include "b.glsl"\nvoid main() {}\n'
    )
    (shader_folder / "a.glsl").write_text('#include "common.glsl"\nfloat a() { return c(); }\n')
    (shader_folder / "b.glsl").write_text('  #include "common.glsl"  \nfloat b() { return c(); }\n')
    (shader_folder / "common.glsl").write_text("float c() { return 1.0; }\n")
    src = cgl.load_shader("main.glsl")
    assert src.count("float c()") == 1  # included twice, expanded once
    assert "// common.glsl already included" in src
    assert "#include" not in src
    order = [src.index(s) for s in ("#version", "float c()", "float a()", "float b()", "main")]
    assert order == sorted(order)


def test_include_cycle_is_refused_with_the_chain(shader_folder: Path) -> None:
    (shader_folder / "a.glsl").write_text('#include "b.glsl"\n')
    (shader_folder / "b.glsl").write_text('#include "c.glsl"\n')
    (shader_folder / "c.glsl").write_text('#include "a.glsl"\n')
    with pytest.raises(
        ValueError, match=r"include cycle: a\.glsl -> b\.glsl -> c\.glsl -> a\.glsl"
    ):
        cgl.load_shader("a.glsl")


def test_self_include_is_a_cycle(shader_folder: Path) -> None:
    (shader_folder / "self.glsl").write_text('#version 430\n#include "self.glsl"\n')
    with pytest.raises(ValueError, match=r"cycle: self\.glsl -> self\.glsl"):
        cgl.load_shader("self.glsl")


def test_missing_include_names_the_file_and_folder(shader_folder: Path) -> None:
    (shader_folder / "main.glsl").write_text('#version 430\n#include "nowhere.glsl"\n')
    with pytest.raises(FileNotFoundError, match=r"'nowhere\.glsl' not found in") as err:
        cgl.load_shader("main.glsl")
    assert str(shader_folder) in str(err.value)
    with pytest.raises(FileNotFoundError, match=r"'absent\.glsl'"):
        cgl.load_shader("absent.glsl")


def test_failed_load_is_not_cached(shader_folder: Path) -> None:
    (shader_folder / "main.glsl").write_text('#version 430\n#include "late.glsl"\n')
    with pytest.raises(FileNotFoundError):
        cgl.load_shader("main.glsl")
    (shader_folder / "late.glsl").write_text("float late() { return 2.0; }\n")
    assert "float late()" in cgl.load_shader("main.glsl")


def _failing_create_context(**kwargs: object) -> moderngl.Context:
    raise Exception("eglGetDisplay failed (no EGL device)")


def test_context_failure_raises_gl_unavailable_with_a_hint(monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[dict] = []

    def fake(**kwargs: object) -> moderngl.Context:
        calls.append(kwargs)
        return _failing_create_context(**kwargs)

    monkeypatch.setattr(moderngl, "create_context", fake)
    with pytest.raises(cgl.GLUnavailableError) as err:
        cgl.GLContext()
    msg = str(err.value)
    assert calls == [{"standalone": True, "backend": "egl", "require": 430}]
    assert "OpenGL 4.3" in msg and "EGL" in msg
    assert "eglGetDisplay failed" in msg  # the cause is kept...
    assert "apt-get install" in msg and "libegl1" in msg and "libgl1" in msg  # ...with the fix
    assert isinstance(err.value.__cause__, Exception)
    assert isinstance(err.value, RuntimeError)


def test_context_failure_names_the_required_version(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(moderngl, "create_context", _failing_create_context)
    with pytest.raises(cgl.GLUnavailableError, match=r"OpenGL 4\.5"):
        cgl.GLContext(require=450)


def test_available_reports_the_reason_instead_of_raising(monkeypatch: pytest.MonkeyPatch) -> None:
    cgl.close_default_context()  # available() reuses the thread's default context when it has one
    monkeypatch.setattr(moderngl, "create_context", _failing_create_context)
    ok, reason = cgl.available()
    assert ok is False
    assert "eglGetDisplay failed" in reason and "apt-get install" in reason


def test_default_context_failure_propagates_and_leaves_nothing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    cgl.close_default_context()
    monkeypatch.setattr(moderngl, "create_context", _failing_create_context)
    with pytest.raises(cgl.GLUnavailableError):
        cgl.default_context()
    assert cgl._thread_default() is None
