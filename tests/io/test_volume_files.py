"""Volume files: cumuli → file → cumuli for every format, the errors, what is read renders in
both lighting modes and both backends, and OpenVDB itself (Debian's ``python3-openvdb``, run by
the system Python) reads what cumuli writes and writes what cumuli reads."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.io import volumes as files

FORMATS = [".vdb", ".vol", ".nc", ".zarr"]
SYSTEM_PYTHON = "/usr/bin/python3"


def _field() -> tuple[np.ndarray, tuple]:
    rng = np.random.default_rng(3)
    values = np.zeros((11, 17, 23), np.float32)
    values[2:9, 3:15, 1:20] = rng.random((7, 12, 19), dtype=np.float32) * 2
    return values, ((-1.0, 0.5, 2.0), (3.6, 2.2, 4.5))


def _has_openvdb() -> bool:
    if not Path(SYSTEM_PYTHON).exists():
        return False
    return (
        subprocess.run([SYSTEM_PYTHON, "-c", "import pyopenvdb"], capture_output=True).returncode
        == 0
    )


needs_openvdb = pytest.mark.skipif(
    not _has_openvdb(), reason="OpenVDB's Python module (Debian python3-openvdb) is not installed"
)


@pytest.mark.parametrize("ext", FORMATS)
def test_a_field_round_trips_bit_exact(tmp_path: Path, ext: str) -> None:
    values, box = _field()
    path = cu.write_volume(tmp_path / f"f{ext}", cu.ExtinctionField(values, box))
    back = cu.read_volume(path)
    assert back.density.dtype == np.float32 and np.array_equal(back.density, values)
    assert np.allclose(back.box, box, rtol=0, atol=1e-6) and back.sigma_t == 1.0
    if ext != ".vol":  # .vol has no attributes
        assert back.params["units"] == "extinction coefficient per world unit"
        assert back.params["cumuli_version"] == cu.__version__


@pytest.mark.parametrize("ext", FORMATS)
def test_a_volume_cloud_keeps_its_medium(tmp_path: Path, ext: str) -> None:
    values, box = _field()
    vol = cu.VolumeCloud(density=values, box=box, sigma_t=2.5, albedo=0.8, g=0.4)
    back = cu.read_volume(cu.write_volume(tmp_path / f"v{ext}", vol))
    assert np.array_equal(back.density, values * np.float32(2.5))
    if ext != ".vol":
        assert (back.albedo, back.g) == (0.8, 0.4)
        assert back.params["extinction_scale"] == 2.5


def test_every_kind_with_a_density_can_be_written(tmp_path: Path) -> None:
    cloud = cu.gaussian_cumulus(seed=1)
    noise = cu.Noise(seed=7)
    written = cu.read_volume(cu.write_volume(tmp_path / "c.vdb", cloud, noise, resolution=24))
    field = cu.density_volume(cloud, noise, resolution=24)
    assert np.array_equal(written.density, field.values)
    assert written.params["generator"] == "gaussian_cumulus" and written.params["kind"] == "cloud"
    parts = cu.particle_cumulus(seed=2)
    p = cu.read_volume(cu.write_volume(tmp_path / "p.vol", parts, resolution=12))
    assert np.array_equal(p.density, parts.to_volume(12)[0])
    deck = cu.CloudDeck(base=20.0, top=30.0, extent=(-60.0, -60.0, 60.0, 60.0), coverage=0.6,
                        sigma_t=0.8, map_size=32, resolution=(32, 6, 32), seed=2)  # fmt: skip
    dv = cu.read_volume(cu.write_volume(tmp_path / "d.zarr", deck))
    assert np.array_equal(dv.density, cu.density_volume(deck, resolution=None).values)
    assert dv.params["kind"] == "deck" and dv.params["extinction_scale"] == 0.8
    bill = cu.seed_box_cloud(cu.seedbox_presets.cumulus(), 4)
    b = cu.read_volume(cu.write_volume(tmp_path / "b.nc", bill, resolution=16))
    assert b.density.max() > 0 and b.params["kind"] == "billboards"


def test_bad_input_is_refused_and_leaves_no_file(tmp_path: Path) -> None:
    values, box = _field()
    with pytest.raises(ValueError, match="unknown volume file extension"):
        cu.write_volume(tmp_path / "f.xyz", (values, box))
    with pytest.raises(ValueError, match="unknown volume file extension"):
        cu.read_volume(tmp_path / "f.raw")
    with pytest.raises(OSError, match="no volume file"):
        cu.read_volume(tmp_path / "missing.vdb")
    bad = values.copy()
    bad[0, 0, 0] = np.nan
    for ext in FORMATS:
        with pytest.raises(ValueError, match="NaN"):
            cu.write_volume(tmp_path / f"nan{ext}", (bad, box))
    with pytest.raises(TypeError, match="float numpy array"):
        cu.write_volume(tmp_path / "i.vol", (values.astype(np.int32), box))
    with pytest.raises(ValueError, match="3-D"):
        cu.write_volume(tmp_path / "s.vol", (values[0], box))
    with pytest.raises(TypeError, match="drawable with a density"):
        cu.write_volume(tmp_path / "x.vdb", "cloud")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.parametrize("ext", [".vdb", ".vol"])
def test_malformed_files_raise_value_error(tmp_path: Path, ext: str) -> None:
    values, box = _field()
    good = cu.write_volume(tmp_path / f"g{ext}", (values, box)).read_bytes()
    for name, raw in {"head": b"NOPE" + good[4:], "cut": good[: len(good) // 2]}.items():
        path = tmp_path / f"{name}{ext}"
        path.write_bytes(raw)
        with pytest.raises(ValueError):
            cu.read_volume(path)


def test_an_existing_file_survives_a_failed_write(tmp_path: Path) -> None:
    values, box = _field()
    path = cu.write_volume(tmp_path / "keep.vdb", (values, box))
    before = path.read_bytes()
    with pytest.raises(ValueError):
        cu.write_volume(path, (-values - 1, box))
    assert path.read_bytes() == before and [p.name for p in tmp_path.iterdir()] == ["keep.vdb"]


def test_the_vdb_is_sparse(tmp_path: Path) -> None:
    values = np.zeros((64, 64, 64), np.float32)
    values[:8, :8, :8] = 1.0
    small = cu.write_volume(tmp_path / "s.vdb", (values, ((0, 0, 0), (1, 1, 1)))).stat().st_size
    assert small < 64**3 * 4 / 50  # one 8³ leaf and two internal nodes, not 64³ floats


@pytest.mark.parametrize("lighting", ["paper", "physical"])
@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_what_is_read_renders(tmp_path: Path, lighting: str, backend: str) -> None:
    values, box = _field()
    vol = cu.read_volume(cu.write_volume(tmp_path / "r.vdb", (values, box)))
    settings = cu.RenderSettings(lighting=lighting, physical_resolution=12)
    scene = cu.Scene(clouds=[vol], settings=settings)
    cam = cu.Camera(position=(1.3, 1.4, -6.0), target=(1.3, 1.4, 3.2), fov=40.0)
    img = cu.render(scene, cam, 24, 18, backend=backend)
    sky = cu.render(cu.Scene(clouds=[], settings=settings), cam, 24, 18, backend="cpu")
    assert np.isfinite(img).all()
    assert np.abs(img[..., :3] - sky[..., :3]).max() > 0.05  # the cloud shows


@needs_openvdb
def test_openvdb_reads_what_cumuli_writes(tmp_path: Path) -> None:
    values, box = _field()
    path = cu.write_volume(tmp_path / "c.vdb", (values, box), attrs={"seed": 11})
    script = f"""
import json, numpy as np, pyopenvdb as vdb
g = vdb.read({str(path)!r}, "density")
a = np.zeros({values.shape[::-1]}, np.float32)
g.copyToArray(a, ijk=(0, 0, 0))
np.save({str(tmp_path / "a.npy")!r}, a)
print(json.dumps({{"class": str(g.gridClass), "active": g.activeVoxelCount(), "seed": g["seed"],
    "w0": g.transform.indexToWorld((0, 0, 0)), "w1": g.transform.indexToWorld((1, 1, 1))}}))
"""
    out = json.loads(subprocess.run([SYSTEM_PYTHON, "-c", script], capture_output=True, text=True,
                                    check=True).stdout)  # fmt: skip
    assert np.array_equal(np.load(tmp_path / "a.npy").transpose(2, 1, 0), values)
    assert out["active"] == int((values != 0).sum()) and out["seed"] == 11
    assert out["class"] in ("fog volume", "FOG_VOLUME")
    voxel = (np.asarray(box[1]) - box[0]) / values.shape[::-1]
    assert np.allclose(out["w0"], np.asarray(box[0]) + voxel / 2)
    assert np.allclose(np.subtract(out["w1"], out["w0"]), voxel)


@needs_openvdb
@pytest.mark.parametrize("half", [False, True])
def test_cumuli_reads_and_renders_what_openvdb_writes(tmp_path: Path, half: bool) -> None:
    rng = np.random.default_rng(5)
    a = np.zeros((30, 20, 18), np.float32)  # [x, y, z]
    a[3:27, 2:18, 4:16] = rng.random((24, 16, 12), dtype=np.float32)
    a[8:24, 8:16, 0:8] = 0.75  # constant blocks: OpenVDB may keep them as tiles
    np.save(tmp_path / "a.npy", a)
    script = f"""
import numpy as np, pyopenvdb as vdb
g = vdb.FloatGrid()
g.copyFromArray(np.load({str(tmp_path / "a.npy")!r}), ijk=(-5, 3, 7))
g.name = "density"
g.transform = vdb.createLinearTransform([[0.5, 0, 0, 0], [0, 0.25, 0, 0], [0, 0, 0.1, 0],
                                         [1, 2, 3, 1]])
g.saveFloatAsHalf = {half}
other = vdb.FloatGrid()
other.name = "temperature"
other.fill((0, 0, 0), (9, 9, 9), 3.0)
vdb.write({str(tmp_path / "o.vdb")!r}, grids=[other, g])
"""
    subprocess.run([SYSTEM_PYTHON, "-c", script], check=True, capture_output=True)
    vol = cu.read_volume(tmp_path / "o.vdb")
    nz = np.argwhere(a != 0)
    lo, hi = nz.min(0), nz.max(0) + 1
    ref = a[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]].transpose(2, 1, 0)
    assert vol.density.shape == ref.shape
    assert np.allclose(vol.density, ref, atol=1e-3 if half else 0.0, rtol=0)
    ijk0 = lo + (-5, 3, 7)
    assert np.allclose(vol.box[0], (1, 2, 3) + (ijk0 - 0.5) * (0.5, 0.25, 0.1))
    cam = cu.Camera(position=(3.0, 5.0, -8.0), target=(3.0, 5.0, 4.0), fov=45.0)
    img = cu.render(cu.Scene(clouds=[vol]), cam, 16, 12, backend="cpu")
    assert np.isfinite(img).all() and img[..., 3].min() >= 0


def test_optional_packages_are_not_needed_to_import_cumuli() -> None:
    code = (
        "import sys; import cumuli; "
        "print([m for m in ('xarray', 'zarr', 'h5netcdf', 'mitsuba', 'bpy') if m in sys.modules])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "[]", out.stderr


def test_the_format_table_names_every_extension() -> None:
    assert set(files.FORMATS) == set(FORMATS)
    with pytest.raises(ValueError):
        files.format_of("a.vdb2")
