"""Mitsuba 3 opens what cumuli writes: a ``.vol`` from ``cu.write_volume`` loads as Mitsuba's
``VolumeGrid`` and renders in a ``gridvolume`` medium; a ``.vol`` Mitsuba writes reads into
cumuli; ``cu.to_mitsuba`` gives a scene Mitsuba loads and renders (tiny images, few samples)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import cumuli as cu

mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 (pip install mitsuba) is not installed")
mi.set_variant("scalar_rgb")

BOX = ((-2.0, -1.0, -1.5), (2.0, 1.0, 1.5))


def _values() -> np.ndarray:
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in (12, 8, 16)), indexing="ij")
    return np.clip(1.2 - (x * x + y * y + z * z), 0, None).astype(np.float32) * 3


def test_mitsuba_loads_the_vol_cumuli_writes_and_renders_it(tmp_path: Path) -> None:
    values = _values()
    path = cu.write_volume(tmp_path / "c.vol", (values, BOX))
    grid = mi.VolumeGrid(str(path))
    assert tuple(grid.size()) == values.shape[::-1] and grid.channel_count() == 1
    assert np.array_equal(np.asarray(grid).reshape(values.shape), values)
    lo, hi = (np.asarray(b) for b in BOX)
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": 1},
        "env": {"type": "constant", "radiance": {"type": "rgb", "value": [1, 1, 1]}},
        "box": {
            "type": "cube", "bsdf": {"type": "null"},
            "to_world": mi.ScalarTransform4f().translate(((lo + hi) / 2).tolist())
                                              .scale(((hi - lo) / 2).tolist()),
            "interior": {"type": "heterogeneous", "albedo": 0.0, "sigma_t": {
                "type": "gridvolume", "filename": str(path),
                "to_world": mi.ScalarTransform4f().translate(lo.tolist()).scale((hi - lo).tolist()),
            }},
        },
        "sensor": {"type": "perspective", "fov": 40.0, "to_world": mi.ScalarTransform4f().look_at(
            origin=[0, 0, -8], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": 32, "height": 24, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": 4}},
    })  # fmt: skip
    img = np.asarray(mi.render(scene))[..., 0]
    # the transmittance along the central ray: exp(-∫σt) through the middle of the grid
    assert img[0, 0] == pytest.approx(1.0, abs=1e-4)
    assert img[12, 16] < 0.2 and 0.3 < img.mean() < 0.95


def test_cumuli_reads_the_vol_mitsuba_writes(tmp_path: Path) -> None:
    values = _values()
    mi.VolumeGrid(values[..., None]).write(str(tmp_path / "m.vol"))
    back = cu.read_volume(tmp_path / "m.vol")
    assert np.array_equal(back.density, values)


def test_to_mitsuba_renders_a_cumuli_scene(tmp_path: Path) -> None:
    vol = cu.read_volume(cu.write_volume(tmp_path / "v.vdb", (_values(), BOX)))
    scene = cu.Scene(clouds=[vol], settings=cu.RenderSettings(lighting="physical"))
    camera = cu.Camera(position=(0.0, 0.5, -9.0), target=(0.0, 0.0, 0.0), fov=35.0)
    spec = cu.to_mitsuba(scene, camera, 24, 18, spp=4, max_depth=4, env_width=64)
    assert {"sun", "sky", "medium_0", "sensor", "integrator"} <= spec.keys()
    assert spec["medium_0"]["interior"]["albedo"] == vol.albedo
    img = np.asarray(mi.render(mi.load_dict(spec)))
    assert img.shape == (18, 24, 3) and np.isfinite(img).all() and img.mean() > 0
    t_spec = cu.to_mitsuba(scene, camera, 24, 18, spp=4, max_depth=1, sun=False, sky=1.0,
                           albedo=0.0)  # fmt: skip
    t = np.asarray(mi.render(mi.load_dict(t_spec)))[..., 0]
    ours = cu.render(scene, camera, 24, 18, backend="cpu")[..., 3]
    assert np.abs((1 - t) - ours).mean() < 0.05  # the same medium: cumuli's alpha is 1 − T
    with pytest.raises(TypeError, match="Camera"):
        cu.to_mitsuba(scene, "camera")
