"""Image sequences: camera paths (:func:`fly_towards`, :func:`orbit`) and :func:`render_frames`."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cumuli import registry
from cumuli._util import validate as check
from cumuli.anim.weather import Weather
from cumuli.camera import Camera
from cumuli.scene import Scene

#: Most frames one call renders (keeps a typo from filling a disk).
MAX_FRAMES = 100_000


def _count(frames: int) -> int:
    return check.integer(frames, "frames", 1, MAX_FRAMES)


def fly_towards(
    start: Sequence[float],
    target: Sequence[float],
    frames: int,
    stop: float = 0.0,
    fov: float = 50.0,
    up: Sequence[float] = (0.0, 1.0, 0.0),
) -> list[Camera]:
    """Cameras moving in a straight line from ``start`` towards ``target``, always looking at it.

    The last camera stands ``stop`` units short of ``target`` (0 stops on it, looking the same
    way; a negative ``stop`` flies past — into the cloud and through). Positions are evenly
    spaced.
    """
    n = _count(frames)
    a = np.asarray(check.vec3(start, "start"), dtype=np.float64)
    b = np.asarray(check.vec3(target, "target"), dtype=np.float64)
    stop = check.real(stop, "stop")
    up = check.direction(up, "up")
    dist = float(np.linalg.norm(b - a))
    if dist < 1e-9:
        raise ValueError("start and target must differ")
    view = (b - a) / dist
    travel = dist - stop
    cams = []
    for k in range(n):
        s = travel * (k / (n - 1) if n > 1 else 0.0)
        pos = a + s * view
        cams.append(Camera(position=tuple(pos), target=tuple(pos + view), up=tuple(up), fov=fov))
    return cams


def orbit(
    centre: Sequence[float],
    radius: float,
    frames: int,
    height: float = 0.0,
    start_angle: float = -90.0,
    degrees: float = 360.0,
    fov: float = 50.0,
) -> list[Camera]:
    """Cameras on a horizontal circle around ``centre`` looking at it.

    Angles in degrees about +y, 0 on +x; the default start (−90°) is on −z. ``height`` lifts the
    circle above ``centre``. A full turn does not repeat its first frame.
    """
    n = _count(frames)
    c = np.asarray(check.vec3(centre, "centre"), dtype=np.float64)
    radius = check.real(radius, "radius", 0.0, lo_open=True)
    height = check.real(height, "height")
    start_angle = check.real(start_angle, "start_angle")
    degrees = check.real(degrees, "degrees")
    full = math.isclose(abs(degrees) % 360.0, 0.0) and degrees != 0
    span = degrees / n if full else (degrees / (n - 1) if n > 1 else 0.0)
    cams = []
    for k in range(n):
        a = math.radians(start_angle + k * span)
        pos = c + np.array([radius * math.cos(a), height, radius * math.sin(a)])
        cams.append(Camera(position=tuple(pos), target=tuple(c), fov=fov))
    return cams


def scene_after(scene: Scene, seconds: float) -> Scene:
    """``scene`` ``seconds`` later: every drawable whose kind changes by itself (its registered
    ``advance``: a `CloudDeck`'s wind moves its weather map) moved on; the others as they are."""
    seconds = check.real(seconds, "seconds", -1e9, 1e9)
    if seconds == 0.0:
        return scene
    clouds = []
    for d in scene.clouds:
        advance = registry.of(d).advance
        clouds.append(d if advance is None else advance(d, seconds))
    return scene.replace(clouds=tuple(clouds))


def render_frames(
    scene: Scene | Weather,
    cameras: Sequence[Camera] | Camera,
    out_dir: str | os.PathLike[str],
    width: int = 320,
    height: int = 240,
    backend: str = "gl",
    pattern: str = "frame_{:04d}.png",
    progress: bool = True,
    alpha: str = "opaque",
    client: Any = None,
    impostors: Any = False,
    *,
    dt: float | None = None,
    frames: int | None = None,
    base: Scene | None = None,
) -> list[Path]:
    """Render ``scene`` from each camera and write numbered images into ``out_dir``.

    ``scene`` may be a `cumuli.Weather` (a scene sequence, Torchelsen & Musse 2005): frame 0
    renders ``weather.scene_at(base)`` as the weather is, and before each later frame the
    weather steps ``dt`` seconds (required), so n frames leave it ``(n − 1)·dt`` later.
    ``cameras`` is then a list (one per frame) or one camera with ``frames`` the number of
    frames. Weathers are filmed locally (no client). For a `Scene`, ``dt`` (optional) moves the
    drawables that change by themselves (a `CloudDeck`'s wind, :func:`scene_after`): frame ``k``
    shows the scene ``k·dt`` seconds later.

    ``pattern`` is a ``str.format`` pattern taking the frame number; its extension picks the
    format (``.png`` sRGB8 or ``.exr`` float32). ``out_dir`` is created if missing. A tqdm bar
    shows progress unless ``progress=False``. ``alpha`` is :func:`cumuli.write_image`'s: frames
    are opaque (``"opaque"``: the render is already composited over the sky) unless
    ``alpha="keep"`` keeps the clouds' coverage ``1 − T`` (``True`` / ``False`` also mean keep /
    opaque). Returns the paths written, in order. With a ``dask.distributed`` ``client`` every
    frame is a task on the cluster (see :mod:`cumuli.anim.cluster`; ``out_dir`` must be a folder
    the workers see); the images are the same. ``impostors=True`` draws the sequence through one
    :class:`cumuli.ImpostorCache` (Harris 2002 §3: each cloud's image is reused while the view
    moves less than ``scene.impostor_settings.tolerance``), or pass a cache to keep it (and its
    ``stats``) after the call; not with ``client`` (frames there are independent tasks).
    """
    from cumuli.io.images import ALPHA_MODES, FORMATS, display_for, write_image
    from cumuli.rendering.compositor import render
    from cumuli.rendering.impostor_cache import ImpostorCache

    weather = scene if isinstance(scene, Weather) else None
    if weather is not None:
        if dt is None:
            raise ValueError("dt (seconds between frames) is required to film a Weather")
        dt = check.real(dt, "dt", 0.0, 1e9)
        if client is not None:
            raise ValueError("a Weather is filmed locally: client must be None")
        if base is not None and not isinstance(base, Scene):
            raise TypeError(f"base must be a cumuli.Scene, got {type(base).__name__}")
        if isinstance(cameras, Camera):
            if frames is None:
                raise ValueError("frames is required with a single camera")
            cameras = [cameras] * _count(frames)
    elif not isinstance(scene, Scene):
        raise TypeError(f"scene must be a cumuli.Scene or a Weather, got {type(scene).__name__}")
    elif frames is not None or base is not None:
        raise ValueError("frames and base apply to a Weather only")
    elif dt is not None:
        dt = check.real(dt, "dt", 0.0, 1e9)
    if isinstance(cameras, Camera):
        raise TypeError("cameras must be a sequence of cumuli.Camera; wrap one camera in a list")
    try:
        cams = list(cameras)
    except TypeError:
        raise TypeError(
            f"cameras must be a sequence of cumuli.Camera, got {type(cameras).__name__}"
        ) from None
    if not cams:
        raise ValueError("cameras must not be empty")
    if len(cams) > MAX_FRAMES:
        raise ValueError(f"at most {MAX_FRAMES} frames, got {len(cams)}")
    for k, cam in enumerate(cams):
        if not isinstance(cam, Camera):
            raise TypeError(f"cameras[{k}] must be a cumuli.Camera, got {type(cam).__name__}")
    if isinstance(alpha, (bool, np.bool_)):
        alpha = "keep" if alpha else "opaque"
    if alpha not in ALPHA_MODES:
        raise ValueError(f"alpha must be one of {ALPHA_MODES}, got {alpha!r}")
    if not isinstance(pattern, str):
        raise TypeError(f"pattern must be a str, got {type(pattern).__name__}")
    try:
        names = [pattern.format(k) for k in range(len(cams))]
    except (IndexError, KeyError, ValueError) as exc:
        raise ValueError(f"pattern {pattern!r} must take one frame number: {exc}") from None
    if len(set(names)) != len(names) or any(os.sep in n for n in names):
        raise ValueError(f"pattern {pattern!r} must give a distinct file name per frame")
    if Path(names[0]).suffix.lower() not in FORMATS:  # before the first frame is rendered
        raise ValueError(
            f"pattern {pattern!r} gives {names[0]!r}, whose extension is not one of "
            f"{sorted(FORMATS)}"
        )
    folder = Path(out_dir)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(f"cannot create out_dir {str(folder)!r}: {exc.strerror or exc}") from exc
    if not os.access(folder, os.W_OK):
        raise OSError(f"out_dir {str(folder)!r} is not writable")
    if isinstance(impostors, (bool, np.bool_)):
        cache = ImpostorCache() if impostors else None
    elif isinstance(impostors, ImpostorCache):
        cache = impostors
    else:
        raise TypeError(
            f"impostors must be a bool or a cumuli.ImpostorCache, got {type(impostors).__name__}"
        )
    if cache is not None and client is not None:
        raise ValueError("impostors need the frames in order on one renderer: not with client")
    if client is not None:
        from cumuli.anim.cluster import _check_client, render_task, run

        _check_client(client, backend)
        tasks = [
            (render_task, (scene_after(scene, k * (dt or 0.0)).to_dict(), cam.to_dict(), width,
                           height, backend, str(folder / n), alpha))
            for k, (cam, n) in enumerate(zip(cams, names, strict=True))
        ]  # fmt: skip
        return [Path(p) for p in run(tasks, client, progress)]
    from tqdm.auto import tqdm

    paths = []
    for k, (cam, name) in enumerate(
        tqdm(list(zip(cams, names, strict=True)), desc="frames", unit="frame", disable=not progress)
    ):
        if weather is not None:
            if k:
                weather.step(dt)  # type: ignore[arg-type]
            frame_scene = weather.scene_at(base)
        else:
            frame_scene = scene_after(scene, k * dt) if dt else scene
        img = render(frame_scene, cam, width=width, height=height, backend=backend, impostors=cache)
        exposure, tonemap = display_for(frame_scene.settings.lighting)  # each mode's display
        paths.append(
            write_image(folder / name, img, alpha=alpha, exposure=exposure, tonemap=tonemap)
        )
    return paths
