"""Frames and sweeps across a Dask cluster (`cumuli.anim.cluster`): the same images as the
serial path, from worker processes started with the spawn method; clear errors."""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu

distributed = pytest.importorskip("distributed")

W, H = 24, 18


def small_scene(seed: int = 1, sun_y: float = 0.8) -> cu.Scene:
    cloud = cu.gaussian_cumulus(n=8, seed=seed)
    return cu.Scene(
        [cloud],
        sun=cu.Sun(direction=(0.3, sun_y, 0.2)),
        noise=cu.Noise(seed=7, size=16),
        settings=cu.RenderSettings(light_resolution=6),
    )


@pytest.fixture(scope="module")
def client() -> Iterator[distributed.Client]:
    # Two worker processes (spawned), one thread each: what the GL backend needs too.
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=":0"
    )
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


def test_frames_on_a_cluster_equal_the_serial_frames(client, tmp_path: Path) -> None:
    scene = small_scene()
    cams = cu.orbit(scene.default_camera().target, 40.0, frames=4, height=5.0)
    serial = cu.render_frames(
        scene, cams, tmp_path / "a", W, H, backend="cpu", pattern="{:02d}.exr", progress=False
    )
    spread = cu.render_frames(
        scene, cams, tmp_path / "b", W, H, backend="cpu", pattern="{:02d}.exr", progress=False,
        client=client,
    )  # fmt: skip
    assert [p.name for p in spread] == [p.name for p in serial]
    for a, b in zip(serial, spread, strict=True):
        np.testing.assert_array_equal(cu.read_image(a), cu.read_image(b))
    # Both workers did some of the work.
    assert len(client.scheduler_info()["workers"]) == 2


def test_sweep_on_a_cluster_equals_the_serial_sweep(client) -> None:
    params = [{"seed": s, "sun_y": y} for s in (1, 2) for y in (0.5, 1.0)]
    camera = cu.Camera(position=(0, 4, -45), target=(0, 4, 0))
    serial = cu.sweep(small_scene, params, camera, W, H, progress=False)
    spread = cu.sweep(small_scene, params, camera, W, H, client=client, progress=False)
    assert len(spread) == 4
    for a, b in zip(serial, spread, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(serial[0], serial[1])  # the sun moved
    # The scene built directly renders the same image.
    direct = cu.render(small_scene(**params[2]), camera, W, H, backend="cpu")
    direct[..., 3] = 1.0
    np.testing.assert_array_equal(serial[2], direct)


def test_sweep_writes_files_and_takes_a_camera_function(tmp_path: Path) -> None:
    params = [{"seed": 1}, {"seed": 3}]

    def cam(seed: int) -> cu.Camera:
        return small_scene(seed).default_camera()

    paths = cu.sweep(small_scene, params, cam, W, H, out_dir=tmp_path, progress=False)
    assert [p.name for p in paths] == ["sweep_0000.png", "sweep_0001.png"]
    assert all(p.is_file() for p in paths)


def test_gl_on_workers_with_several_threads_is_refused() -> None:
    cluster = distributed.LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=":0"
    )
    with distributed.Client(cluster) as c:
        with pytest.raises(ValueError, match="one thread per worker"):
            cu.sweep(functools.partial(small_scene, 1), [{}], None, W, H, backend="gl", client=c)
    cluster.close()


def test_bad_sweep_arguments() -> None:
    with pytest.raises(TypeError, match="scene_fn"):
        cu.sweep("scene", [{}])
    with pytest.raises(TypeError, match="params"):
        cu.sweep(small_scene, {"seed": 1})
    with pytest.raises(TypeError, match=r"params\[1\]"):
        cu.sweep(small_scene, [{}, 3])
    with pytest.raises(ValueError, match="backend"):
        cu.sweep(small_scene, [{}], backend="vulkan")
    with pytest.raises(TypeError, match="client"):
        cu.sweep(small_scene, [{}], client=object())
    with pytest.raises(TypeError, match="cumuli.Scene"):
        cu.sweep(lambda: "not a scene", [{}], progress=False)


def test_bench_cluster_quick_writes_json_and_plot(
    tmp_path: Path, run_bench: Callable[..., str]
) -> None:
    import json

    run_bench("bench_cluster.py", tmp_path, timeout=300)
    data = json.loads((tmp_path / "cluster.json").read_text())
    assert data["images_identical"] is True
    assert set(data["seconds"]) == {"serial", "1 worker", "2 workers"}
    assert data["ratios"]["2_workers_speedup_over_1"] > 0
    assert (tmp_path / "cluster.png").stat().st_size > 1000


def test_workers_run_tasks_under_the_submitters_budget(client) -> None:
    from cumuli.anim import cluster

    def budget_here() -> int:
        return cu.get_limits().memory

    with cu.limits(memory="3M"):
        seen = cluster.run([(budget_here, ()), (budget_here, ())], client, progress=False)
    assert seen == [3 << 20, 3 << 20]  # the workers' own default is 4 GiB
    assert cluster.run([(budget_here, ())], client, progress=False) == [cu.Limits().memory]
    with cu.limits(memory="1M"):  # a scene the submitter refuses is refused on the workers
        with pytest.raises(cu.BudgetError, match="Noise"):
            cu.sweep(lambda: cu.Scene([], noise=cu.Noise(seed=1, size=128)), [{}],
                     client=client, progress=False)  # fmt: skip
