"""Particle clouds as a drawable kind: the drawers the compositor calls (Harris 2002 §2.3, §4).

:class:`ParticleCloudsGL` (GL, the shared sprite pipeline) and :func:`draw_particle_clouds_cpu`
(its C++ twin) draw several particle clouds of a :class:`cumuli.LitScene` **in one pass**, as
SkyWorks does: clouds back to front by the distance from the eye to their bounding-sphere centre
(ties: scene order), each cloud's particles back to front (``scene.sprite_settings.sort``), all
splatted into one premultiplied layer — ``groups = True``, so a scene of only particle clouds is
one draw. Clouds and particles off screen are culled (never changes a pixel). Each cloud is lit
by ``scene.sun`` and ``scene.lights`` with its :class:`~cumuli.light.particles.ParticleLight`
from the light step.

With opaque solids in the scene (``Scene.solids``) every sprite is depth-tested against the
solids' view depth — [H]'s direct rendering, whose hard splat/solid intersections (Fig. 7 left)
impostor splitting removes: :meth:`ParticleCloudsGL.draw_split` / :func:`split_particle_cloud_cpu`
draw one cloud as ``m + 1`` layers cut at the solids' sort keys (no depth test), which
:func:`cumuli.rendering.solids.composite_split` combines with the solids.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli._util.structs import core_struct
from cumuli.camera import Camera
from cumuli.gl import GLContext
from cumuli.gl.sprites import (
    MAX_SPRITES,
    SpriteLayerRenderer,
    Sprites,
    camera_dict,
    draw_sprites_cpu,
)
from cumuli.light import sprite_physical
from cumuli.light.particles import light_directions
from cumuli.light.prepare import LitScene
from cumuli.rendering.params import camera_params
from cumuli.rendering.particles import _check_light as check_light
from cumuli.rendering.particles import particle_sprites
from cumuli.rendering.solids import SolidsGL, draw_solids_cpu, solid_depth
from cumuli.sky import sky_args

#: Sprites splatted by the CPU twin since import (GL drawers count their own).
cpu_sprites_drawn = [0]


def cloud_order(lit: LitScene, indices: Sequence[int], camera: Camera) -> list[int]:
    """``indices`` back to front by the distance from the eye to each cloud's bounding-sphere
    centre (SkyWorks' ``SortInstances``); ties keep the scene order."""
    eye = np.asarray(camera.position, dtype=np.float64)
    dist = [float(np.linalg.norm(lit.scene.clouds[k].sphere[0] - eye)) for k in indices]
    keyed = zip((-d for d in dist), range(len(dist)), indices, strict=True)
    return [k for _, _, k in sorted(keyed)]


def _cloud_sprites(
    lit: LitScene, k: int, camera: Camera, width: int, height: int, keys: bool = False
) -> Any:
    scene = lit.scene
    if scene.settings.physical:
        return _physical_sprites(lit, [k], camera, width, height, keys)
    return particle_sprites(
        scene.clouds[k], lit.lights[k], (scene.sun, *scene.lights), camera, width, height,
        scene.sprite_settings, return_keys=keys,
    )  # fmt: skip


def _sprite_maker(scene: Any, camera: Camera, width: int, height: int) -> Any:
    """``f(cloud, light) -> (index, colour, alpha, key)``: Harris's eye pass of one cloud
    (``_core.particle_sprites``, culled) with the scene's lights, camera and sprite settings
    prepared once for many clouds."""
    s = scene.sprite_settings
    lights = (scene.sun, *scene.lights)
    dirs = light_directions(lights)
    radiance = np.array([x.radiance for x in lights], dtype=np.float32).reshape(-1, 3)
    cam = camera_dict(camera, width, height, s.near)
    settings = core_struct(
        _core.ParticleSpriteSettings, solid_angle=s.solid_angle, phase=s.phase, hg_g=s.hg_g,
        ambient=s.ambient, sort=s.sort, cull=True,
    )  # fmt: skip

    def sprites_of(cloud: Any, light: Any) -> Any:
        check_light(cloud, light, lights)
        return _core.particle_sprites(
            *cloud.core_args(), light.light, dirs, radiance, cam, settings
        )

    return sprites_of


def _physical_sprites(
    lit: LitScene, indices: Sequence[int], camera: Camera, width: int, height: int,
    keys: bool = False,
) -> Any:  # fmt: skip
    """The sprites of the clouds ``indices`` (in that order) with the physical mode's colours
    (:func:`cumuli.light.sprite_physical.particle_colours`): Harris's light as the sun's
    transmittance, the scene's phase, octaves and sky."""
    scene = lit.scene
    sprites_of = _sprite_maker(scene, camera, width, height)
    parts, sort_keys = [], []
    for k in indices:
        cloud, light = scene.clouds[k], lit.lights[k]
        index, _, alpha, key = sprites_of(cloud, light)
        index = np.asarray(index, np.int64)
        colour = sprite_physical.particle_colours(scene, cloud, light, index, camera.position)
        parts.append(Sprites(centres=cloud.centres[index], half_sizes=cloud.radii[index],
                             colours=colour, alpha=alpha))  # fmt: skip
        sort_keys.append(np.asarray(key))
    sprites = _concat(parts)
    return (sprites, np.concatenate(sort_keys) if sort_keys else np.zeros(0)) if keys else sprites


def _concat(parts: Sequence[Sprites]) -> Sprites:
    if len(parts) == 1:
        return parts[0]
    return Sprites(
        centres=np.concatenate([p.centres for p in parts]) if parts else np.zeros((0, 3)),
        half_sizes=np.concatenate([p.half_sizes for p in parts]) if parts else np.zeros((0, 2)),
        colours=np.concatenate([p.colours for p in parts]) if parts else np.zeros((0, 4, 3)),
        alpha=np.concatenate([p.alpha for p in parts]) if parts else np.zeros(0),
    )


def scene_sprites(
    lit: LitScene, indices: Sequence[int], camera: Camera, width: int, height: int
) -> Sprites:
    """The sprites of the clouds ``indices``, clouds and particles back to front (one batch):
    :func:`~cumuli.rendering.particles.particle_sprites` per cloud with the camera, lights and
    settings prepared once (a field has thousands of clouds)."""
    scene = lit.scene
    if scene.settings.physical:
        return _physical_sprites(lit, cloud_order(lit, indices, camera), camera, width, height)
    sprites_of = _sprite_maker(scene, camera, width, height)
    centres, radii, colours, alphas = [], [], [], []
    for k in cloud_order(lit, indices, camera):
        cloud, light = scene.clouds[k], lit.lights[k]
        index, colour, alpha, _ = sprites_of(cloud, light)
        centres.append(cloud.centres[index])
        radii.append(cloud.radii[index])
        colours.append(colour)
        alphas.append(alpha)
    if not centres:
        return _concat([])
    return Sprites(
        centres=np.concatenate(centres), half_sizes=np.concatenate(radii),
        colours=np.concatenate(colours), alpha=np.concatenate(alphas),
    )  # fmt: skip


def split_sprites(
    lit: LitScene, k: int, camera: Camera, width: int, height: int, cuts: Sequence[float]
) -> list[Sprites]:
    """Cloud ``k``'s sprites cut at the sort keys ``cuts`` ([H] §3.1.1): ``m + 1`` batches,
    farthest first — batch j holds the particles whose key lies between the (m − j)-th and the
    (m − j + 1)-th smallest cut (``z_0 = −∞``, ``z_{m+1} = +∞``, lower bound inclusive)."""
    sprites, keys = _cloud_sprites(lit, k, camera, width, height, keys=True)
    z = np.sort(np.asarray(cuts, dtype=np.float64))
    m = len(z)
    bins = m - np.searchsorted(z, np.asarray(keys, dtype=np.float64), side="right")
    out = []
    for j in range(m + 1):
        sel = np.flatnonzero(bins == j)
        out.append(
            Sprites(
                centres=sprites.centres[sel],
                half_sizes=sprites.half_sizes[sel],
                colours=sprites.colours[sel],
                alpha=sprites.alpha[sel],
            )  # fmt: skip
        )
    return out


def sort_key(lit: LitScene, point: Sequence[float], camera: Camera) -> float:
    """The particle sort key of a point (``distance`` |p − eye| or ``depth`` (p − eye)·f)."""
    v = np.subtract(point, camera.position, dtype=np.float64)
    if lit.scene.sprite_settings.sort == "depth":
        return float(v @ camera.basis()[0].astype(np.float64))
    return float(np.linalg.norm(v))


def over_sky(
    layer: np.ndarray, lit: LitScene, indices: Sequence[int], camera: Camera, threads: int = 0
) -> np.ndarray:
    """``rgb = C + (1 − A)·sky``, ``alpha = A`` (the compositor with one layer, boxed by the
    clouds' union)."""
    scene = lit.scene
    if indices:
        boxes = np.array([scene.clouds[k].layer_box() for k in indices], np.float32)
        box = np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])[None]
    else:
        box = np.zeros((1, 2, 3), np.float32)
    return _core.composite_layers(
        layer[None], box, camera_params(camera), sky_args(scene.sky), scene.sun.direction,
        scene.sun.radiance, check.threads(threads),
    )  # fmt: skip


def _draw(
    lit: LitScene,
    indices: Sequence[int],
    camera: Camera,
    width: int,
    height: int,
    with_sky: bool,
    splat: Callable[..., np.ndarray],
    solids: Callable[[], np.ndarray],
    threads: int,
) -> np.ndarray:
    s = lit.scene.sprite_settings
    sprites = scene_sprites(lit, indices, camera, width, height)
    depth = solid_depth(solids()) if lit.scene.solids else None
    layer = splat(sprites, kernel=s.kernel, peak=s.peak, near=s.near, depth=depth)
    return over_sky(layer, lit, indices, camera, threads) if with_sky else layer


class ParticleCloudsGL:
    """The GL drawer of `ParticleCloud` drawables (see :mod:`cumuli.rendering.kinds`): several
    clouds in one sprite pass."""

    groups = True
    #: Draws only what lies in front of the scene's solids (depth test): exact with solids.
    clips_solids = True

    def __init__(self, gl: GLContext, tiles: Any) -> None:
        self.gl = gl
        self.tiles = tiles
        self.sprites = SpriteLayerRenderer(gl, tile=tiles.tile)
        self._solids: SolidsGL | None = None
        #: Sprites splatted by this drawer (all draws).
        self.sprites_drawn = 0

    @staticmethod
    def check(scene: Any, indices: Sequence[int]) -> None:
        """The sprites of one draw: at most ``MAX_SPRITES`` particles together."""
        total = sum(scene.clouds[k].n for k in indices)
        if total > MAX_SPRITES:
            raise ValueError(
                f"the particle clouds drawn together hold {total} particles, more than the "
                f"sprite pipeline's {MAX_SPRITES} per pass"
            )

    def _splat(self, sprites: Sprites, camera: Camera, width: int, height: int, **kw: Any):
        image = self.sprites.draw(sprites, camera, width, height, **kw)
        self.sprites_drawn += len(sprites)
        return image

    def _solid_image(self, lit: LitScene, camera: Camera, width: int, height: int) -> np.ndarray:
        if self._solids is None:
            self._solids = SolidsGL(self.gl, self.tiles)
        return self._solids.draw(lit.scene.solids, lit.scene.sun, camera, width, height)

    def draw(
        self,
        lit: LitScene,
        indices: Sequence[int],
        camera: Camera,
        width: int,
        height: int,
        with_sky: bool,
    ) -> np.ndarray:
        """The clouds ``indices`` over the sky or as a premultiplied layer ``(H, W, 4)``."""
        return _draw(
            lit, indices, camera, width, height, with_sky,
            lambda sp, **kw: self._splat(sp, camera, width, height, **kw),
            lambda: self._solid_image(lit, camera, width, height), 0,
        )  # fmt: skip

    def draw_split(
        self,
        lit: LitScene,
        k: int,
        camera: Camera,
        width: int,
        height: int,
        cuts: Sequence[float],
    ) -> np.ndarray:
        """Cloud ``k`` as ``m + 1`` premultiplied layers ``(m + 1, H, W, 4)``, farthest first,
        cut at the sort keys ``cuts`` (:func:`split_sprites`; no depth test)."""
        s = lit.scene.sprite_settings
        parts = split_sprites(lit, k, camera, width, height, cuts)
        return np.stack(
            [
                self._splat(p, camera, width, height, kernel=s.kernel, peak=s.peak, near=s.near)
                for p in parts
            ]
        )

    def release(self) -> None:
        self.sprites.release()
        if self._solids is not None:
            self._solids.release()


def draw_particle_clouds_cpu(
    lit: LitScene,
    indices: Sequence[int],
    camera: Camera,
    width: int,
    height: int,
    with_sky: bool,
    threads: int = 0,
) -> np.ndarray:
    """The CPU twin of :meth:`ParticleCloudsGL.draw` (C++ sprite rasteriser)."""

    def splat(sprites: Sprites, **kw: Any) -> np.ndarray:
        cpu_sprites_drawn[0] += len(sprites)
        return draw_sprites_cpu(sprites, camera, width, height, threads=threads, **kw)

    def solids() -> np.ndarray:
        scene = lit.scene
        return draw_solids_cpu(scene.solids, scene.sun, camera, width, height, threads)

    return _draw(lit, indices, camera, width, height, with_sky, splat, solids, threads)


def split_particle_cloud_cpu(
    lit: LitScene,
    k: int,
    camera: Camera,
    width: int,
    height: int,
    cuts: Sequence[float],
    threads: int = 0,
) -> np.ndarray:
    """The CPU twin of :meth:`ParticleCloudsGL.draw_split`."""
    s = lit.scene.sprite_settings
    out = []
    for p in split_sprites(lit, k, camera, width, height, cuts):
        cpu_sprites_drawn[0] += len(p)
        out.append(
            draw_sprites_cpu(
                p,
                camera,
                width,
                height,
                kernel=s.kernel,
                peak=s.peak,
                near=s.near,
                threads=threads,
            )  # fmt: skip
        )
    return np.stack(out)
