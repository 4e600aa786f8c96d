"""Frames and parameter sweeps across a Dask cluster (beyond the papers: datasets and sweeps).

Users render thousands of frames — camera paths, datasets, sweeps over the sun, the density or
the phase g. `render_frames(..., client=)` and `sweep(scene_fn, params, client=)` hand one task
per frame to a ``dask.distributed`` client: the scene travels as its JSON (`Scene.to_dict`, a few
kB to a few MB), each worker process rebuilds it, runs the light step (memoised per process) and
renders with its own backend — for ``backend="gl"`` one GL context per worker process, so
workers must run one thread each (``LocalCluster(threads_per_worker=1)``, which starts worker
processes with the ``spawn`` method: a forked process must not inherit a GL context). Frames are
written atomically by the workers (``out_dir`` must then be a folder every worker sees) or
returned as arrays. Without a client the same tasks run here, one after the other; the images
are identical either way.

Needs the optional extra ``cumuli[cluster]`` (``dask[distributed]``). To use a real cluster,
give a client connected to its scheduler: ``Client("tcp://scheduler:8786")`` (workers started
with ``dask worker tcp://scheduler:8786 --nthreads 1`` on machines where ``pip install
cumuli[cluster]`` works), or a ``dask_jobqueue`` / ``dask_kubernetes`` cluster's client.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cumuli._util.budget import Limits, get_limits, within
from cumuli.camera import Camera
from cumuli.scene import Scene

BACKENDS = ("gl", "cpu")
#: Most renders of one `sweep` (as `render_frames`' MAX_FRAMES: its tasks are held in memory).
MAX_SWEEP = 100_000


def render_task(
    scene: dict[str, Any],
    camera: dict[str, Any] | None,
    width: int,
    height: int,
    backend: str,
    path: str | None,
    alpha: str,
    threads: int = 0,
) -> np.ndarray | str:
    """One frame, as a worker runs it: rebuild the scene from its JSON, render, write or return.

    ``camera=None`` uses the scene's default camera. With ``path`` the image is written there
    (atomically) and the path returned, else the ``(H, W, 4)`` float32 image. ``threads`` is the
    CPU backend's (0: every core of the worker's machine).
    """
    from cumuli.io.images import write_image
    from cumuli.rendering.compositor import render, render_cpu

    built = Scene.from_dict(scene)
    cam = built.default_camera() if camera is None else Camera(**camera)
    if backend == "cpu":
        img = render_cpu(built, cam, width, height, threads=threads)
    else:
        img = render(built, cam, width=width, height=height, backend=backend)
    if path is not None:
        return str(write_image(path, img, alpha=alpha))
    if alpha == "opaque":  # what write_image would save
        img[..., 3] = 1.0
    return img


def sweep_task(
    scene_fn: Callable[..., Scene],
    params: dict[str, Any],
    camera: Any,
    width: int,
    height: int,
    backend: str,
    path: str | None,
    alpha: str,
) -> np.ndarray | str:
    """One point of a sweep: ``scene_fn(**params)`` built where the task runs, then rendered."""
    scene = scene_fn(**params)
    if not isinstance(scene, Scene):
        raise TypeError(f"scene_fn must return a cumuli.Scene, got {type(scene).__name__}")
    if callable(camera):
        camera = camera(**params)
    cam = None if camera is None else camera.to_dict()
    return render_task(scene.to_dict(), cam, width, height, backend, path, alpha)


def _check_client(client: Any, backend: str) -> None:
    if not hasattr(client, "submit") or not hasattr(client, "gather"):
        raise TypeError(f"client must be a dask.distributed Client, got {type(client).__name__}")
    if backend == "gl":
        threads = client.nthreads()
        many = {w: n for w, n in threads.items() if n > 1}
        if many:
            raise ValueError(
                "backend='gl' needs one thread per worker (one GL context per worker process); "
                f"these workers run several: {many}. Start them with threads_per_worker=1 "
                "(LocalCluster) or --nthreads 1 (dask worker), or use backend='cpu'"
            )


def _within(limits: Limits, fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)`` under ``limits`` (a worker runs a task with its submitter's budget)."""
    with within(limits):
        return fn(*args)


def run(
    tasks: Sequence[tuple[Callable[..., Any], tuple[Any, ...]]],
    client: Any = None,
    progress: bool = True,
    desc: str = "frames",
) -> list[Any]:
    """Run ``(function, args)`` tasks on ``client`` (or here, in order); results in order."""
    if client is None:
        from tqdm.auto import tqdm

        return [
            fn(*args) for fn, args in tqdm(tasks, desc=desc, unit="frame", disable=not progress)
        ]
    # pure=False: every frame is a distinct task even when its arguments repeat. Each task runs
    # under the budget of the process that submits it (a worker's own may be the default).
    limits = get_limits()
    futures = [client.submit(_within, limits, fn, *args, pure=False) for fn, args in tasks]
    if progress:
        from distributed import progress as dask_progress

        dask_progress(futures)
    return client.gather(futures)


def sweep(
    scene_fn: Callable[..., Scene],
    params: Sequence[dict[str, Any]],
    camera: Camera | Callable[..., Camera] | None = None,
    width: int = 320,
    height: int = 240,
    backend: str = "cpu",
    client: Any = None,
    out_dir: str | os.PathLike[str] | None = None,
    pattern: str = "sweep_{:04d}.png",
    progress: bool = True,
    alpha: str = "opaque",
) -> list[np.ndarray] | list[Path]:
    """Render ``scene_fn(**p)`` for every ``p`` in ``params``: a sweep over anything a scene
    depends on (sun, density, g, seeds...).

    ``scene_fn`` runs where the task runs (on the workers with a ``client``), so building the
    scene is distributed too; with a client it must be picklable by cloudpickle (a function, a
    lambda or a partial). ``camera`` is a `Camera`, a function of the same parameters, or None
    (each scene's default camera). Returns the images (opaque unless ``alpha="keep"``, as
    :func:`cumuli.write_image` saves them), or with ``out_dir`` the paths of the files written
    there (``pattern`` numbered by sweep index).
    """
    from cumuli._util import validate as check
    from cumuli.io.images import ALPHA_MODES

    if not callable(scene_fn):
        raise TypeError(f"scene_fn must be callable, got {type(scene_fn).__name__}")
    if isinstance(params, (str, bytes, dict)) or not isinstance(params, Sequence):
        raise TypeError("params must be a sequence of dicts (keyword arguments of scene_fn)")
    if len(params) > MAX_SWEEP:  # as render_frames: a list of tasks is held in memory
        raise ValueError(f"params has {len(params)} entries, more than MAX_SWEEP={MAX_SWEEP}")
    for k, p in enumerate(params):
        if not isinstance(p, dict):
            raise TypeError(f"params[{k}] must be a dict, got {type(p).__name__}")
    if camera is not None and not isinstance(camera, Camera) and not callable(camera):
        raise TypeError("camera must be a cumuli.Camera, a function of the parameters, or None")
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if alpha not in ALPHA_MODES:
        raise ValueError(f"alpha must be one of {ALPHA_MODES}, got {alpha!r}")
    width = check.integer(width, "width", 1, 1 << 14)
    height = check.integer(height, "height", 1, 1 << 14)
    paths = _paths(out_dir, pattern, len(params))
    if client is not None:
        _check_client(client, backend)
    tasks = [
        (sweep_task, (scene_fn, p, camera, width, height, backend, path, alpha))
        for p, path in zip(params, paths, strict=True)
    ]
    results = run(tasks, client, progress, desc="sweep")
    return [Path(r) for r in results] if out_dir is not None else results


def _paths(out_dir: str | os.PathLike[str] | None, pattern: str, count: int) -> list[str | None]:
    if out_dir is None:
        return [None] * count
    if not isinstance(pattern, str):
        raise TypeError(f"pattern must be a str, got {type(pattern).__name__}")
    try:
        names = [pattern.format(k) for k in range(count)]
    except (IndexError, KeyError, ValueError) as exc:
        raise ValueError(f"pattern {pattern!r} must take one frame number: {exc}") from None
    if len(set(names)) != len(names) or any(os.sep in n for n in names):
        raise ValueError(f"pattern {pattern!r} must give a distinct file name per frame")
    from cumuli.io.images import FORMATS

    if count and Path(names[0]).suffix.lower() not in FORMATS:  # before any task runs
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
    return [str(folder / n) for n in names]
