"""Ready-made scenes: the demo of ``cumuli demo`` (cumuli at sunset in the physical lighting mode,
with their shadows on the ground), the paper's Fig. 10 and a single daylight cumulus."""

from __future__ import annotations

from cumuli.camera import Camera
from cumuli.ground import Ground
from cumuli.model.gaussian import gaussian_cumulus
from cumuli.noise import Noise
from cumuli.scene import Scene
from cumuli.settings import RenderSettings
from cumuli.sky import Sky, Sun


def cumulus_scene(seed: int = 1, settings: RenderSettings | None = None) -> Scene:
    """One Gaussian cumulus (the paper's defaults, 35 spheres) under a daylight sky (Fig. 9).

    The camera stands 60 units away on −z, slightly below the cloud's middle.
    """
    cloud = gaussian_cumulus(centre=(0.0, 0.0, 0.0), seed=seed)
    return Scene(
        clouds=[cloud],
        sun=Sun(direction=(0.45, 0.75, 0.5), colour=(1.0, 0.97, 0.92), intensity=1.0),
        sky=Sky(),
        noise=Noise(seed=7),
        settings=settings or RenderSettings(),
        camera=Camera(position=(0.0, 3.0, -60.0), target=(0.0, 4.0, 0.0), fov=45.0),
    )


def default_scene(settings: RenderSettings | None = None) -> Scene:
    """Three Gaussian cumuli in a sunset sky (paper Fig. 10).

    A low orange sun from the right and slightly behind the camera lights the clouds' sides
    and leaves their far sides and bases in shadow.
    """
    clouds = [
        gaussian_cumulus(centre=(-26.0, 2.0, 30.0), seed=11),
        gaussian_cumulus(centre=(4.0, 6.0, 55.0), seed=12),
        gaussian_cumulus(centre=(30.0, 0.0, 20.0), seed=13),
    ]
    return Scene(
        clouds=clouds,
        sun=Sun(direction=(0.8, 0.3, -0.15), colour=(1.0, 0.72, 0.45), intensity=1.6),
        sky=Sky.sunset(),
        noise=Noise(seed=7),
        settings=settings or RenderSettings(),
        camera=Camera(position=(0.0, 4.0, -40.0), target=(0.0, 8.0, 30.0), fov=55.0),
    )


#: Display settings of the demo (``cumuli demo``): exposure and tone mapping of the 8-bit image.
DEMO_EXPOSURE = 0.7
DEMO_TONEMAP = "aces"


def sunset_scene(settings: RenderSettings | None = None) -> Scene:
    """The demo: the three cumuli of :func:`default_scene` at sunset in the physical lighting
    mode (RENDER_CONTRACT), over a ground they shade.

    A low orange sun (17° up, from the right and slightly behind the camera, irradiance 9)
    lights their sides; the sunset sky lights the rest, so undersides and the far sides stay
    soft and blue-grey rather than black. Display with :data:`DEMO_EXPOSURE` and the ACES tone
    curve (``cu.write_image(path, img, exposure=0.7, tonemap="aces")``).
    """
    base = default_scene()
    return base.replace(
        sun=Sun(direction=(0.8, 0.3, -0.15), colour=(1.0, 0.62, 0.36), intensity=9.0),
        settings=settings or RenderSettings(lighting="physical"),
        camera=Camera(position=(0.0, 4.0, -40.0), target=(0.0, 12.0, 30.0), fov=55.0),
        ground=Ground(height=-20.0, albedo=(0.22, 0.2, 0.17)),
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

    Every scene has the same sun, sky and noise; light grids are 20³ (computed on first render).
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
            return gaussian_cumulus(centre=(0.0, 0.0, 0.0), seed=1), RenderSettings()
        if name == "mesh":
            vertices, faces = bunny_like(subdivisions=2)
            cloud = mesh_cloud((vertices * 6.0, faces), scale=1.2, target_faces=370)
            return cloud, RenderSettings(fixed_step=0.1)
        if name == "metaball":
            return metaball_cumulus(seed=3), RenderSettings()
        cloud = lsystem_cloud(
            "X", {"X": "X+Y", "Y": "X&Y"}, iterations=7, angle=(20.0, 40.0),
            heading=(0, 1, 0), up=(0, 0, -1), seed=2,
        )  # fmt: skip
        return cloud, RenderSettings()

    scenes = {}
    for name in names:
        cloud, settings = make(name)
        scenes[name] = Scene(
            clouds=[cloud],
            sun=Sun(direction=(0.45, 0.75, 0.5), colour=(1.0, 0.97, 0.92)),
            sky=Sky(),
            noise=Noise(seed=7),
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
