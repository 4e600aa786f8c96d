"""Ready-made scenes: the demo of ``cumuli demo`` (cumuli at sunset in the physical lighting mode,
with their shadows on the ground), the paper's Fig. 10, a single daylight cumulus, Harris 2002's
Fig. 13 (``cumuli demo --harris``: particle clouds at sunset under two coloured lights) and the
climatic-variation sequence of ``cumuli demo --torchelsen`` (Torchelsen & Musse 2005, Fig. 14)
and a stratocumulus deck over a plain (``cumuli demo --deck``)."""

from __future__ import annotations

import math

import numpy as np

from cumuli.camera import Camera
from cumuli.ground import Ground
from cumuli.io.images import DISPLAY_EXPOSURE, DISPLAY_TONEMAP
from cumuli.model.deck import CloudDeck
from cumuli.model.gaussian import gaussian_cumulus
from cumuli.noise import DEFAULT_VERSION, PAPER_VERSION, Noise
from cumuli.scene import Scene
from cumuli.settings import RenderSettings
from cumuli.sky import Sky, Sun

#: Seed of the noise that fills the ready-made scenes' 2018 clouds.
_NOISE_SEED = 7


def _figure_noise(settings: RenderSettings) -> Noise:
    """The noise of a scene that reproduces one of the paper's figures: seed ``_NOISE_SEED``,
    the paper's noise (version 1, :data:`cumuli.noise.PAPER_VERSION`) in the paper lighting mode,
    so its figures and reference images stay bit for bit, and the default version in the
    physical mode."""
    paper = settings.lighting == "paper"
    return Noise(seed=_NOISE_SEED, version=PAPER_VERSION if paper else DEFAULT_VERSION)


#: The sun's irradiance of the demo's daylight scenes in the physical mode: about ten times the
#: sky's radiance, as outdoors (the paper mode's light grid takes 1).
PHYSICAL_SUN_INTENSITY = 6.0


def cumulus_scene(seed: int = 1, settings: RenderSettings | None = None) -> Scene:
    """One Gaussian cumulus (the paper's defaults, 35 spheres) under a daylight sky (Fig. 9).

    The camera stands 60 units away on −z, slightly below the cloud's middle. The sun's
    intensity is :data:`PHYSICAL_SUN_INTENSITY` in the physical mode (the default), 1 in the
    paper mode. The noise has seed 7: the paper's (version 1) in the paper mode, the default
    version in the physical mode.
    """
    settings = settings or RenderSettings()
    intensity = 1.0 if settings.lighting == "paper" else PHYSICAL_SUN_INTENSITY
    cloud = gaussian_cumulus(centre=(0.0, 0.0, 0.0), seed=seed)
    return Scene(
        clouds=[cloud],
        sun=Sun(direction=(0.45, 0.75, 0.5), colour=(1.0, 0.97, 0.92), intensity=intensity),
        sky=Sky(),
        noise=_figure_noise(settings),
        settings=settings,
        camera=Camera(position=(0.0, 3.0, -60.0), target=(0.0, 4.0, 0.0), fov=45.0),
    )


def default_scene(settings: RenderSettings | None = None) -> Scene:
    """Three Gaussian cumuli in a sunset sky (paper Fig. 10).

    A low orange sun from the right and slightly behind the camera lights the clouds' sides
    and leaves their far sides and bases in shadow. The noise has seed 7: the paper's (version 1)
    in the paper mode, the default version in the physical mode.
    """
    settings = settings or RenderSettings()
    clouds = [
        gaussian_cumulus(centre=(-26.0, 2.0, 30.0), seed=11),
        gaussian_cumulus(centre=(4.0, 6.0, 55.0), seed=12),
        gaussian_cumulus(centre=(30.0, 0.0, 20.0), seed=13),
    ]
    return Scene(
        clouds=clouds,
        sun=Sun(direction=(0.8, 0.3, -0.15), colour=(1.0, 0.72, 0.45), intensity=1.6),
        sky=Sky.sunset(),
        noise=_figure_noise(settings),
        settings=settings,
        camera=Camera(position=(0.0, 4.0, -40.0), target=(0.0, 8.0, 30.0), fov=55.0),
    )


def harris_scene(n_particles: int = 2500, clouds: int = 4, seed: int = 3) -> Scene:
    """Harris 2002 Fig. 13: particle cumuli at sunset lit by two lights, an orange sun low on the
    right and a pink light from the left ([H] §2.3.1: "one orange and one pink"), with the
    default [H] shading (τ = 8, albedo 0.9, Rayleigh phase, multiple forward scattering, γ = 1)
    and a little ambient. The clouds are `particle_cumulus` shapes filled with ``n_particles``
    each; the camera looks across them towards the low sun."""
    from cumuli.light.sprite_settings import SpriteSettings
    from cumuli.model.particles import particle_cumulus

    spots = [(-38.0, 16.0, 60.0), (10.0, 24.0, 95.0), (42.0, 14.0, 55.0), (-4.0, 12.0, 30.0)]
    field = [
        particle_cumulus(spots[k % len(spots)], n_particles, seed=seed + k, radius=(1.2, 2.6))
        for k in range(clouds)
    ]
    return Scene(
        clouds=field,
        sun=Sun(direction=(0.45, 0.1, 0.89), colour=(1.0, 0.55, 0.25), intensity=1.8),
        lights=(Sun(direction=(-0.75, 0.45, -0.2), colour=(1.0, 0.42, 0.62), intensity=1.0),),
        sky=Sky.sunset(),
        sprite_settings=SpriteSettings(ambient=(0.05, 0.04, 0.07)),
        settings=RenderSettings(lighting="paper"),
        camera=Camera(position=(0.0, 0.0, -40.0), target=(2.0, 14.0, 40.0), fov=60.0),
    )


#: Display settings of the demo (``cumuli demo``): the display defaults of the 8-bit image.
DEMO_EXPOSURE = DISPLAY_EXPOSURE
DEMO_TONEMAP = DISPLAY_TONEMAP


def sunset_scene(settings: RenderSettings | None = None) -> Scene:
    """The demo: the three cumuli of :func:`default_scene` at sunset in the physical lighting
    mode (RENDER_CONTRACT), over a ground they shade.

    A low orange sun (17° up, from the right and slightly behind the camera, irradiance 9)
    lights their sides; the sunset sky lights the rest, so undersides and the far sides stay
    soft and blue-grey rather than black. Display with :data:`DEMO_EXPOSURE` and the ACES tone
    curve (``cu.write_image(path, img)``: exposure 0.8, ACES, the defaults).
    """
    base = default_scene()
    return base.replace(
        sun=Sun(direction=(0.8, 0.3, -0.15), colour=(1.0, 0.62, 0.36), intensity=9.0),
        settings=settings or RenderSettings(lighting="physical"),
        camera=Camera(position=(0.0, 4.0, -40.0), target=(0.0, 12.0, 30.0), fov=55.0),
        ground=Ground(height=-20.0, albedo=(0.22, 0.2, 0.17)),
    )


def deck_scene(settings: RenderSettings | None = None, seed: int = 4) -> Scene:
    """A stratocumulus deck (:class:`cumuli.CloudDeck`) 1.2–1.9 km up over a plain, seen from
    60 m above the ground in the physical lighting mode: rounded cells with blue gaps, lit from
    above by a mid-morning sun, their shadows patching the ground. Display like the demo
    (:data:`DEMO_EXPOSURE`, ACES)."""
    deck = CloudDeck(
        base=1200.0, top=1900.0, extent=(-12000.0, -4000.0, 12000.0, 20000.0), coverage=0.5,
        cloud_type="stratocumulus", seed=seed,
    )  # fmt: skip
    return Scene(
        clouds=[deck],
        sun=Sun(direction=(0.35, 0.6, 0.7), colour=(1.0, 0.93, 0.85), intensity=9.0),
        sky=Sky(),
        # Metres: air of about 40 km visibility in a boundary layer 1 km deep.
        settings=settings or RenderSettings(air_extinction=1e-4, air_height=1000.0),
        camera=Camera(position=(0.0, 60.0, -3000.0), target=(0.0, 1100.0, 6000.0), fov=65.0),
        ground=Ground(height=0.0, albedo=(0.2, 0.22, 0.15)),
    )


#: Names of :func:`benchmark_scenes`, in the paper's order of presentation.
BENCHMARK_SCENES = ("cumulus", "mesh", "metaball", "lsystem")


def benchmark_scenes(names: tuple[str, ...] = BENCHMARK_SCENES) -> dict[str, Scene]:
    """The four test clouds of the paper's benchmarks (§4.2, Fig. 16, Table 3), a scene each.

    - ``cumulus``: the Gaussian cumulus of 35 drawn spheres with the hollow and containment
      filters (29 kept for seed 1), LOD step (Algorithm 1, line 50);
    - ``mesh``: the rabbit-like procedural mesh decimated to 370 faces (the paper's rabbit has
      370), one ellipsoid per face, fixed step 0.1 as in the paper's mesh tests;
    - ``metaball``: the six-sphere metaball cumulus (Fig. 13);
    - ``lsystem``: the paper's grammar after 7 iterations, 128 spheres (Fig. 12).

    Every scene has the same sun, sky and noise (the paper's, version 1); light grids are 20³
    (computed on first render).
    Decimating the mesh needs the ``fast-simplification`` package (``pip install cumuli[mesh]``).
    """
    from cumuli.io.meshes import bunny_like
    from cumuli.model.gaussian import metaball_cumulus
    from cumuli.model.lsystem import lsystem_cloud
    from cumuli.model.mesh import mesh_cloud

    unknown = [n for n in names if n not in BENCHMARK_SCENES]
    if unknown:
        raise ValueError(f"unknown benchmark scene(s) {unknown}; choose from {BENCHMARK_SCENES}")

    def make(name: str) -> tuple[object, RenderSettings]:
        if name == "cumulus":
            return gaussian_cumulus(centre=(0.0, 0.0, 0.0), seed=1), RenderSettings(
                lighting="paper"
            )
        if name == "mesh":
            vertices, faces = bunny_like(subdivisions=2)
            cloud = mesh_cloud((vertices * 6.0, faces), scale=1.2, target_faces=370)
            return cloud, RenderSettings(fixed_step=0.1, lighting="paper")
        if name == "metaball":
            return metaball_cumulus(seed=3), RenderSettings(lighting="paper")
        cloud = lsystem_cloud(
            "X", {"X": "X+Y", "Y": "X&Y"}, iterations=7, angle=(20.0, 40.0),
            heading=(0, 1, 0), up=(0, 0, -1), seed=2,
        )  # fmt: skip
        return cloud, RenderSettings(lighting="paper")

    scenes = {}
    for name in names:
        cloud, settings = make(name)
        scenes[name] = Scene(
            clouds=[cloud],
            sun=Sun(direction=(0.45, 0.75, 0.5), colour=(1.0, 0.97, 0.92)),
            sky=Sky(),
            noise=Noise(seed=_NOISE_SEED, version=PAPER_VERSION),
            settings=settings,
        )
    return scenes


def distance_camera(scene: Scene, distance: float, fov: float = 45.0) -> Camera:
    """A camera ``distance`` from the centre of the scene's clouds, on −z, looking along +z.

    Distance 0 puts the camera at the centre (inside the cloud), as the paper's Fig. 16 curves
    start.
    """
    lo, hi = scene.bounds()
    centre = (lo + hi) / 2
    position = (float(centre[0]), float(centre[1]), float(centre[2]) - float(distance))
    target = (position[0], position[1], position[2] + 1.0)
    return Camera(position=position, target=target, fov=fov)


#: The ground camera of :func:`torchelsen_sequence`: in the Table 1 sky square, looking up 25°.
TORCHELSEN_CAMERA = Camera(position=(0.0, 2.0, -420.0), target=(0.0, 198.0, 0.0), fov=65.0)


def torchelsen_sequence(
    width: int = 640, height: int = 480, backend: str = "gl", seed: int = 0, panels: int = 4
) -> np.ndarray:
    """[TM] Fig. 14: the Table 1 weather (two layers, CV 0 → 1 over 600 s) seen from the ground
    at CV = 0, 1/3, 2/3, 1 (``panels`` frames evenly over the schedule), as a 2-column grid of
    ``width/2 × height/2`` frames (one row when ``panels`` is 2). Returns ``(H, W, 4)`` linear
    RGBA, opaque."""
    from cumuli._util import validate as check
    from cumuli.anim.weather_presets import table1
    from cumuli.rendering.compositor import render

    panels = check.integer(panels, "panels", 2, 16)
    w, h = check.integer(width, "width", 2, 8192) // 2, check.integer(height, "height", 2, 8192)
    rows = math.ceil(panels / 2)
    h //= rows
    weather = table1(seed=seed)
    end = weather.schedule.keys[-1][0]
    # Clouds 0.4–3 thousand units away: air six times thinner per unit than the default, so the
    # far ones fade towards the horizon without vanishing.
    base = Scene(
        sun=Sun(direction=(0.3, 0.6, 0.6), colour=(1.0, 0.97, 0.92), intensity=1.4),
        settings=RenderSettings(air_extinction=0.0005),
    )
    out = np.ones((rows * h, 2 * w, 4), np.float32)
    for k in range(panels):
        t = end * k / (panels - 1)
        while weather.t < t - 1e-9:
            weather.step(min(1.0, t - weather.t))
        img = render(weather.scene_at(base), TORCHELSEN_CAMERA, w, h, backend=backend)
        r, c = divmod(k, 2)
        out[r * h : (r + 1) * h, c * w : (c + 1) * w, :3] = img[..., :3]
    return out
