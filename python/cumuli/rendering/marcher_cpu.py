"""The CPU twin of the 2018 marcher (RENDER_CONTRACT, DESIGN §4): ``_core.render_cpu``.

The same render pass as the GLSL marcher (Algorithms 1 and 3 of Jiménez de Parga & Gómez Palomo
2018), run by the C++ core on all cores without the GIL. It is slow next to the GPU but exact and
independent of any driver: the parity tests hold the GLSL marcher to it, and it renders where no
OpenGL context can be made. :func:`draw_clouds_cpu` is its layer drawer for the compositor
(``cumuli.rendering.compositor``); ``cumuli.render_cpu`` renders a whole scene with the CPU twins
of every kind.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli.camera import Camera
from cumuli.ground import ground_args
from cumuli.light.physical import PhysicalLight
from cumuli.light.prepare import LitScene, prepare_light
from cumuli.model.cloud import Cloud
from cumuli.model.solid import solid_arrays
from cumuli.rendering.edges import core_pass
from cumuli.rendering.params import (
    MIN_TRANSMITTANCE,  # noqa: F401  (re-exported)
    march_params,
    sky_params,
    sun_params,
    viewport,
)
from cumuli.scene import Scene

#: Largest image edge the CPU marcher accepts.
MAX_EDGE = 1 << 14
#: Largest image in pixels (the core's own limit, checked before any light grid is made).
MAX_PIXELS = 1 << 26
#: Cells per axis of a cloud's occupancy grid (empty-space skipping; the shader's OCC_RES).
OCCUPANCY_RESOLUTION = 16


@dataclass(frozen=True)
class MarchStats:
    """The work of one CPU render of 2018 clouds: counted by the C++ marcher
    per pixel, so the numbers do not depend on the thread count, and counting never changes the
    image.

    Attributes
    ----------
    fbm_evaluations:
        fBm evaluations of the density (eq. 1) over the image.
    steps:
        Samples marched, empty and skipped ones included (what ``max_steps`` bounds).
    skipped:
        Samples passed over by empty-space skipping (no density evaluated).
    fbm_map:
        ``(height, width)`` uint32: the fBm evaluations of each pixel.
    """

    fbm_evaluations: int
    steps: int
    skipped: int
    fbm_map: np.ndarray

    @property
    def pixels(self) -> int:
        """Pixels of the image."""
        return int(self.fbm_map.size)

    @property
    def fbm_per_pixel(self) -> float:
        """Mean fBm evaluations per pixel."""
        return self.fbm_evaluations / self.pixels

    @property
    def steps_per_pixel(self) -> float:
        """Mean samples marched per pixel."""
        return self.steps / self.pixels


def occupancy_grid(
    cloud: Cloud, resolution: int = OCCUPANCY_RESOLUTION
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """A cloud's coarse occupancy grid (RENDER_CONTRACT "Empty-space skipping"), as both
    marchers use it: ``(cells, (lo, hi))`` with ``cells`` a ``[z, y, x]`` bool array of
    ``resolution³`` cells over the box ``(lo, hi)`` (float32, the cloud's `layer_box`),
    ``False`` where no primitive can give density > 0 anywhere in the cell (conservative)."""
    if not isinstance(cloud, Cloud):
        raise TypeError(f"cloud must be a cumuli.Cloud, got {type(cloud).__name__}")
    resolution = check.integer(resolution, "resolution", 1, 256)
    centres, radii, rotations, model = cloud.core_args()[:4]
    cells, lo, hi = _core.occupancy_grid(centres, radii, rotations, model, resolution)
    return cells.astype(bool), (np.asarray(lo, np.float32), np.asarray(hi, np.float32))


def physical_core_tuple(light: PhysicalLight) -> tuple:
    """A drawable's physical light as the core takes it (the core adds ``upstream``'s value
    per column to the sun lattice's, as :meth:`PhysicalLight.sample_depth` does)."""
    lo, hi = light.box
    return (light.frame, light.sun_depth, lo, hi, light.grid, light.upstream)


def cloud_core_dict(cloud: Cloud, grid: Any, kappa: float | None = None) -> dict[str, Any]:
    """The dict ``_core.render_cpu`` takes for one cloud and its light (a `LightGrid`, or a
    `PhysicalLight` in the physical mode).

    ``kappa`` overrides the cloud's own κ when given (``RenderSettings.kappa``).
    """
    centres, radii, rotations, model, cloud_kappa, phi, noise_offset = cloud.core_args()
    shape = {
        "centres": centres,
        "radii": radii,
        "rotations": rotations,
        "model": model,
        "kappa": float(cloud_kappa if kappa is None else kappa),
        "phi": float(phi),
        "noise_offset": noise_offset,
    }
    if isinstance(grid, PhysicalLight):
        return shape | {"physical": physical_core_tuple(grid)}
    lo, hi = grid.box
    return shape | {
        "light": np.ascontiguousarray(grid, dtype=np.float32),
        "light_lo": check.vec3(lo, "light box lo"),
        "light_hi": check.vec3(hi, "light box hi"),
    }


def render_cpu_args(
    scene: Scene | LitScene,
    camera: Camera,
    width: int,
    height: int,
    threads: int = 0,
    indices: Sequence[int] | None = None,
    with_sky: bool = True,
) -> dict[str, Any]:
    """Keyword arguments of ``_core.render_cpu`` for the 2018 clouds ``indices`` (all by default)
    of a scene (its light prepared first when it is not a `LitScene`).

    Exposed for tests and tools that want to change one knob of the core call (for example
    ``args["settings"].density_constant``, a constant density in place of fBm for analytic
    checks).
    """
    lit = scene if isinstance(scene, LitScene) else prepare_light(scene, threads=threads)
    scene = lit.scene
    width = check.integer(width, "width", 1, MAX_EDGE)
    height = check.integer(height, "height", 1, MAX_EDGE)
    threads = check.threads(threads)
    if indices is None:
        indices = range(len(scene.clouds))
    s = scene.settings
    return {
        "view": viewport(camera, width, height),
        "clouds": [cloud_core_dict(scene.clouds[k], lit.lights[k], s.kappa) for k in indices],
        "sun": sun_params(scene.sun),
        "sky": sky_params(scene.sky),
        "settings": march_params(s, _octaves(lit, indices) if s.physical else 1),
        "noise": scene.noise._core,
        "threads": threads,
        "with_sky": bool(with_sky),
        "solids": solid_arrays(scene.solids)[0] if scene.solids else None,
        "ground": ground_args(scene.ground, scene.sky, lit.shadow),
    }


def _octaves(lit: LitScene, indices: Sequence[int]) -> int:
    """Scattering orders drawn (every physical light of a pass draws the same)."""
    return max((lit.lights[k].octaves for k in indices), default=1)


def check_stats_scene(scene: Scene, impostors: Any) -> None:
    """``return_stats`` counts the 2018 marcher's single pass: only such scenes qualify."""
    if not scene.clouds or not all(isinstance(c, Cloud) for c in scene.clouds):
        raise ValueError("return_stats=True needs a scene of 2018 clouds (cumuli.Cloud) only")
    if scene.solids or impostors is not None:
        raise ValueError(
            "return_stats=True counts the marcher's single pass: no solids or impostors"
        )


def combined_stats(passes: Sequence[dict[str, Any]], width: int, height: int) -> MarchStats:
    """One `MarchStats` of an image from its marches' raw statistics (``_core.render_cpu``'s):
    the image's own, whose ``fbm_map`` is the image's, and the edge pass's, a list of sub-pixels
    (``raw["pixels"]``, ``(N, 2)`` rows and columns of an image ``raw["size"]`` = k times the
    image's height) whose counts add to the pixel each lies in."""
    fbm_map = np.zeros((height, width), np.uint32)
    for raw in passes:
        m = np.asarray(raw["fbm_map"], np.uint32)
        if "pixels" not in raw:
            fbm_map += m
            continue
        k = int(raw["size"][0]) // height
        pixels = np.asarray(raw["pixels"])
        np.add.at(fbm_map, (pixels[:, 0] // k, pixels[:, 1] // k), m)
    return MarchStats(
        sum(int(raw["fbm_evaluations"]) for raw in passes),
        sum(int(raw["steps"]) for raw in passes),
        sum(int(raw["skipped"]) for raw in passes),
        fbm_map,
    )


def draw_clouds_cpu(
    lit: LitScene,
    indices: Sequence[int],
    camera: Camera,
    width: int,
    height: int,
    with_sky: bool,
    threads: int = 0,
    pixels: np.ndarray | None = None,
    return_stats: bool = False,
    edges: bool = False,
) -> Any:
    """The CPU twin of :meth:`cumuli.rendering.marcher.MarcherGL.draw`; with ``pixels`` (an
    ``(N, 2)`` integer array of rows and columns) only those pixels, as ``(N, 4)`` values; with
    ``return_stats``, ``(image, raw)``: ``_core.render_cpu``'s statistics of the march. With
    ``edges`` the whole image gets the physical mode's edge pass in the same call
    (:func:`cumuli.rendering.edges.core_pass`) and the result is ``(image, mask or None)``
    (``(image, mask, raw)`` with ``return_stats``, the outline's work counted in its pixels)."""
    args = render_cpu_args(lit, camera, width, height, threads, indices, with_sky)
    if not edges:
        return _core.render_cpu(**args, pixels=pixels, return_stats=return_stats)
    if pixels is not None:
        raise ValueError("the edge pass draws the whole image: pass pixels or edges, not both")
    return _core.render_cpu_edged(**edged_args(args), return_stats=return_stats, edges=core_pass())


def edged_args(args: dict[str, Any]) -> dict[str, Any]:
    """:func:`render_cpu_args` as ``_core.render_cpu_edged`` takes them: the edge pass draws the
    whole image over the sky, with no solids."""
    if args["solids"] is not None or not args["with_sky"]:
        raise ValueError("the edge pass draws 2018 clouds over the sky, without solids")
    return {k: v for k, v in args.items() if k not in ("solids", "with_sky")}
