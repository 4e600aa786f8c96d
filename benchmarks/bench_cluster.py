"""Frames across a Dask cluster: a camera path rendered serially and on 1 and 2 local workers.

`cumuli.render_frames(..., client=)` sends one task per frame to a ``dask.distributed`` cluster
(the scene as JSON, rebuilt and lit in each worker process). This script renders the same orbit
of the benchmark cumulus with the CPU backend (one thread per render, so the workers are the
parallelism) serially in this process, on a ``LocalCluster`` of one worker process and of two,
and reports the wall time of the whole sequence (cluster start-up excluded, each cluster warmed
up by one frame per worker so that its processes have imported cumuli and lit the scene) and the
speed-ups as ratios in one run. The images are checked equal to the serial ones. Writes
``cluster.json`` and ``cluster.png`` under ``benchmarks/out/`` (or ``--out``).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.anim.cluster import render_task, run  # noqa: E402
from cumuli.demo import benchmark_scenes  # noqa: E402


def sequence(scene: cu.Scene, cams: list[cu.Camera], w: int, h: int, client: Any) -> list[Any]:
    """The frames as arrays (one CPU thread per frame: the workers are the parallelism)."""
    data = scene.to_dict()
    tasks = [(render_task, (data, c.to_dict(), w, h, "cpu", None, "opaque", 1)) for c in cams]
    return run(tasks, client, progress=False)


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    import distributed
    import numpy as np

    w, h = (48, 36) if args.quick else (160, 120)
    frames = 4 if args.quick else 16
    repeats = 1 if args.quick else 3
    machine = common.machine_info()
    scene = benchmark_scenes(("cumulus",))["cumulus"]
    # One render thread per frame, so that 1 vs 2 workers measures the cluster, not the core.
    scene = scene.replace(settings=scene.settings.replace(light_resolution=20))
    centre = scene.default_camera().target
    cams = cu.orbit(centre, 60.0, frames=frames, height=8.0)
    common.log(f"{frames} frames of {w}x{h}, CPU backend; {machine['cores']} cores")

    timings: dict[str, list[float]] = {}
    reference = None
    tmp = Path(tempfile.mkdtemp(prefix="cumuli-bench-cluster-"))
    try:
        for name, workers in (("serial", 0), ("1 worker", 1), ("2 workers", 2)):
            client = cluster = None
            if workers:
                cluster = distributed.LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True,
                    host="127.0.0.1", dashboard_address=":0", local_directory=str(tmp),
                )  # fmt: skip
                client = distributed.Client(cluster)
                sequence(scene, cams[:workers], w, h, client)  # warm up every worker
            else:
                sequence(scene, cams[:1], w, h, None)
            times = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                images = sequence(scene, cams, w, h, client)
                times.append(time.perf_counter() - t0)
            if reference is None:
                reference = images
            same = all(np.array_equal(a, b) for a, b in zip(reference, images, strict=True))
            if not same:
                raise SystemExit(f"{name}: images differ from the serial ones")
            timings[name] = times
            common.log(f"{name}: {1e3 * min(times):.0f} ms best, images identical")
            if client is not None:
                client.close()
                cluster.close()
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    stats = {k: common.spread(v) for k, v in timings.items()}
    serial = stats["serial"]["median"]
    ratios = {
        "1_worker_over_serial": stats["1 worker"]["median"] / serial,
        "2_workers_speedup_over_1": stats["1 worker"]["median"] / stats["2 workers"]["median"],
        "2_workers_speedup_over_serial": serial / stats["2 workers"]["median"],
    }
    data = {
        "benchmark": "cluster",
        "image": [w, h],
        "frames": frames,
        "backend": "cpu",
        "machine": machine,
        "timing": "wall seconds of the whole sequence (cluster start-up excluded)",
        "seconds": stats,
        "ratios": ratios,
        "images_identical": True,
    }
    path = common.write_json(args.out / "cluster.json", data)
    speedup = ratios["2_workers_speedup_over_1"]
    common.log(f"wrote {path}; 2 workers / 1 worker speed-up {speedup:.2f}")

    plt = common.pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.5))
    names = list(stats)
    ax.bar(names, [stats[n]["median"] for n in names])
    ax.set_ylabel(f"s for {frames} frames of {w}x{h} (median)")
    ax.set_title(f"render_frames on a Dask LocalCluster ({machine['cores']} cores)", fontsize=9)
    fig.tight_layout()
    fig.savefig(args.out / "cluster.png", dpi=100)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
