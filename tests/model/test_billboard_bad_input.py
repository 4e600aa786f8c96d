"""Bad input to the Torchelsen & Musse pieces: a ValueError/TypeError naming the parameter,
checked before anything is allocated; a failed call changes nothing; corrupt files are refused
with an error naming the file."""

from __future__ import annotations

import io
import json
import math
import zipfile

import numpy as np
import pytest

from cumuli.anim.weather import CloudLayer, Schedule, SkyState, Weather, load_weather
from cumuli.light.caf import BillboardShading, absorption_factors, shade_points
from cumuli.model import seedbox_presets as presets
from cumuli.model.atlas import SpriteAtlas, sprite_atlas
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import (
    BasisModel,
    BillboardCloud,
    SeedBox,
    load_billboards,
    seed_box_cloud,
)
from cumuli.sky import Sun


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"half_size": (0, 1, 1)}, "half_size"),
        ({"half_size": (1, -1, 1)}, "half_size"),
        ({"centre": (math.nan, 0, 0)}, "centre"),
        ({"centre": (1e16, 0, 0)}, "centre"),
        ({"directions": [(0, 0, 0)], "apertures": [30]}, "directions"),
        ({"directions": [], "apertures": []}, "directions"),
        ({"directions": [(1, 0)], "apertures": [30]}, "directions"),
        ({"apertures": (400, 30, 30)}, "apertures"),
        ({"apertures": (30, 30)}, "apertures"),
        ({"levels": 0}, "levels"),
        ({"levels": 17}, "levels"),
        ({"levels": 1.5}, "levels"),
        ({"boxes_per_level": (3, 1)}, "boxes_per_level"),
        ({"boxes_per_level": (0, 65)}, "boxes_per_level"),
        ({"boxes_per_level": 3}, "boxes_per_level"),
        ({"billboards_per_box": (0, 300)}, "billboards_per_box"),
        ({"child_scale": (0, 1)}, "child_scale"),
        ({"child_scale": (2, 1)}, "child_scale"),
        ({"reach": -1.0}, "reach"),
        ({"reach": math.inf}, "reach"),
        ({"count_per": "box"}, "count_per"),
        ({"flat_base": 1}, "flat_base"),
    ],
)
def test_seed_box_parameters(kwargs, name) -> None:
    with pytest.raises((ValueError, TypeError), match=name):
        SeedBox(**kwargs)


def test_basis_model_limits_checked_before_generating() -> None:
    huge = SeedBox(directions=[(1, 0, 0)] * 64, apertures=[30] * 64, levels=16,
                   boxes_per_level=(64, 64), billboards_per_box=(0, 0))  # fmt: skip
    assert huge.max_boxes == 1 + 16 * 64 * 64 > 2**16
    with pytest.raises(ValueError, match="seeds"):
        BasisModel((huge,))
    many = SeedBox(directions=[(1, 0, 0)], apertures=[30], levels=16, boxes_per_level=(64, 64),
                   billboards_per_box=(0, 256))  # fmt: skip
    with pytest.raises(ValueError, match="billboards_per_box"):
        BasisModel((many,) * 5)
    for kwargs, name in [
        ({"textures": (0, 99)}, "textures"),
        ({"textures": ()}, "textures"),
        ({"opacity": 0.0}, "opacity"),
        ({"opacity": 1.5}, "opacity"),
        ({"billboard_size": (1.0, 0.5)}, "billboard_size"),
        ({"aspect_min": 0.0}, "aspect_min"),
        ({"min_spacing": -1.0}, "min_spacing"),
        ({"atlas": "sunny"}, "atlas"),
        ({"rotate": "yes"}, "rotate"),
    ]:
        with pytest.raises((ValueError, TypeError), match=name):
            BasisModel((SeedBox(),), **kwargs)
    with pytest.raises(TypeError, match="seeds"):
        BasisModel(("box",))
    m = BasisModel((SeedBox(),))
    with pytest.raises(TypeError, match="model"):
        seed_box_cloud("cumulus", 0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="seed"):
        seed_box_cloud(m, -1)
    with pytest.raises(ValueError, match="threads"):
        seed_box_cloud(m, 0, threads=-1)


def test_atlas_arguments() -> None:
    for kwargs, name in [({"style": "cloudy"}, "style"), ({"n": 0}, "n"), ({"n": 257}, "n"),
                         ({"size": 4}, "size"), ({"seed": -2}, "seed")]:  # fmt: skip
        with pytest.raises((ValueError, TypeError), match=name):
            sprite_atlas(**kwargs)
    with pytest.raises(ValueError, match="shape"):
        SpriteAtlas.from_image(np.zeros((8, 8, 3)), (2, 2))
    with pytest.raises(ValueError, match="grid"):
        SpriteAtlas.from_image(np.zeros((8, 9, 4)), (2, 2))
    with pytest.raises(ValueError, match="finite"):
        SpriteAtlas.from_image(np.full((8, 8, 4), np.nan), (2, 2))
    with pytest.raises(ValueError, match="alpha"):
        SpriteAtlas.from_image(np.full((8, 8, 4), 2.0), (2, 2))


def arrays_of(c: BillboardCloud) -> dict:
    keys = ("boxes", "box_level", "box_seed", "box_direction", "centres", "sizes", "texture",
            "box", "rotation")  # fmt: skip
    return {k: np.array(getattr(c, k)) for k in keys}


def test_billboard_cloud_validation() -> None:
    c = seed_box_cloud(presets.cumulus(), 0)
    bad = arrays_of(c)
    bad["boxes"][0, 0, 0] = bad["boxes"][0, 1, 0] + 1
    with pytest.raises(ValueError, match="boxes"):
        BillboardCloud(**bad)
    for key, value, name in [
        ("box", lambda a: a + 1000, "box"),
        ("texture", lambda a: a + 99, "texture"),
        ("sizes", lambda a: -a, "sizes"),
        ("sizes", lambda a: a[:-1], "sizes"),
        ("centres", lambda a: a * np.nan, "centres"),
        ("rotation", lambda a: a.astype(str), "rotation"),
    ]:
        arr = arrays_of(c)
        arr[key] = value(arr[key])
        with pytest.raises((ValueError, TypeError), match=name):
            BillboardCloud(**arr)
    with pytest.raises(ValueError, match="opacity"):
        BillboardCloud(**arrays_of(c), opacity=0.0)
    with pytest.raises(TypeError, match="params"):
        BillboardCloud(**arrays_of(c), params={"x": object()})
    with pytest.raises(ValueError, match="offset"):
        c.translated((0, math.nan, 0))
    with pytest.raises(ValueError, match="degrees"):
        c.rotated_y(math.inf)
    with pytest.raises(ValueError, match="atlas"):
        c.merged(seed_box_cloud(presets.rain(), 0))
    with pytest.raises(ValueError, match="kind"):
        c.to_cloud(kind="metaballs")


def test_light_arguments() -> None:
    c = seed_box_cloud(presets.cumulus(), 0)
    for kwargs, name in [
        ({"sun": (0, 0, 0)}, "sun"),
        ({"sun": "up"}, "sun"),
        ({"max_distance": 0.0}, "max_distance"),
        ({"max_distance": -3.0}, "max_distance"),
        ({"max_distance": math.nan}, "max_distance"),
        ({"overlap": "max"}, "overlap"),
        ({"curve": "cubic"}, "curve"),
        ({"at": "vertex"}, "at"),
        ({"include_self": 1}, "include_self"),
    ]:
        args = {"sun": (0, 1, 0), **kwargs}
        with pytest.raises((ValueError, TypeError), match=name):
            absorption_factors(c, **args)
    with pytest.raises(TypeError, match="cloud"):
        absorption_factors(c.to_cloud(), (0, 1, 0))  # type: ignore[arg-type]
    for kwargs, name in [
        ({"d_min": 0.9, "d_max": 0.5}, "d_min"),
        ({"k_dir": 0.0}, "k_dir"),
        ({"ambient": (-1, 0, 0)}, "ambient"),
        ({"height_levels": ((0.5, 1.0), (0.2, 1.0))}, "height_levels"),
        ({"height_levels": ((0.5, -1.0),)}, "height_levels"),
        ({"shading": "pixel"}, "shading"),
        ({"directional": "cosine"}, "directional"),
        ({"k_amb": math.nan}, "k_amb"),
    ]:
        with pytest.raises((ValueError, TypeError), match=name):
            BillboardShading(**kwargs)
    sun = Sun((0, 1, 0))
    lt = absorption_factors(c, sun)
    with pytest.raises(ValueError, match="billboard"):
        shade_points(c, np.zeros((2, 3)), np.array([0, c.n_billboards]), sun, lt)
    with pytest.raises(ValueError, match="points"):
        shade_points(c, np.zeros((2, 2)), np.array([0, 1]), sun, lt)
    with pytest.raises(TypeError, match="light"):
        shade_points(c, np.zeros((1, 3)), np.array([0]), sun, lt, extra=[(sun, None)])


def test_field_arguments() -> None:
    vs = [seed_box_cloud(presets.cumulus(), k) for k in range(2)]
    off = np.zeros((3, 3))
    for kwargs, name in [
        ({"variant": [0, 1, 2]}, "variant"),
        ({"variant": [0, 1]}, "variant"),
        ({"alpha": [0, 1, 2]}, "alpha"),
        ({"yaw": [0, math.nan, 0]}, "yaw"),
        ({"state": [0, -1, 0]}, "state"),
    ]:
        with pytest.raises((ValueError, TypeError), match=name):
            BillboardField(vs, off, **kwargs)
    with pytest.raises(ValueError, match="offsets"):
        BillboardField(vs, [[0, math.nan, 0]])
    with pytest.raises(TypeError, match="variants"):
        BillboardField(vs[0], off)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def small_weather_args():
    state = SkyState(0.0, (presets.cumulus(),), variants=2, count=10)
    return state, CloudLayer(40.0, 8.0, (5.0, 0.0), (state,))


def test_weather_arguments_and_failed_step(small_weather_args) -> None:
    state, layer = small_weather_args
    for kwargs, name in [
        ({"area": ((10, 0), (0, 10))}, "area"),
        ({"area": ((0, 0), (math.nan, 10))}, "area"),
        ({"layers": []}, "layers"),
        ({"layers": [state]}, "layers"),
        ({"cv": [(0, 0.0), (0, 1.0)]}, "cv"),
        ({"cv": 1.5}, "cv"),
        ({"seed": -1}, "seed"),
    ]:
        args = {"area": ((-100, -100), (100, 100)), "layers": [layer], **kwargs}
        with pytest.raises((ValueError, TypeError), match=name):
            Weather(**args)
    for kwargs, name in [
        ({"states": (SkyState(0.5, state.models), SkyState(0.2, state.models))}, "states"),
        ({"boundary": "bounce"}, "boundary"),
        ({"wind": (1, 2, 3)}, "wind"),
        ({"fade_time": -1.0}, "fade_time"),
        ({"thickness": -1.0}, "thickness"),
    ]:
        args = {"altitude": 40.0, "thickness": 8.0, "states": (state,), **kwargs}
        with pytest.raises((ValueError, TypeError), match=name):
            CloudLayer(**args)
    for kwargs, name in [({"cv": 1.5}, "cv"), ({"count": -1}, "count"),
                         ({"variants": 0}, "variants"), ({"models": ()}, "models")]:  # fmt: skip
        args = {"cv": 0.0, "models": state.models, **kwargs}
        with pytest.raises((ValueError, TypeError), match=name):
            SkyState(**args)
    with pytest.raises(ValueError, match="variants"):
        Weather(layers=[CloudLayer(40, 8, (1, 0), (SkyState(0.0, state.models, variants=5000),))])
    with pytest.raises(ValueError, match="strictly increasing"):
        Schedule([(0, 0.0), (5, 0.5), (4, 1.0)])
    w = Weather(((-100, -100), (100, 100)), [layer], cv=0.0, seed=3)
    w.step(1.0)
    before = (w.t, w.instances(0), w.layer_stats(0))
    for dt in (-1.0, math.nan, math.inf, None):
        with pytest.raises((ValueError, TypeError), match="dt"):
            w.step(dt)  # type: ignore[arg-type]
    assert w.t == before[0]
    after = w.instances(0)
    assert all(np.array_equal(after[k], before[1][k]) for k in after)
    assert w.layer_stats(0)["events"] == before[2]["events"]
    with pytest.raises(ValueError, match="layer"):
        w.instances(3)


# --- files ---------------------------------------------------------------------------------------
def test_billboard_files(tmp_path) -> None:
    c = seed_box_cloud(presets.cumulus(), 0)
    with pytest.raises(FileNotFoundError):
        load_billboards(tmp_path / "missing.npz")
    with pytest.raises(ValueError, match="path"):
        c.save(tmp_path / "c.txt")
    with pytest.raises(FileNotFoundError):
        c.save(tmp_path / "no" / "c.npz")
    assert not list(tmp_path.iterdir())
    (tmp_path / "empty.npz").write_bytes(b"")
    (tmp_path / "junk.npz").write_bytes(b"PK\x03\x04 not really a zip")
    (tmp_path / "junk.json").write_text("{not json")
    (tmp_path / "other.json").write_text(json.dumps({"format": "cumuli.cloud"}))
    for name in ("empty.npz", "junk.npz", "junk.json", "other.json"):
        with pytest.raises(ValueError, match=name.replace(".", r"\.")):
            load_billboards(tmp_path / name)
    good = c.save(tmp_path / "good.npz")
    data = good.read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="cut"):
        load_billboards(tmp_path / "cut.npz")
    # A member declaring a huge shape is refused before it is inflated.
    buf = io.BytesIO()
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(buf, "w") as dst:
        for item in src.namelist():
            if item != "centres.npy":
                dst.writestr(item, src.read(item))
        huge = io.BytesIO()
        np.lib.format.write_array_header_1_0(huge, {"descr": "<f4", "fortran_order": False,
                                                    "shape": (1 << 30, 3)})  # fmt: skip
        dst.writestr("centres.npy", huge.getvalue())
    (tmp_path / "huge.npz").write_bytes(buf.getvalue())
    with pytest.raises(ValueError, match="huge.npz: array .centres. has unacceptable shape"):
        load_billboards(tmp_path / "huge.npz")
    doc = json.loads(json.dumps(c.to_dict()))
    doc["box"][0] = 10_000
    (tmp_path / "badbox.json").write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="badbox"):
        load_billboards(tmp_path / "badbox.json")


def rewrite_npz(src, dst, change) -> None:
    with zipfile.ZipFile(src) as zs:
        members = {n: zs.read(n) for n in zs.namelist()}
    arrays = {n[:-4]: np.load(io.BytesIO(b)) for n, b in members.items()}
    change(arrays)
    with open(dst, "wb") as fh:
        np.savez(fh, **arrays)


def test_corrupt_weather_files(tmp_path, small_weather_args) -> None:
    _, layer = small_weather_args
    w = Weather(((-100, -100), (100, 100)), [layer], cv=0.0, seed=3)
    for _ in range(5):
        w.step(1.0)
    path = w.save(tmp_path / "w.npz")
    with pytest.raises(FileNotFoundError):
        load_weather(tmp_path / "none.npz")
    with pytest.raises(ValueError, match="path"):
        w.save(tmp_path / "w.json")
    data = path.read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) - 40])
    (tmp_path / "junk.npz").write_bytes(b"\x00" * 100)
    seed_box_cloud(presets.cumulus(), 0).save(tmp_path / "cloud.npz")

    def meta_change(fn):
        def change(arrays):
            meta = json.loads(arrays["meta"].tobytes())
            fn(meta)
            arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), np.uint8)

        return change

    cases = {
        "events.npz": meta_change(lambda m: m["layers"][0].update(events=0)),
        "count.npz": meta_change(lambda m: m["layers"][0].update(n=3)),
        "version.npz": meta_change(lambda m: m.update(version=99)),
        "config.npz": meta_change(lambda m: m["config"]["layers"][0].update(wind="east")),
        "quota.npz": meta_change(lambda m: m["layers"][0].update(quota=-1.0)),
        "variant.npz": lambda a: a.update(layer0_variant=a["layer0_variant"] + 50),
        "dtype.npz": lambda a: a.update(layer0_x0=a["layer0_x0"].astype(np.float32)),
        "missing.npz": lambda a: a.pop("layer0_t0"),
        "nan.npz": lambda a: a.update(layer0_z0=a["layer0_z0"] * np.nan),
    }
    for name, change in cases.items():
        rewrite_npz(path, tmp_path / name, change)
    for name in ("cut.npz", "junk.npz", "cloud.npz", *cases):
        with pytest.raises(ValueError, match=name.replace(".", r"\.")):
            load_weather(tmp_path / name)
    ok = load_weather(path)
    assert ok.t == w.t
