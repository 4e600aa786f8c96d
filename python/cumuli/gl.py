"""Headless OpenGL through moderngl's standalone EGL context, and shader loading.

Every GL pipeline in cumuli (the fBm parity path, the ray marcher) gets its context here, loads
its GLSL from ``shaders/`` with the small ``#include "file.glsl"`` mechanism below, and releases
every GL object with the context.
"""

from __future__ import annotations

import atexit
import logging
import re
import threading
import time
from functools import cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import moderngl
import numpy as np

from cumuli import _validate as check

if TYPE_CHECKING:
    from cumuli.noise import Noise

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


def with_defines(source: str, defines: dict[str, int]) -> str:
    """``source`` with ``#define NAME value`` lines inserted after its ``#version`` line."""
    lines = []
    for name, value in defines.items():
        if not re.fullmatch(r"[A-Z_][A-Z0-9_]*", name):
            raise ValueError(f"shader define name must be an upper-case identifier, got {name!r}")
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"shader define {name} must be an int, got {value!r}")
        lines.append(f"#define {name} {value}")
    head, sep, rest = source.partition("\n")
    if not head.lstrip().startswith("#version"):
        raise ValueError("shader source must start with a #version line")
    return head + sep + "\n".join(lines) + "\n" + rest


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
                "(Debian: apt-get install libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri) or run on a "
                "machine with a GPU driver."
            ) from exc
        self.renderer: str = self.ctx.info.get("GL_RENDERER", "unknown")
        self.closed = False
        self._timer_query: moderngl.Query | None = None
        log.info("GL_RENDERER: %s", self.renderer)

    @property
    def info(self) -> dict[str, Any]:
        return dict(self.ctx.info)

    def program(
        self, vertex: str, fragment: str, defines: dict[str, int] | None = None
    ) -> moderngl.Program:
        """Compile a program from two shader file names under ``shaders/``.

        ``defines`` become ``#define NAME value`` lines right after the fragment shader's
        ``#version`` line (compile-time variants, e.g. the marcher's candidate sort).
        """
        fragment_source = load_shader(fragment)
        if defines:
            fragment_source = with_defines(fragment_source, defines)
        self.make_current()
        return self.ctx.program(vertex_shader=load_shader(vertex), fragment_shader=fragment_source)

    def compute(self, name: str) -> moderngl.ComputeShader:
        """Compile a compute shader from a file name under ``shaders/``."""
        self.make_current()
        return self.ctx.compute_shader(load_shader(name))

    def timer_query(self) -> moderngl.Query:
        """This context's GL_TIME_ELAPSED query, made on first use and shared by every caller.

        moderngl (5.x) cannot release a query on its own (it goes with the context), so one per
        context, reused, keeps long-lived contexts from accumulating them.
        """
        if self._timer_query is None:
            self._timer_query = self.ctx.query(time=True)
        return self._timer_query

    def make_current(self) -> None:
        """Make this context the current one. moderngl sends every call to the current context,
        which is the last one created (or entered) — not necessarily the one an object belongs
        to — so every entry point that makes or uses GL objects (`_resolve_context`, `program`,
        `compute`, the renderers' draws) makes its context current first."""
        if self.closed:
            raise ValueError("this GL context is closed")
        self.ctx.__enter__()  # never exited: exiting would restore the previous (maybe dead) one

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


# --- the process-wide context used by convenience functions -------------------------------------

_default_context: GLContext | None = None
_default_lock = threading.Lock()


def default_context() -> GLContext:
    """A process-wide :class:`GLContext`, created on first use and closed at interpreter exit.

    Convenience functions (``cumuli.gl.fbm`` and the like) use it when no ``context`` is given, so
    that repeated calls do not pay for a new EGL context each time.
    """
    global _default_context
    with _default_lock:
        if _default_context is None or _default_context.closed:
            _default_context = GLContext()
        return _default_context


def close_default_context() -> None:
    """Close the process-wide context if it exists (a later call makes a new one)."""
    global _default_context
    with _default_lock:
        if _default_context is not None:
            _default_context.close()
            _default_context = None


atexit.register(close_default_context)


def _resolve_context(context: GLContext | None) -> GLContext:
    """``context`` (default: the process-wide one), made current: GL calls go to the current
    context, and the last one created may be another (see `GLContext.make_current`)."""
    if context is None:
        context = default_context()
    elif not isinstance(context, GLContext):
        raise TypeError(
            f"context must be a cumuli.gl.GLContext or None, got {type(context).__name__}"
        )
    if context.closed:
        raise ValueError("context is closed")
    context.make_current()
    return context


# --- fBm on the GPU (common/noise.glsl through noise/fbm_points.comp.glsl) -----------------------

#: Points per dispatch: 4 Mi points is 48 MiB of xyz, under llvmpipe's 128 MiB storage-block limit;
#: drivers with a smaller GL_MAX_SHADER_STORAGE_BLOCK_SIZE get smaller batches.
_FBM_BATCH = 1 << 22
_LOCAL_SIZE = 64  # local_size_x in fbm_points.comp.glsl
_MAX_GROUPS = 65535  # guaranteed minimum of GL_MAX_COMPUTE_WORK_GROUP_COUNT per axis


class FbmProgram:
    """The fBm compute program with one noise's lattice uploaded, reusable for many calls.

    The lattice goes to an R32F 3D texture with LINEAR filtering and REPEAT wrapping, which is
    what the paper's GPU implementation samples. Call the object like :func:`fbm`; after each call
    :attr:`gpu_time_ns` holds the dispatch time measured with a GL timer query (uploads and
    read-back excluded) and :attr:`dispatch_wall_s` the wall time from the dispatch to
    ``glFinish`` (llvmpipe runs compute work inside ``glDispatchCompute``, outside its timer
    queries, which then read ~0; the wall time is the meaningful number there). Release with
    :meth:`release` or use it as a context manager; closing its context releases it too.
    """

    def __init__(self, noise: Noise, context: GLContext | None = None) -> None:
        from cumuli.noise import Noise

        if not isinstance(noise, Noise):
            raise TypeError(f"noise must be a cumuli.Noise, got {type(noise).__name__}")
        self.context = _resolve_context(context)
        self.noise = noise
        self.gpu_time_ns: int | None = None
        self.dispatch_wall_s: float | None = None
        self._objects: list[Any] = []
        ctx = self.context.ctx
        size = noise.size
        if size > int(self.context.info.get("GL_MAX_3D_TEXTURE_SIZE", 2048)):
            raise ValueError(f"noise size {size} exceeds this GL's largest 3D texture")
        try:
            self.program = self.context.compute("noise/fbm_points.comp.glsl")
            self._objects.append(self.program)
            lattice = np.ascontiguousarray(noise.lattice, dtype=np.float32)
            self.texture = ctx.texture3d((size, size, size), 1, data=lattice.tobytes(), dtype="f4")
            self._objects.append(self.texture)
            self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.texture.repeat_x = self.texture.repeat_y = self.texture.repeat_z = True
            self._query = self.context.timer_query()
            max_block = int(self.context.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 24))
            self._batch = max(_LOCAL_SIZE, min(_FBM_BATCH, max_block // 12))
        except Exception:
            self.release()
            raise

    def __call__(
        self,
        points: np.ndarray,
        octaves: int = 5,
        gain: float = 0.5,
        lacunarity: float = 2.0,
        frequency: float = 1.0,
        exact: bool = False,
    ) -> np.ndarray:
        """fBm at ``(N, 3)`` points on the GPU; returns ``(N,)`` float32."""
        from cumuli.noise import _fbm_params, check_fbm_reach

        if self.program is None or self.context.closed:
            raise ValueError("this FbmProgram has been released")
        self.context.make_current()
        pts = check.points3(points, "points")
        octaves, gain, lacunarity, frequency = _fbm_params(octaves, gain, lacunarity, frequency)
        check_fbm_reach(pts, (octaves, gain, lacunarity, frequency), "points")
        if not isinstance(exact, (bool, np.bool_)):
            raise TypeError(f"exact must be a bool, got {type(exact).__name__}")
        n = pts.shape[0]
        out = np.empty(n, dtype=np.float32)
        self.gpu_time_ns = 0
        self.dispatch_wall_s = 0.0
        if n == 0:
            return out
        ctx = self.context.ctx
        prog = self.program
        prog["u_octaves"].value = octaves
        prog["u_gain"].value = gain
        prog["u_lacunarity"].value = lacunarity
        prog["u_frequency"].value = frequency
        prog["u_exact"].value = bool(exact)
        prog["u_lattice"].value = 0
        batch = min(n, self._batch)
        made: list[Any] = []
        try:
            src = ctx.buffer(reserve=batch * 12)
            made.append(src)
            dst = ctx.buffer(reserve=batch * 4)
            made.append(dst)
            self.texture.use(location=0)
            src.bind_to_storage_buffer(0)
            dst.bind_to_storage_buffer(1)
            for start in range(0, n, batch):
                count = min(batch, n - start)
                src.write(pts[start : start + count].tobytes())
                prog["u_count"].value = count
                groups = -(-count // _LOCAL_SIZE)
                gx = min(groups, _MAX_GROUPS)
                gy = -(-groups // gx)
                ctx.finish()  # uploads done: time the dispatch alone
                start_s = time.perf_counter()
                with self._query:
                    prog.run(gx, gy, 1)
                ctx.memory_barrier()
                ctx.finish()
                self.dispatch_wall_s += time.perf_counter() - start_s
                out[start : start + count] = np.frombuffer(dst.read(size=count * 4), np.float32)
                self.gpu_time_ns += int(self._query.elapsed)
        finally:
            for obj in made:
                obj.release()
        return out

    def release(self) -> None:
        """Release the program and the lattice texture (idempotent)."""
        if not self.context.closed:
            for obj in self._objects:
                obj.release()
        self._objects.clear()
        self.program = None

    def __enter__(self) -> FbmProgram:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def fbm(
    noise: Noise,
    points: np.ndarray,
    octaves: int = 5,
    gain: float = 0.5,
    lacunarity: float = 2.0,
    frequency: float = 1.0,
    exact: bool = False,
    context: GLContext | None = None,
) -> np.ndarray:
    """fBm (eq. 1) of ``noise`` at ``(N, 3)`` points, by ``shaders/common/noise.glsl`` on a GPU.

    This is the GLSL twin of :meth:`cumuli.Noise.fbm`, used to check that the shaders and the C++
    core agree. ``exact=True`` blends the 8 texels by hand with float weights (agrees with the
    C++ to float rounding); ``exact=False`` uses the hardware trilinear filter of the R32F
    LINEAR/REPEAT texture, as the renderer does, whose weights have reduced precision on most
    GPUs. Uses the process-wide :func:`default_context` unless ``context`` is given; every GL
    object made here is released before returning. Returns ``(N,)`` float32.
    """
    with FbmProgram(noise, context) as program:
        return program(points, octaves, gain, lacunarity, frequency, exact)
