"""The compositor: one `render` for scenes holding any kinds of cloud (RENDER_CONTRACT,
"Compositor").

A render is three steps: the checks that need no light, the light step
(:func:`cumuli.prepare_light`, skipped for a :class:`cumuli.LitScene`; its camera-dependent part,
:func:`cumuli.light.view.seen_from`, per frame), and the draw. A scene
whose drawables one drawer can draw in a single pass over the sky — only 2018 clouds (the
marcher orders them per pixel itself), or a single drawable — is drawn so, bit-identical to that
drawer on its own. Otherwise every drawable is drawn as a premultiplied layer ``(colour, 1 − T)``
and ``_core.composite_layers`` (C++, shared by both backends) combines them over the sky, front
to back per pixel by the ray's entry into each drawable's ``layer_box()``.

:class:`Renderer` owns a GL context and one drawer per kind (made on first use);
:func:`render` uses a process-wide one, or the CPU twins with ``backend="cpu"``.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from cumuli import _core, registry
from cumuli._util import progress as _progress
from cumuli._util import validate as check
from cumuli.camera import Camera
from cumuli.gl.context import GLContext, _thread_default, check_context, default_context
from cumuli.gl.tiles import Tiles
from cumuli.ground import ground_args
from cumuli.light.physical import view_depth_scale
from cumuli.light.prepare import LitScene, prepare_light
from cumuli.light.view import seen_from
from cumuli.model.volume import DEFAULT_DETAIL, VolumeCloud
from cumuli.rendering.air import finish
from cumuli.rendering.marcher_cpu import check_stats_scene, combined_stats
from cumuli.rendering.painters import CountingCPUPainter, CPUPainter, GLPainter
from cumuli.rendering.params import camera_params
from cumuli.rendering.volume import MAX_IMAGE, camera_rays
from cumuli.scene import Scene
from cumuli.settings import RenderSettings
from cumuli.sky import Sun, as_sky, sky_args

#: Largest tile drawn in one call (keeps each draw short on software GL and under driver timeouts).
TILE = 1024
#: Largest image accepted, in pixels (2²⁶ RGBA32F pixels = 1 GiB of output).
MAX_PIXELS = 1 << 26
#: Most bytes the layers of one layered render may take (one (H, W, 4) float32 layer per call).
MAX_LAYER_BYTES = 1 << 31
MAX_EDGE = 1 << 14  #: Largest image edge of the CPU backend.
BACKENDS = ("gl", "cpu")


def _one_drawer(kinds: set[str]) -> bool:
    """Whether grouped ``kinds`` share one drawer on both backends (one pass draws them all)."""
    found = [registry.get(k) for k in kinds]
    return (
        all(k is not None and k.groups for k in found)
        and len({k.gl_drawer for k in found}) == 1  # type: ignore[union-attr]
        and len({k.cpu_drawer for k in found}) == 1  # type: ignore[union-attr]
    )


def plan(scene: Scene) -> list[tuple[str, list[int]]]:
    """The draw calls of ``scene``: one ``(kind, indices)`` over the sky when one pass can draw
    everything (an empty scene draws the sky with the marcher; grouped kinds sharing a drawer
    count as one; a ground needs a drawer that draws it), else one per drawable (so with solids,
    each composited with them by its own box)."""
    kinds = scene.kinds
    if not kinds:
        return [("cloud", [])]
    if single_pass(scene):
        return [(kinds[0], list(range(len(kinds))))]
    return [(kind, [k]) for k, kind in enumerate(kinds)]


def _union_box(scene: Scene, indices: Sequence[int]) -> np.ndarray:  # of drawables' layer boxes
    boxes = np.array([scene.clouds[k].layer_box() for k in indices], np.float32)
    return np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])


def single_pass(scene: Scene) -> bool:
    """Whether one drawer draws the whole scene over its background (see :func:`plan`)."""
    if scene.solids:
        return False
    kinds = scene.kinds
    if not kinds:
        return True
    one = len(kinds) == 1 or _one_drawer(set(kinds))
    return one and (scene.ground is None or _kind(kinds[0]).draws_ground)


def _edge_pass(scene: Scene, kind: str, indices: Sequence[int]) -> bool:
    """Whether a single pass of ``kind`` gets the edge pass (:mod:`cumuli.rendering.edges`):
    the 2018 marcher's clouds in the physical mode with its resolve pass."""
    s = scene.settings
    return kind == "cloud" and bool(indices) and s.physical and s.resolve and not scene.solids


def compose(
    lit: LitScene,
    camera: Camera,
    width: int,
    height: int,
    painter: Any,
    threads: int = 0,
    impostors: Any = None,
) -> np.ndarray:
    """Draw ``lit`` with ``painter`` (:mod:`cumuli.rendering.painters`) and composite the layers,
    the solids and the ground over the sky (see the module doc); ``impostors`` an
    :class:`~cumuli.rendering.impostor_cache.ImpostorCache` draws every layer through it."""
    lit = seen_from(lit, camera)
    scene = lit.scene
    calls = plan(scene)
    if impostors is None and single_pass(scene):
        kind, indices = calls[0]
        if _edge_pass(scene, kind, indices):
            image, edges = painter.edged(lit, indices, camera, width, height)
        else:
            image, edges = painter.layer(lit, kind, indices, camera, width, height, True), None
        return finish(image, scene, camera, lit.shadow, threads, edges, in_place=True)
    if impostors is not None:
        layer_list, box_list = impostors.layers(lit, calls, camera, width, height, painter)
        kinds = []  # impostors are images: their layers composite by their coverage
    else:
        layer_list, box_list, kinds = [], [], []
        for kind, indices in calls:
            if indices:
                layer_list.append(painter.layer(lit, kind, indices, camera, width, height, False))
                box_list.append(_union_box(scene, indices))
                kinds.append(kind)
    layers = np.stack(layer_list) if layer_list else np.zeros((0, height, width, 4), np.float32)
    boxes = np.array(box_list, np.float32).reshape(-1, 2, 3)
    solid = painter.solids(lit, camera, width, height) if scene.solids else None
    image = _core.composite_layers(
        layers, boxes, camera_params(camera), sky_args(scene.sky), scene.sun.direction,
        scene.sun.radiance, check.threads(threads),
        solid,
        ground_args(scene.ground, scene.sky, lit.shadow),
        view_scales(scene, kinds) if kinds else None,
    )  # fmt: skip
    return finish(image, scene, camera, lit.shadow, threads, in_place=True)


def view_scales(scene: Scene, kinds: Sequence[str]) -> np.ndarray:
    """Each layer's view scale for the compositor: in the physical mode a medium's (a 2018
    cloud, a volume, a deck: drawn by the marchers) is the δ-M view's ``1 − f·ϖ``
    (:func:`cumuli.light.physical.view_depth_scale`), what lies behind it showing through
    ``(1 − A)^v``, as within one march; a sprite layer's (particles, billboards) is 1."""
    v = view_depth_scale(scene.settings) if scene.settings.physical else 1.0
    return np.array([v if _kind(k).medium else 1.0 for k in kinds], np.float32)


def _lit(scene: Any) -> tuple[LitScene | None, Scene]:
    if isinstance(scene, LitScene):
        return scene, scene.scene
    if isinstance(scene, Scene):
        return None, scene
    raise TypeError(f"scene must be a cumuli.Scene or cumuli.LitScene, got {type(scene).__name__}")


def _check_size(
    width: Any, height: Any, max_edge: int, limit_name: str | None = None
) -> tuple[int, int]:
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise TypeError(f"{name} must be an integer, got {type(v).__name__}")
        if v < 1:
            raise ValueError(f"{name} must be >= 1, got {v}")
        if v > max_edge:
            why = f" ({limit_name})" if limit_name else ""
            raise ValueError(f"{name} must be <= {max_edge}{why}, got {v}")
    if int(width) * int(height) > MAX_PIXELS:
        raise ValueError(
            f"image of {width}x{height} pixels is larger than the limit of {MAX_PIXELS} pixels"
        )
    return int(width), int(height)


def _kind(name: str) -> registry.Kind:
    found = registry.get(name)
    if found is None:
        raise TypeError(f"no kind of drawable is registered as {name!r}")
    return found


def _check_kinds(scene: Scene, backend: str) -> None:
    for k, kind in enumerate(scene.kinds):
        found = registry.get(kind)
        if found is None or getattr(found, f"{backend.lower()}_drawer", None) is None:
            raise TypeError(f"scene.clouds[{k}]: the {backend} backend has no drawer for {kind!r}")


def _check_layers(scene: Scene, width: int, height: int) -> None:
    """The layers of a layered render (one per draw call) must fit in ``MAX_LAYER_BYTES``."""
    if single_pass(scene):
        return
    calls = plan(scene)
    need = len(calls) * width * height * 16
    if need > MAX_LAYER_BYTES:
        raise ValueError(
            f"the scene's {len(calls)} layers of {width}x{height} pixels need {need >> 20} MiB, "
            f"more than {MAX_LAYER_BYTES >> 20} MiB: render a smaller image or fewer drawables "
            "of mixed kinds (drawables of one grouped kind share a layer)"
        )


# --------------------------------------------------------------------------------------------
class Renderer:
    """A GL renderer of scenes of every kind; use as a context manager or call :meth:`close`.

    Parameters
    ----------
    context:
        A :class:`cumuli.gl.GLContext` to draw with (never closed by :meth:`close`); by default
        the calling thread's default context (:func:`cumuli.gl.default_context`, shared with
        :func:`render`), so making and closing renderers opens no new EGL context. A renderer
        belongs to the thread of its context: from another thread it raises
        :class:`cumuli.gl.GLThreadError` (make one renderer per thread, or call :func:`render`).
    tile:
        Largest tile edge drawn per draw call (images larger than this are rendered in tiles).
    """

    def __init__(self, context: GLContext | None = None, tile: int = TILE) -> None:
        self.closed = False
        self._drawers: dict[str, Any] = {}
        self._extras: dict[str, Any] = {}
        self._impostors: Any = None
        # Arguments first: a bad one must not leave a context behind.
        self.tile = check.integer(tile, "tile", 16, 4096)
        if context is not None:
            if not isinstance(context, GLContext):
                raise TypeError(
                    f"context must be a cumuli.gl.GLContext or None, got {type(context).__name__}"
                )
            if context.closed:
                raise ValueError("context is closed")
        self.gl = default_context() if context is None else context
        self.gl.check_usable()
        self.tiles = Tiles(self.gl, self.tile)
        self.gl.make_current()
        try:
            with self.gl.activate():
                self.drawer("cloud")  # the marcher compiles now: a broken driver fails here
                self.gl.timer_query()
        except Exception:
            self.close()
            raise
        self.max_texture_size = int(self.gl.ctx.info["GL_MAX_TEXTURE_SIZE"])
        #: GPU time of the last render's draws in nanoseconds (GL timer queries of the tiled
        #: passes); None when the driver could not time a draw.
        self.last_gpu_ns: int | None = None

    @property
    def renderer_string(self) -> str:
        """The GL_RENDERER string of the context (e.g. ``llvmpipe (LLVM 15.0.6, 256 bits)``)."""
        return self.gl.renderer

    def make_current(self) -> None:
        """Make this renderer's context current in this thread, and leave it so (for GL calls
        made outside :meth:`render`, which does it itself)."""
        with self.gl.activate("this Renderer's GL context"):
            pass

    def drawer(self, kind: str) -> Any:
        """The GL drawer of ``kind`` (made on first use)."""
        if kind not in self._drawers:
            self._drawers[kind] = _kind(kind).gl_drawer(self.gl, self.tiles)
        return self._drawers[kind]

    def extra(self, name: str, make: Callable[[GLContext, Tiles], Any]) -> Any:
        """A helper drawer of this renderer (solids, impostor display), made on first use."""
        if name not in self._extras:
            self._extras[name] = make(self.gl, self.tiles)
        return self._extras[name]

    @property
    def impostor_cache(self) -> Any:
        """This renderer's own :class:`cumuli.ImpostorCache` (``render(..., impostors=True)``)."""
        if self._impostors is None:
            from cumuli.rendering.impostor_cache import ImpostorCache

            self._impostors = ImpostorCache(self)
        return self._impostors

    def render(
        self,
        scene: Scene | LitScene,
        camera: Camera,
        width: int,
        height: int,
        impostors: Any = None,
        progress: bool | None = None,
    ) -> np.ndarray:
        """Render ``scene`` seen by ``camera``: ``(height, width, 4)`` float32 linear RGBA, row 0
        at the top, alpha = 1 − transmittance. A `Scene`'s light is prepared first
        (:func:`cumuli.prepare_light`); a `LitScene` is drawn with its own. ``impostors``: an
        :class:`cumuli.ImpostorCache` kept across frames (``True``: this renderer's own) draws
        every drawable through its impostor (Harris 2002 §3). Light passes and tiles that take
        more than a few seconds show a progress bar (``progress=False``: none)."""
        if self.closed:
            raise RuntimeError("this Renderer is closed")
        with self.gl.activate("this Renderer's GL context"):
            self.tiles.progress = progress
            try:
                return self._render(scene, camera, width, height, impostors, progress)
            finally:
                self.tiles.progress = None

    def _render(
        self,
        scene: Any,
        camera: Any,
        width: Any,
        height: Any,
        impostors: Any,
        progress: bool | None,
    ) -> np.ndarray:
        lit, plain = _lit(scene)
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
        width, height = _check_size(width, height, self.max_texture_size, "GL_MAX_TEXTURE_SIZE")
        cache = self._cache_arg(impostors)
        _check_kinds(plain, "GL")
        _check_layers(plain, width, height)
        for kind, indices in plan(plain):  # before the light pass, which could be long
            drawer = self.drawer(kind)
            drawer.check(plain, indices)
            if lit is None and hasattr(drawer, "check_light"):
                drawer.check_light(plain, indices)  # the light the light step will make
        lit = prepare_light(plain, progress=progress) if lit is None else lit
        self.tiles.last_gpu_ns = None
        image = compose(lit, camera, width, height, GLPainter(self), impostors=cache)
        marched = cache is None and single_pass(plain) and plan(plain)[0][0] == "cloud"
        self.last_gpu_ns = self.tiles.last_gpu_ns if marched else None
        return image

    def _cache_arg(self, impostors: Any) -> Any:
        from cumuli.rendering.impostor_cache import ImpostorCache

        if impostors is None or impostors is False:
            return None
        if impostors is True:
            return self.impostor_cache
        if not isinstance(impostors, ImpostorCache):
            raise TypeError(
                f"impostors must be a cumuli.ImpostorCache, True or None, got "
                f"{type(impostors).__name__}"
            )
        if impostors.renderer is not None and impostors.renderer is not self:
            if not getattr(impostors.renderer, "closed", False):
                raise ValueError("this ImpostorCache belongs to another Renderer")
            impostors.detach()  # its renderer is closed: keep the images, re-upload them here
        impostors.renderer = self
        return impostors

    # --- lifetime ---------------------------------------------------------------------------
    def close(self) -> None:
        """Release every GL object (and the context when this renderer created it)."""
        if self.closed:
            return
        self.closed = True
        if hasattr(self, "gl") and not self.gl.closed and self.gl._pid == os.getpid():
            with self.gl.activate("this Renderer's GL context"):
                if getattr(self, "_impostors", None) is not None:
                    self._impostors.clear()
                for drawer in [*self._drawers.values(), *getattr(self, "_extras", {}).values()]:
                    try:
                        drawer.release()
                    except Exception:
                        pass
                if hasattr(self, "tiles"):
                    self.tiles.release()
        self._drawers.clear()
        getattr(self, "_extras", {}).clear()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:  # best effort; close() is the contract
        try:
            self.close()
        except Exception:
            pass


# --------------------------------------------------------------------------------------------
_shared = threading.local()


def shared_renderer() -> Renderer:
    """This thread's renderer used by :func:`render` (created on first use; drawn with the
    thread's default context, shared with the other GL conveniences)."""
    renderer = getattr(_shared, "renderer", None)
    if renderer is None or renderer.closed or renderer.gl is not _thread_default():
        renderer = Renderer(context=default_context())
        _shared.renderer = renderer
    return renderer


def render_cpu(
    scene: Scene | LitScene,
    camera: Camera,
    width: int,
    height: int,
    threads: int = 0,
    impostors: Any = None,
    progress: bool | None = None,
    return_stats: bool = False,
) -> Any:
    """Render ``scene`` seen by ``camera`` with the C++ twins of every drawer and the C++
    compositor; returns ``(height, width, 4)`` float32 linear RGBA, row 0 at the top, alpha
    ``1 − T``. ``threads=0`` uses every core; the image does not depend on the thread count.
    ``impostors``: an :class:`cumuli.ImpostorCache` kept across frames. Ctrl-C stops it between
    chunks of rows; a progress bar shows when it takes more than a few seconds
    (``progress=False``: none). ``return_stats=True`` (2018 clouds only, no solids or
    impostors: the marcher's single pass) returns ``(image, MarchStats)``: the same image and
    the marcher's work (fBm evaluations, steps), the edge pass's rays included."""
    from cumuli.rendering.impostor_cache import ImpostorCache

    lit, plain = _lit(scene)
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a cumuli.Camera, got {type(camera).__name__}")
    # Arguments are checked before the (possibly long) light pass runs.
    width, height = _check_size(width, height, MAX_EDGE)
    threads = check.threads(threads)
    if impostors is not None and not isinstance(impostors, ImpostorCache):
        raise TypeError(
            f"impostors must be a cumuli.ImpostorCache or None, got {type(impostors).__name__}"
        )
    _check_kinds(plain, "CPU")
    _check_layers(plain, width, height)
    if check.flag(return_stats, "return_stats"):
        check_stats_scene(plain, impostors)
    lit = prepare_light(plain, threads=threads, progress=progress) if lit is None else lit
    with _progress.core("render (cpu)", progress):
        if return_stats:
            counting = CountingCPUPainter(threads)
            image = compose(lit, camera, width, height, counting, threads)
            return image, combined_stats(counting.passes, width, height)
        return compose(lit, camera, width, height, CPUPainter(threads), threads, impostors)


def render(
    scene: Scene | LitScene,
    camera: Camera | None = None,
    width: int = 640,
    height: int = 480,
    backend: str = "gl",
    impostors: Any = None,
    progress: bool | None = None,
    return_stats: bool = False,
) -> Any:
    """Render ``scene`` (a `Scene` or a `LitScene`) to an ``(height, width, 4)`` float32 linear
    RGBA image, row 0 on top (``(image, MarchStats)`` with ``return_stats``: `render_cpu`).

    ``backend="gl"`` runs the GLSL drawers in a process-wide headless context; ``"cpu"`` runs
    their C++ twins (same contract, for parity and for machines without EGL). ``camera``
    defaults to :meth:`Scene.default_camera`. ``impostors``: an :class:`cumuli.ImpostorCache`
    kept across frames (Harris 2002 §3). Steps that take more than a few seconds (light passes,
    tiles, the CPU marcher) show a progress bar unless ``progress=False`` (or
    ``CUMULI_PROGRESS=0``).
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    _, plain = _lit(scene)
    if camera is None:
        camera = plain.default_camera()
    if return_stats is not False and backend != "cpu":
        raise ValueError("return_stats needs backend='cpu' (the CPU marcher counts its work)")
    if backend == "gl":
        return shared_renderer().render(
            scene, camera, width, height, impostors=impostors, progress=progress
        )
    kw = {"impostors": impostors, "progress": progress, "return_stats": return_stats}
    return render_cpu(scene, camera, width, height, **kw)


def _as_camera(camera: Any) -> Camera:
    if isinstance(camera, Camera):
        return camera
    if isinstance(camera, dict):
        raise TypeError("camera must be a cumuli.Camera or an object with position, target, fov")
    rays = camera_rays(camera)  # validates a duck-typed camera
    target = np.add(rays["position"], rays["forward"])
    return Camera(rays["position"], tuple(target), getattr(camera, "up", (0, 1, 0)), camera.fov)


def render_volume(
    volume: Any,
    light: Any,
    box: tuple[Sequence[float], Sequence[float]],
    camera: Any,
    width: int,
    height: int,
    sun: Sun | None = None,
    sky: Any = None,
    backend: str = "cpu",
    *,
    sigma_t: float | None = None,
    albedo: float = 1.0,
    g: float = 0.2,
    step: float | None = None,
    threads: int = 0,
    context: GLContext | None = None,
    settings: RenderSettings | None = None,
    detail: float = DEFAULT_DETAIL,
    reconstruction: str = "cubic",
) -> np.ndarray:
    """Render one lit density volume: ``(height, width, 4)`` float32 linear RGBA, row 0 on top.

    ``volume`` ``(D, H, W)`` densities over ``box = (box_min, box_max)``; ``light`` ``(D, H, W, 4)``
    from :meth:`cumuli.VolumeLighting.light` (made with the same ``sigma_t``). ``step`` defaults
    to half the smallest voxel edge. ``g`` is the Henyey–Greenstein asymmetry of sun scattering.
    With ``settings=RenderSettings(lighting="physical")`` the physical mode lights the volume
    (``σt = sigma_t·volume``; ``light`` may be None, the light step computes its own).
    ``sigma_t=None`` is the mode's extinction per unit density: 1 in the paper mode,
    ``settings.extinction_scale`` in the physical mode (the volume then reads like a 2018 cloud
    of the same density); ``detail``, ``reconstruction``: its sharp reading (`VolumeCloud`'s).
    ``settings`` left None is the paper mode when a ``light`` is given (the volume's own light
    model draws it) and the physical mode (the default) when it is None.
    A thin wrapper: a scene holding one :class:`cumuli.VolumeCloud` through :func:`render`.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    sun = Sun() if sun is None else sun
    if not isinstance(sun, Sun):
        raise TypeError(f"sun must be a cumuli.Sun, got {type(sun).__name__}")
    sky = as_sky(sky)
    width = check.integer(width, "width", 1, MAX_IMAGE)
    height = check.integer(height, "height", 1, MAX_IMAGE)
    cam = _as_camera(camera)
    if settings is None:  # a light given is the volume's own model, drawn outside the physical mode
        settings = RenderSettings(lighting="paper") if light is not None else RenderSettings()
    if not isinstance(settings, RenderSettings):
        raise TypeError(f"settings must be a cumuli.RenderSettings, got {type(settings).__name__}")
    if light is None and not settings.physical:
        raise ValueError("light is required unless settings.lighting == 'physical'")
    check_context(context)  # on the CPU backend too
    lit = {} if light is None else {"light": light, "light_sun": sun, "light_sky": sky}
    vc = VolumeCloud(
        density=volume, box=box, sigma_t=sigma_t, albedo=albedo, g=g, step=step, detail=detail,
        reconstruction=reconstruction, **lit,
    )  # fmt: skip
    scene = Scene([vc], sun=sun, sky=sky, settings=settings)
    if backend == "cpu":
        return render_cpu(scene, cam, width, height, threads=threads)
    if context is None:
        return shared_renderer().render(scene, cam, width, height)
    with Renderer(context=context) as renderer:
        return renderer.render(scene, cam, width, height)
