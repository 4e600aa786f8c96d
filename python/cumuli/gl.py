"""Headless OpenGL through moderngl's standalone EGL context, and shader loading.

Every GL pipeline in cumuli (the fBm parity path, the ray marcher) gets its context here, loads
its GLSL from ``shaders/`` with the small ``#include "file.glsl"`` mechanism below, and releases
every GL object with the context.
"""

from __future__ import annotations

import logging
import re
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import moderngl

log = logging.getLogger("cumuli.gl")

_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.MULTILINE)


class GLUnavailableError(RuntimeError):
    """No OpenGL 4.3+ context could be created (no EGL library or no device)."""


def shader_dir() -> Path:
    """The folder holding the GLSL sources: inside the installed package, else the repository's."""
    packaged = Path(str(resources.files("cumuli"))) / "shaders"
    if packaged.is_dir():
        return packaged
    repo = Path(__file__).resolve().parents[2] / "shaders"
    if repo.is_dir():
        return repo
    raise FileNotFoundError("cumuli's shaders/ folder was not found next to the package")


@cache
def load_shader(name: str) -> str:
    """Source of ``shaders/<name>`` with ``#include "x.glsl"`` lines expanded (each file once)."""
    root = shader_dir()
    seen: set[str] = set()

    def expand(file: str, stack: tuple[str, ...]) -> str:
        if file in stack:
            raise ValueError(f"shader include cycle: {' -> '.join((*stack, file))}")
        path = root / file
        if not path.is_file():
            raise FileNotFoundError(f"shader {file!r} not found in {root}")
        if file in seen:
            return f"// {file} already included\n"
        seen.add(file)
        text = path.read_text(encoding="utf-8")
        return _INCLUDE.sub(lambda m: expand(m.group(1), (*stack, file)), text)

    return expand(name, ())


class GLContext:
    """A moderngl standalone (EGL) context; use as a context manager or call :meth:`close`.

    Raises :class:`GLUnavailableError` with a hint when EGL or a GPU/llvmpipe device is missing.
    """

    def __init__(self, require: int = 430) -> None:
        try:
            self.ctx: moderngl.Context = moderngl.create_context(
                standalone=True, backend="egl", require=require
            )
        except Exception as exc:  # moderngl/glcontext raise plain Exceptions
            raise GLUnavailableError(
                f"could not create a headless OpenGL {require // 100}.{require % 100 // 10} "
                f"context through EGL ({exc}). Install EGL and Mesa "
                "(Debian: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri) or run on a "
                "machine with a GPU driver."
            ) from exc
        self.renderer: str = self.ctx.info.get("GL_RENDERER", "unknown")
        self.closed = False
        log.info("GL_RENDERER: %s", self.renderer)

    @property
    def info(self) -> dict[str, Any]:
        return dict(self.ctx.info)

    def program(self, vertex: str, fragment: str) -> moderngl.Program:
        """Compile a program from two shader file names under ``shaders/``."""
        return self.ctx.program(vertex_shader=load_shader(vertex), fragment_shader=load_shader(fragment))

    def compute(self, name: str) -> moderngl.ComputeShader:
        """Compile a compute shader from a file name under ``shaders/``."""
        return self.ctx.compute_shader(load_shader(name))

    def close(self) -> None:
        """Release the context and every GL object made with it (idempotent)."""
        if not self.closed:
            self.ctx.release()
            self.closed = True

    def __enter__(self) -> GLContext:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:  # best effort; explicit close() is the contract
        try:
            self.close()
        except Exception:
            pass


def available() -> tuple[bool, str]:
    """Whether a headless context can be made here, and the renderer string or the reason."""
    try:
        with GLContext() as ctx:
            return True, ctx.renderer
    except GLUnavailableError as exc:
        return False, str(exc)
