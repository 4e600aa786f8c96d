"""Ready-made scenes: the demo of ``cumuli demo`` (paper Fig. 10) and a single daylight cumulus."""

from __future__ import annotations

from cumuli.noise import Noise
from cumuli.scene import Camera, RenderSettings, Scene, Sky
from cumuli.shapes import gaussian_cumulus
from cumuli.sun import Sun


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
