"""What the compositor asks of a backend: layers, solid images, splits and impostor displays.

:class:`GLPainter` draws with a :class:`cumuli.Renderer`'s GL drawers, :class:`CPUPainter` with
their C++ twins; :func:`cumuli.rendering.compositor.compose` and the
:class:`~cumuli.rendering.impostor_cache.ImpostorCache` only talk to this interface, so every
feature (solids, splitting, impostors) works the same on both backends and any kind registered in
:mod:`cumuli.rendering.kinds` takes part.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from cumuli import _core, registry
from cumuli._util import validate as check
from cumuli.camera import Camera
from cumuli.light.prepare import LitScene
from cumuli.rendering import particle_layers
from cumuli.rendering.edges import SUB, supersample_edges
from cumuli.rendering.impostor_gl import ImpostorDisplayGL, quad_planes
from cumuli.rendering.marcher_cpu import draw_clouds_cpu
from cumuli.rendering.solids import SolidsGL, draw_solids_cpu


def _kind(name: str) -> registry.Kind:
    found = registry.get(name)
    if found is None:
        raise TypeError(f"no kind of drawable is registered as {name!r}")
    return found


class CPUPainter:
    """The C++ twins, on ``threads`` threads (0: all cores)."""

    backend = "cpu"

    def __init__(self, threads: int = 0) -> None:
        self.threads = check.threads(threads)

    def layer(
        self, lit: LitScene, kind: str, indices: Sequence[int], camera: Camera, width: int,
        height: int, with_sky: bool,
    ) -> np.ndarray:  # fmt: skip
        return _kind(kind).cpu_drawer(lit, indices, camera, width, height, with_sky, self.threads)

    def marched(
        self, lit: LitScene, indices: Sequence[int], camera: Camera, width: int, height: int,
        pixels: np.ndarray,
    ) -> np.ndarray:  # fmt: skip
        """The 2018 clouds ``indices`` over the sky at the ``(N, 2)`` pixels (rows, columns) of
        a ``(height, width)`` image, as ``(N, 4)`` values in their order (the edge pass,
        :mod:`cumuli.rendering.edges`)."""
        return draw_clouds_cpu(lit, indices, camera, width, height, True, self.threads, pixels)

    def edged(
        self, lit: LitScene, indices: Sequence[int], camera: Camera, width: int, height: int
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """The 2018 clouds ``indices`` over the sky with the physical mode's edge pass, and its
        outline (or None): :func:`cumuli.rendering.edges.supersample_edges` of :meth:`layer`
        and :meth:`marched`, here in one core call."""
        return draw_clouds_cpu(lit, indices, camera, width, height, True, self.threads, edges=True)

    def solids(self, lit: LitScene, camera: Camera, width: int, height: int) -> np.ndarray:
        scene = lit.scene
        return draw_solids_cpu(scene.solids, scene.sun, camera, width, height, self.threads)

    def can_split(self, kind: str) -> bool:
        return _kind(kind).cpu_split is not None

    def clips_solids(self, kind: str) -> bool:
        return _kind(kind).clips_solids

    def split(
        self, lit: LitScene, k: int, camera: Camera, width: int, height: int, cuts: Sequence[float]
    ) -> np.ndarray:
        kind = lit.scene.clouds[k].kind
        return _kind(kind).cpu_split(lit, k, camera, width, height, cuts, self.threads)

    def display(
        self, quads: Sequence[Any], camera: Camera, width: int, height: int, exact: bool = True
    ) -> np.ndarray:
        """Impostor quads back to front into a premultiplied layer (always exact on the CPU)."""
        planes, clamp = quad_planes(quads)
        return _core.display_impostors(
            [q.image for q in quads], planes, clamp, camera.position, camera.target, camera.up,
            float(camera.fov), width, height, self.threads,
        )  # fmt: skip

    def splats(self) -> int:
        """Sprites splatted so far (a running count)."""
        return particle_layers.cpu_sprites_drawn[0]

    def forget(self, quad: Any) -> None:
        """An impostor was dropped (nothing to release on the CPU)."""


class CountingCPUPainter(CPUPainter):
    """A :class:`CPUPainter` that counts the 2018 marcher's work (``render_cpu(return_stats=
    True)``): ``passes`` receives each march's raw statistics, the image's and the edge pass's
    (its ``fbm_map`` one count per listed pixel, with ``pixels`` and the image's ``size``)."""

    def __init__(self, threads: int = 0) -> None:
        super().__init__(threads)
        self.passes: list[dict[str, Any]] = []

    def layer(
        self, lit: LitScene, kind: str, indices: Sequence[int], camera: Camera, width: int,
        height: int, with_sky: bool,
    ) -> np.ndarray:  # fmt: skip
        if kind != "cloud":
            raise ValueError("return_stats=True counts the 2018 marcher's passes only")
        return self._count(lit, indices, camera, width, height, with_sky, None)

    def marched(
        self, lit: LitScene, indices: Sequence[int], camera: Camera, width: int, height: int,
        pixels: np.ndarray,
    ) -> np.ndarray:  # fmt: skip
        return self._count(lit, indices, camera, width, height, True, pixels)

    def edged(
        self, lit: LitScene, indices: Sequence[int], camera: Camera, width: int, height: int
    ) -> tuple[np.ndarray, np.ndarray | None]:
        image, mask, raw = draw_clouds_cpu(
            lit, indices, camera, width, height, True, self.threads, return_stats=True,
            edges=True,
        )  # fmt: skip
        self.passes.append(raw)  # the outline's work is counted in its pixels
        return image, mask

    def _count(
        self, lit: LitScene, indices: Sequence[int], camera: Camera, width: int, height: int,
        with_sky: bool, pixels: np.ndarray | None,
    ) -> np.ndarray:  # fmt: skip
        image, raw = draw_clouds_cpu(
            lit, indices, camera, width, height, with_sky, self.threads, pixels, return_stats=True
        )
        if pixels is not None:
            raw.update(pixels=pixels, size=(height, width))
        self.passes.append(raw)
        return image


class GLPainter:
    """The GL drawers of a :class:`cumuli.Renderer` (and its impostor display)."""

    backend = "gl"

    def __init__(self, renderer: Any) -> None:
        self.renderer = renderer

    def layer(
        self, lit: LitScene, kind: str, indices: Sequence[int], camera: Camera, width: int,
        height: int, with_sky: bool,
    ) -> np.ndarray:  # fmt: skip
        return self.renderer.drawer(kind).draw(lit, indices, camera, width, height, with_sky)

    def marched(
        self, lit: LitScene, indices: Sequence[int], camera: Camera, width: int, height: int,
        pixels: np.ndarray,
    ) -> np.ndarray:  # fmt: skip
        """As :meth:`CPUPainter.marched`, on the GL marcher."""
        drawer = self.renderer.drawer("cloud")
        tiles = self.renderer.tiles
        first = tiles.last_gpu_ns  # the main pass's time: the render's is both passes'
        image = drawer.draw(lit, indices, camera, width, height, True, pixels=pixels)
        if first is None or tiles.last_gpu_ns is None:
            tiles.last_gpu_ns = None
        else:
            tiles.last_gpu_ns += first
        return image

    def edged(
        self, lit: LitScene, indices: Sequence[int], camera: Camera, width: int, height: int
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """As :meth:`CPUPainter.edged`: the layer, then its outline's list draw."""
        image = self.layer(lit, "cloud", indices, camera, width, height, True)
        return supersample_edges(
            image,
            lambda m: self.marched(lit, indices, camera, SUB * width, SUB * height, m),
            writable=image.dtype == np.float32 and image.flags.writeable,
        )

    def solids(self, lit: LitScene, camera: Camera, width: int, height: int) -> np.ndarray:
        drawer = self.renderer.extra("solids", lambda gl, tiles: SolidsGL(gl, tiles))
        return drawer.draw(lit.scene.solids, lit.scene.sun, camera, width, height)

    def can_split(self, kind: str) -> bool:
        return hasattr(_kind(kind).gl_drawer, "draw_split")

    def clips_solids(self, kind: str) -> bool:
        return _kind(kind).clips_solids

    def split(
        self, lit: LitScene, k: int, camera: Camera, width: int, height: int, cuts: Sequence[float]
    ) -> np.ndarray:
        drawer = self.renderer.drawer(lit.scene.clouds[k].kind)
        return drawer.draw_split(lit, k, camera, width, height, cuts)

    def display(
        self, quads: Sequence[Any], camera: Camera, width: int, height: int, exact: bool = False
    ) -> np.ndarray:
        display = self.renderer.extra("impostors", ImpostorDisplayGL)
        return display.draw(quads, camera, width, height, exact)

    def splats(self) -> int:
        drawers = self.renderer._drawers.values()
        return sum(int(getattr(d, "sprites_drawn", 0)) for d in drawers)

    def forget(self, quad: Any) -> None:
        """Return a dropped impostor's texture to the pool."""
        display = self.renderer._extras.get("impostors")
        if display is not None:
            display.forget(quad)
