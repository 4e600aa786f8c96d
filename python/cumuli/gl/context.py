"""Headless OpenGL through moderngl's standalone EGL context, and shader loading.

Every GL pipeline in cumuli (the fBm parity path, the ray marchers) gets its context here, loads
its GLSL from ``shaders/`` with the small ``#include "file.glsl"`` mechanism below, and releases
every GL object with the context.

Processes and threads (docs/conventions.md, "GL, threads and processes"):

- **One context per thread.** An EGL context is current in one thread at a time, so
  :func:`default_context` (what ``cu.render``, ``cu.Renderer()``, ``cumuli.gl.fbm`` and
  ``cu.render_volume`` use) is per thread: each thread gets its own, made on first use and
  reused by every later call in that thread. A context made explicitly (``GLContext()``) belongs
  to the thread that made it; using it from another thread raises :class:`GLThreadError`.
- **Several contexts in one thread** are fine: every GL entry point makes its own context
  current first (EGL makes the newest context current on creation).
- **No GL after fork.** Mesa keeps its EGL display and llvmpipe's rasteriser threads per
  process, and a forked child inherits them without the threads: it would wait for them forever.
  A process forked after GL was used refuses GL with :class:`GLForkError` (a
  :class:`GLUnavailableError`); worker processes that render with GL must be started with the
  ``spawn`` (or ``forkserver``) method, or render with ``backend="cpu"``.
- **Reuse.** Each EGL context opened and closed leaves ~38 KB behind in Mesa/glcontext, so the
  common paths reuse the thread's default context instead of opening new ones.
"""

from __future__ import annotations

import atexit
import logging
import os
import re
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import moderngl
import numpy as np

from cumuli._util import validate as check

if TYPE_CHECKING:
    from cumuli.noise import Noise

log = logging.getLogger("cumuli.gl")

_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.MULTILINE)


class GLUnavailableError(RuntimeError):
    """No OpenGL 4.3+ context could be created (no EGL library or no device)."""


class GLForkError(GLUnavailableError):
    """GL was used by a parent of this process before it forked: Mesa's state cannot be used."""


class GLThreadError(RuntimeError):
    """A GL context (or an object made with it) was used from a thread that did not make it."""


#: The process that made the first GL context (EGL state lives in it); children forked from it
#: cannot use GL.
_gl_pid: int | None = None
#: Contexts made by this process (tests and diagnostics).
contexts_made = 0
#: Per thread: its default context (``context``) and the context current in it (``current``).
_local = threading.local()


def _fork_error(parent: int | None) -> GLForkError:
    return GLForkError(
        f"OpenGL was initialised in process {parent} before it forked this process "
        f"({os.getpid()}): Mesa's EGL state does not survive fork (a draw would wait forever for "
        "the parent's rasteriser threads). Start worker processes with the 'spawn' method "
        "(multiprocessing.get_context('spawn').Pool(...), or concurrent.futures."
        "ProcessPoolExecutor(mp_context=multiprocessing.get_context('spawn'))), or render with "
        "backend='cpu' in the workers."
    )


def _thread_error(what: str, owner: str) -> GLThreadError:
    return GLThreadError(
        f"{what} belongs to thread {owner!r} and EGL contexts are bound to the thread that made "
        f"them; this is thread {threading.current_thread().name!r}. Call cu.render / "
        "cumuli.gl.fbm (each thread gets its own default context) or make a cu.Renderer() / "
        "cumuli.gl.GLContext() in each thread."
    )


def shader_dir() -> Path:
    """The folder holding the GLSL sources: inside the installed package, else the repository's."""
    packaged = Path(str(resources.files("cumuli"))) / "shaders"
    if packaged.is_dir():
        return packaged
    repo = Path(__file__).resolve().parents[3] / "shaders"
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


#: The core-profile OpenGL versions a context may require (``major * 100 + minor * 10``).
GL_VERSIONS = (330, 400, 410, 420, 430, 440, 450, 460)


class GLContext:
    """A moderngl standalone (EGL) context; use as a context manager or call :meth:`close`.

    Belongs to the thread that made it (:class:`GLThreadError` from others) and to this process
    (:class:`GLForkError` in a forked child). Raises :class:`GLUnavailableError` with a hint when
    EGL or a GPU/llvmpipe device is missing.
    """

    def __init__(self, require: int = 430) -> None:
        global _gl_pid, contexts_made
        self.closed = True  # until made: __del__ of a failed construction does nothing
        if isinstance(require, bool) or not isinstance(require, int):
            raise TypeError(
                f"require must be an OpenGL version as an int (430 for 4.3), got {require!r}"
            )
        if require not in GL_VERSIONS:
            raise ValueError(
                f"require must be one of the OpenGL versions {GL_VERSIONS} (430 for 4.3: the "
                f"compute shaders need it), got {require}"
            )
        pid = os.getpid()
        if _gl_pid is not None and _gl_pid != pid:
            raise _fork_error(_gl_pid)
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
        _gl_pid = pid
        contexts_made += 1
        self._pid = pid
        self._thread = threading.get_ident()
        self._thread_name = threading.current_thread().name
        _local.current = self  # EGL made it current
        self.renderer: str = self.ctx.info.get("GL_RENDERER", "unknown")
        self.closed = False
        self._timer_query: moderngl.Query | None = None
        log.info("GL_RENDERER: %s", self.renderer)

    def check_usable(self, what: str = "this GL context") -> None:
        """Raise unless this context can be used here: open, this process, this thread."""
        if os.getpid() != self._pid:
            raise _fork_error(self._pid)
        if self.closed:
            raise RuntimeError(f"{what} is closed (its GL context was released)")
        if threading.get_ident() != self._thread:
            raise _thread_error(what, self._thread_name)

    @contextmanager
    def activate(self, what: str = "this GL context") -> Iterator[GLContext]:
        """Make this context current in this thread (checked by :meth:`check_usable`) for the
        ``with`` body; it stays current afterwards, until another context is activated or made.

        Every GL entry point of cumuli runs inside it: EGL makes a new context current when it
        is made, so without it a second context in the same thread would receive the first
        one's draws.
        """
        self.check_usable(what)
        if getattr(_local, "current", None) is not self:
            self.ctx.__enter__()  # eglMakeCurrent
            _local.current = self
        yield self

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
        with self.activate():
            return self.ctx.program(
                vertex_shader=load_shader(vertex), fragment_shader=fragment_source
            )

    def compute(self, name: str) -> moderngl.ComputeShader:
        """Compile a compute shader from a file name under ``shaders/``."""
        with self.activate():
            return self.ctx.compute_shader(load_shader(name))

    def timer_query(self) -> moderngl.Query:
        """This context's GL_TIME_ELAPSED query, made on first use and shared by every caller.

        moderngl (5.x) cannot release a query on its own (it goes with the context), so one per
        context, reused, keeps long-lived contexts from accumulating them. A context's first
        timed draw reads 2³²−1 on llvmpipe, so a 1×1 draw is timed once here, when the query is
        made, and the first real draw is timed properly.
        """
        if self._timer_query is None:
            with self.activate():
                query = self.ctx.query(time=True)
                self._warm_up(query)
                self._timer_query = query
        return self._timer_query

    def _warm_up(self, query: moderngl.Query) -> None:
        ctx = self.ctx
        made: list[Any] = []
        try:
            prog = ctx.program(
                vertex_shader="#version 330\nvoid main() { gl_Position = vec4("
                "float((gl_VertexID << 1) & 2) * 2.0 - 1.0, float(gl_VertexID & 2) * 2.0 - 1.0, "
                "0.0, 1.0); }",
                fragment_shader="#version 330\nout vec4 c;\nvoid main() { c = vec4(1.0); }",
            )
            made.append(prog)
            vao = ctx.vertex_array(prog, [])
            made.append(vao)
            tex = ctx.texture((1, 1), 4)
            made.append(tex)
            fbo = ctx.framebuffer(color_attachments=[tex])
            made.append(fbo)
            fbo.use()
            with query:
                vao.render(mode=moderngl.TRIANGLES, vertices=3)
                ctx.finish()
            _ = query.elapsed
        finally:
            for obj in reversed(made):
                obj.release()

    def make_current(self) -> None:
        """Make this context current in this thread and leave it so (:meth:`activate` without
        the ``with``): moderngl sends every call to the current context, the last one created or
        entered, which need not be the one an object belongs to."""
        with self.activate():
            pass

    def close(self) -> None:
        """Release the context and every GL object made with it (idempotent). In a process
        forked from its owner it is only marked closed: the parent's context is never touched.
        """
        if self.closed:
            return
        if os.getpid() != self._pid:
            self.closed = True
            return
        if threading.get_ident() != self._thread:
            raise _thread_error("this GL context", self._thread_name)
        self.closed = True
        if getattr(_local, "current", None) is self:
            _local.current = None
        self.ctx.release()

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
    """Whether GL can be used in this thread, and the renderer string or the reason.

    Uses (and keeps) the thread's default context rather than opening and closing one.
    """
    try:
        return True, default_context().renderer
    except GLUnavailableError as exc:
        return False, str(exc)


# --- the per-thread default context used by convenience functions -------------------------------


def _thread_default() -> GLContext | None:
    ctx = getattr(_local, "context", None)
    if ctx is None or ctx.closed or ctx._pid != os.getpid():
        return None
    return ctx


def default_context() -> GLContext:
    """This thread's default :class:`GLContext`, created on first use and reused.

    Convenience functions (``cu.render``, ``cu.Renderer()``, ``cumuli.gl.fbm`` and the like) use
    it when no ``context`` is given, so repeated calls do not pay for (and leak) a new EGL
    context each time. Each thread has its own (EGL contexts are bound to one thread); the main
    thread's is closed at interpreter exit, another thread's when that thread ends.
    """
    ctx = _thread_default()
    if ctx is None:
        ctx = GLContext()
        _local.context = ctx
    return ctx


def close_default_context() -> None:
    """Close this thread's default context if it exists (a later call makes a new one)."""
    ctx = getattr(_local, "context", None)
    _local.context = None
    if ctx is not None:
        ctx.close()


atexit.register(close_default_context)


def check_context(context: Any) -> None:
    """Refuse a ``context`` argument that is neither a :class:`GLContext` nor None — on every
    backend, so that a CPU call does not accept what the GL one would refuse."""
    if context is not None and not isinstance(context, GLContext):
        raise TypeError(
            f"context must be a cumuli.gl.GLContext or None, got {type(context).__name__}"
        )


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
    context.check_usable()
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
        self.program: Any = None
        ctx = self.context.ctx
        size = noise.size
        if size > int(self.context.info.get("GL_MAX_3D_TEXTURE_SIZE", 2048)):
            raise ValueError(f"noise size {size} exceeds this GL's largest 3D texture")
        with self.context.activate():
            self._make(ctx, noise)

    def _make(self, ctx: moderngl.Context, noise: Noise) -> None:
        size = noise.size
        try:
            self.program = self.context.compute("noise/fbm_points.comp.glsl")
            self._objects.append(self.program)
            # Version 2's exact lookup hashes its corners; the texture holds the same values.
            self._hash, self._key = noise.version == 2, noise.key
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
        if self.program is None or self.context.closed:
            raise ValueError("this FbmProgram has been released")
        with self.context.activate("this FbmProgram's GL context"):
            return self._run(points, octaves, gain, lacunarity, frequency, exact)

    def _run(
        self,
        points: np.ndarray,
        octaves: int,
        gain: float,
        lacunarity: float,
        frequency: float,
        exact: bool,
    ) -> np.ndarray:
        from cumuli.noise import _fbm_params, check_fbm_reach

        pts, biggest = check.points3_magnitude(points, "points")
        octaves, gain, lacunarity, frequency = _fbm_params(octaves, gain, lacunarity, frequency)
        check_fbm_reach(biggest, (octaves, gain, lacunarity, frequency), "points")
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
        for name, value in (("u_noise_hash", self._hash), ("u_noise_key", self._key)):
            if name in prog:  # absent where the compiler dropped the exact lookup
                prog[name].value = value
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
        if not self.context.closed and self._objects:
            with self.context.activate("this FbmProgram's GL context"):
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
