"""The budget: every input's memory and work estimated before anything is made, against limits
a user can read and raise; the documented limits are the code's.

The expensive inputs are reproduced under a tiny budget (``cu.limits``), so the refusals are
checked at small sizes; where the real size is cheap to estimate it is checked too, with the
memory traced to show that nothing large was allocated.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli._util import budget, limits_table
from cumuli._util import validate as check
from cumuli.light import medium, physical, prepare
from cumuli.model import atlas as atlas_module
from cumuli.model import seedbox_presets as presets
from cumuli.model.billboard_field import BYTES_PER_BILLBOARD

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _restore_limits():
    previous = cu.get_limits()
    yield
    cu.set_limits(previous)


def _traced(call) -> tuple[BaseException, int]:
    """The exception ``call`` raises and the peak Python memory while it ran."""
    tracemalloc.start()
    try:
        with pytest.raises(ValueError) as err:
            call()
        return err.value, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


# --- the budget itself --------------------------------------------------------------------------
def test_limits_are_read_changed_and_restored() -> None:
    assert cu.get_limits() == cu.Limits()  # the documented defaults (no variable set here)
    assert cu.Limits().memory == 1 << 32 and cu.Limits().work == 1 << 28
    previous = cu.set_limits(memory="512M", work=1000)
    assert cu.get_limits().memory == 512 << 20 and cu.get_limits().work == 1000
    assert previous == cu.Limits()
    with cu.limits(memory="1K") as inside:
        assert inside.memory == 1024 and cu.get_limits().work == 1000
    assert cu.get_limits().memory == 512 << 20
    cu.set_limits(cu.Limits())
    assert cu.get_limits() == cu.Limits()


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [({"memory": 0}, ValueError), ({"memory": "lots"}, ValueError), ({"work": 1.5}, TypeError),
     ({"memory": True}, TypeError), ({"scene_expansion": 2**63}, ValueError)],
)  # fmt: skip
def test_bad_limits_are_refused_and_change_nothing(kwargs, error) -> None:
    with pytest.raises(error):
        cu.set_limits(**kwargs)
    assert cu.get_limits() == cu.Limits()


def test_the_environment_sets_the_starting_budget() -> None:
    code = "import cumuli as cu; l = cu.get_limits(); print(l.memory, l.work, l.scene_allowance)"
    env = {**os.environ, "CUMULI_MEMORY_BUDGET": "16G", "CUMULI_WORK_BUDGET": "1000",
           "CUMULI_SCENE_ALLOWANCE": "1M"}  # fmt: skip
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.stdout.split() == [str(16 << 30), "1000", str(1 << 20)], done.stderr
    env["CUMULI_MEMORY_BUDGET"] = "plenty"
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.returncode != 0 and "CUMULI_MEMORY_BUDGET" in done.stderr


def test_a_refusal_names_the_input_the_cost_the_budget_and_the_setting() -> None:
    with cu.limits(memory="1M"), pytest.raises(ValueError) as err:
        cu.sprite_atlas(n=64, size=64)
    text = str(err.value)
    for part in ("sprite_atlas(n=64, size=64)", "4.0 MiB", "1.0 MiB", "set_limits(memory=",
                 "CUMULI_MEMORY_BUDGET"):  # fmt: skip
        assert part in text, (part, text)


# --- the page of limits is generated from the code ---------------------------------------------
def test_the_limits_page_is_what_the_code_generates() -> None:
    page = (ROOT / "docs" / "limits.md").read_text(encoding="utf-8")
    assert page == limits_table.markdown(), (
        "docs/limits.md is stale: python -m cumuli._util.limits_table > docs/limits.md"
    )


def test_the_limits_page_names_real_constants() -> None:
    for _, path in (*limits_table.COSTS, *limits_table.FIXED):
        assert isinstance(limits_table.resolve(path), (int, float)), path
    for _, field, path, _ in limits_table.BUDGET:
        assert getattr(cu.Limits(), field) == limits_table.resolve(path)


def test_density_volume_agrees_with_the_documented_voxel_limit() -> None:
    assert medium.MAX_VOXELS == check.MAX_POINTS == 1 << 28
    cloud = cu.gaussian_cumulus(n=4, seed=1)
    err, peak = _traced(lambda: cu.density_volume(cloud, cu.Noise(seed=1, size=8), resolution=1024))
    assert "MAX_VOXELS" in str(err) and peak < 1 << 20
    cube = cu.VolumeCloud(np.ones((4, 4, 4), np.float32), ((0, 0, 0), (1, 1, 1)))
    with pytest.raises(ValueError, match="MAX_VOXELS"):
        cu.density_volume(cube, resolution=(1024, 1024, 257))


def test_density_volume_within_the_limit_is_held_to_the_budget(monkeypatch) -> None:
    cloud, noise = cu.gaussian_cumulus(n=4, seed=1), cu.Noise(seed=1, size=8)

    def never(*args):
        raise AssertionError("the field was computed")

    monkeypatch.setattr(medium._core, "density_grid", never)
    with cu.limits(memory="64K"), pytest.raises(ValueError, match="memory"):
        cu.density_volume(cloud, noise, resolution=32)
    with cu.limits(work=1000), pytest.raises(ValueError, match="samples"):
        cu.density_volume(cloud, noise, resolution=32)
    monkeypatch.undo()
    assert cu.density_volume(cloud, noise, resolution=8).values.size > 0


# --- scene files that expand -------------------------------------------------------------------
def _atlas_scene(tmp_path: Path, recipes: list[dict]) -> Path:
    clouds = [cu.seed_box_cloud(presets.cirrus(), seed=k).translated((30 * k, 0, 0))
              for k in range(len(recipes))]  # fmt: skip
    data = cu.Scene(clouds, noise=cu.Noise(seed=2, size=16)).to_dict()
    for entry, recipe in zip(data["clouds"], recipes, strict=True):
        entry["atlas"] = {"recipe": recipe}
    path = tmp_path / "atlases.json"
    path.write_text(json.dumps(data))
    return path


def _recipe(seed: int, n: int = 256, size: int = 512) -> dict:
    return {"style": "sunny", "n": n, "size": size, "seed": seed}


def test_a_small_scene_naming_huge_atlases_is_refused_before_any_is_made(
    tmp_path: Path, monkeypatch
) -> None:
    path = _atlas_scene(tmp_path, [_recipe(k) for k in range(3)])  # 3 GiB of atlases
    assert path.stat().st_size < 1 << 16

    def never(*args):
        raise AssertionError("an atlas was generated")

    monkeypatch.setattr(atlas_module._core, "sprite_atlas", never)
    atlas_module._generated.cache_clear()
    err, peak = _traced(lambda: cu.load_scene(path))
    text = str(err)
    assert "atlases.json" in text and "3 × atlas recipe (n=256, size=512): 3.0 GiB" in text
    assert "256.0 MiB" in text and "scene_allowance" in text
    assert peak < 8 << 20


def test_a_recipe_named_by_many_clouds_is_counted_once(tmp_path: Path) -> None:
    one = atlas_module.atlas_bytes(16, 32)
    assert one == 16 * 32 * 32 * 16
    path = _atlas_scene(tmp_path, [_recipe(1, 16, 32)] * 3)
    size = path.stat().st_size
    # A budget that holds one atlas beside the noise lattice, not three.
    noise = 16**3 * 4
    with cu.limits(scene_expansion=1, scene_allowance=one + noise + 1):
        assert cu.load_scene(path).clouds[0].atlas.recipe["n"] == 16
    distinct = _atlas_scene(tmp_path, [_recipe(k, 16, 32) for k in range(3)])
    with cu.limits(scene_expansion=1, scene_allowance=one + noise + 1):
        with pytest.raises(ValueError, match="3 × atlas recipe"):
            cu.load_scene(distinct)
    assert size > 0


def test_a_scene_file_may_cost_its_stated_multiple(tmp_path: Path) -> None:
    path = _atlas_scene(tmp_path, [_recipe(1, 64, 64)])  # a 4 MiB atlas
    size = path.stat().st_size
    limits = cu.Limits(scene_expansion=8, scene_allowance=1)
    assert limits.scene_bytes(size) == 8 * size
    with cu.limits(scene_expansion=8, scene_allowance=1):
        with pytest.raises(ValueError, match=r"max\(8 × its size"):
            cu.load_scene(path)
    with cu.limits(scene_expansion=8, scene_allowance=8 << 20):
        cu.load_scene(path)
    with cu.limits(memory="1M", scene_allowance="1G"):  # never more than the memory budget
        assert cu.Limits(memory=1 << 20).scene_bytes(size) == 1 << 20
        with pytest.raises(ValueError, match="memory"):
            cu.load_scene(path)


def test_the_cli_refuses_an_expanding_scene_and_the_environment_raises_it(tmp_path: Path) -> None:
    path = _atlas_scene(tmp_path, [_recipe(1, 64, 64)])  # 4 MiB of atlas
    out = tmp_path / "x.png"
    args = [sys.executable, "-m", "cumuli", "render", str(path), "-o", str(out), "--size", "8x8",
            "--backend", "cpu"]  # fmt: skip
    env = {**os.environ, "CUMULI_PROGRESS": "0", "CUMULI_SCENE_ALLOWANCE": "1M"}
    done = subprocess.run(args, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "atlases.json" in done.stderr and "atlas recipe" in done.stderr
    assert not out.exists()
    env["CUMULI_SCENE_ALLOWANCE"] = "64M"
    done = subprocess.run(args, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert out.exists()


def test_a_billboard_field_is_held_to_the_budget_as_a_call_and_from_a_file(tmp_path) -> None:
    cloud = cu.seed_box_cloud(presets.cirrus(), seed=1)
    offsets = np.zeros((1000, 3), np.float32)
    drawn = 1000 * cloud.n_billboards
    with cu.limits(memory=drawn * BYTES_PER_BILLBOARD - 1):
        with pytest.raises(ValueError, match=f"1000 instances \\({drawn} billboards\\)"):
            cu.BillboardField([cloud], offsets)
        scene = cu.Scene([cu.BillboardField([cloud], offsets[:10])])
        data = scene.to_dict()
        data["clouds"][0]["offsets"] = offsets.tolist()
        data["clouds"][0]["variant"] = [0] * 1000
        for key in ("yaw", "alpha", "state"):
            data["clouds"][0][key] = [data["clouds"][0][key][0]] * 1000
        data["clouds"][0]["ids"] = list(range(1000))
        path = tmp_path / "field.json"
        path.write_text(json.dumps(data))
        with pytest.raises(ValueError, match="billboard field of 1000 instances"):
            cu.load_scene(path)
    assert cu.BillboardField([cloud], offsets).n == 1000


def test_the_physical_resolution_is_held_to_the_budget_before_the_light_pass(monkeypatch) -> None:
    clouds = [cu.gaussian_cumulus(n=4, seed=1), cu.gaussian_cumulus(n=4, seed=2)]
    settings = cu.RenderSettings(lighting="physical", physical_resolution=256)
    scene = cu.Scene([clouds[0], clouds[1].translated((6, 0, 0))], settings=settings,
                     noise=cu.Noise(seed=1, size=8))  # fmt: skip

    def never(*args):
        raise AssertionError("the physical light was computed")

    monkeypatch.setattr(physical._core, "light_space_depth", never)
    monkeypatch.setattr(medium._core, "density_grid", never)
    prepare.clear_memo()
    err, peak = _traced(lambda: cu.render(scene, scene.default_camera(), 8, 8, backend="cpu"))
    assert "physical_resolution=256" in str(err) and peak < 8 << 20
    memory, samples = settings.physical_cost(2)
    # Held by its work (its memory, ~3.6 GB with two sun-lattice nodes per cell along the
    # light, is within the 4 GiB default; the work is twice the limit).
    assert samples > cu.get_limits().work and memory > cu.get_limits().memory / 2
    small = cu.RenderSettings(lighting="physical", physical_resolution=16)
    with cu.limits(memory=small.physical_cost(2)[0] - 1):
        with pytest.raises(ValueError, match="physical_resolution=16"):
            small.check_physical_budget(2)
    small.check_physical_budget(2)


def test_a_deck_and_a_noise_are_held_to_the_budget() -> None:
    with cu.limits(memory="1M"):
        with pytest.raises(ValueError, match="deck of resolution"):
            cu.CloudDeck(resolution=(64, 16, 64))
        with pytest.raises(ValueError, match="Noise\\(size=128\\)"):
            cu.Noise(seed=1, size=128)
        with pytest.raises(cu.BudgetError, match="fbm_grid of shape"):
            cu.Noise(seed=1, size=16).fbm_grid(128, (0, 0, 0), (1, 1, 1))
    assert cu.CloudDeck(resolution=(64, 16, 64)).resolution == (64, 16, 64)


def test_a_weather_file_is_held_to_the_scene_rule(tmp_path: Path, monkeypatch) -> None:
    from cumuli.anim import weather

    path = tmp_path / "w.npz"
    made = cu.weather_presets.three_layers(seed=1)
    made.save(path)
    with cu.limits(scene_expansion=1, scene_allowance=1024):
        with pytest.raises(cu.BudgetError, match="w.npz.*atlas recipe"):
            cu.load_weather(path)
    atlases = 2 * atlas_module.atlas_bytes(16, 64)  # the preset's two recipes
    variants = weather.variants_cost(made.layers)
    assert variants > 0

    def never(*args, **kwargs):
        raise AssertionError("a variant was generated")

    monkeypatch.setattr(weather, "cloud_variants", never)
    with cu.limits(scene_expansion=1, scene_allowance=atlases + variants - 1):
        with pytest.raises(cu.BudgetError, match="w.npz.*variants") as err:
            cu.load_weather(path)
    assert "invalid" not in str(err.value)  # a refusal, not a corrupt file
    with cu.limits(memory=variants - 1, scene_allowance=1 << 30):  # and as a call
        with pytest.raises(cu.BudgetError, match="weather of"):
            cu.Weather(made.area, made.layers, seed=1)
    monkeypatch.undo()
    assert cu.load_weather(path) is not None


def test_a_billboard_file_is_held_to_the_scene_rule(tmp_path: Path) -> None:
    cloud = cu.seed_box_cloud(presets.cirrus(), seed=1)
    for suffix in (".npz", ".json"):
        path = tmp_path / f"b{suffix}"
        cloud.save(path)
        with cu.limits(scene_expansion=1, scene_allowance=1024):
            with pytest.raises(cu.BudgetError, match=f"b{suffix}.*atlas recipe"):
                cu.load_billboards(path)
        assert cu.load_billboards(path).n_billboards == cloud.n_billboards


def test_amounts_read_as_people_write_them() -> None:
    assert budget.parse_amount("8G", "x") == 8 << 30
    assert budget.parse_amount("512MiB", "x") == 512 << 20
    assert budget.parse_amount("1000", "x") == 1000
    for bad in ("", "-1", "1.5G", "9" * 30, "0"):
        with pytest.raises(ValueError):
            budget.parse_amount(bad, "x")
