"""The GL backend: what every GL drawer of the stages stands on.

- :mod:`cumuli.gl.context`: the headless EGL context (one per thread, refused after fork),
  shader loading with ``#include``, and the GLSL fBm twin of :meth:`cumuli.Noise.fbm`.
- :mod:`cumuli.gl.sprites`: the shared sprite pipeline (Harris particles, Torchelsen billboards)
  and its C++ twin.
- :mod:`cumuli.gl.sprite_shading`: per-pixel billboard shading for that pipeline.

Like ``io`` and the top-level modules, ``gl`` serves the stages and imports none of them. The
context's public names are re-exported here (``cumuli.gl.GLContext``, ``cumuli.gl.fbm``, …);
the sprite modules are imported by name, so ``import cumuli.gl`` stays as light as before.
"""

from cumuli.gl.context import (
    FbmProgram,
    GLContext,
    GLForkError,
    GLThreadError,
    GLUnavailableError,
    available,
    close_default_context,
    default_context,
    fbm,
    load_shader,
    shader_dir,
    with_defines,
)

__all__ = [
    "FbmProgram",
    "GLContext",
    "GLForkError",
    "GLThreadError",
    "GLUnavailableError",
    "available",
    "close_default_context",
    "default_context",
    "fbm",
    "load_shader",
    "shader_dir",
    "with_defines",
]
