"""Cloud values: transforms, merge, save/load round trips and malformed files."""

from __future__ import annotations

import json
import os
import struct
import zipfile
from pathlib import Path

import numpy as np
import pytest

import cumuli
from cumuli import Cloud


def _fields(c: Cloud) -> dict:
    return {k: v.copy() if isinstance(v, np.ndarray) else v for k, v in vars(c).items()}


def test_translated_moves_centres_only_and_leaves_the_original() -> None:
    c = cumuli.gaussian_cumulus(seed=1)
    before = _fields(c)
    t = c.translated((1.0, -2.0, 3.5))
    np.testing.assert_allclose(t.centres, c.centres + [1.0, -2.0, 3.5], atol=1e-5)
    assert np.array_equal(t.radii, c.radii) and np.array_equal(t.rotations, c.rotations)
    assert all(np.array_equal(before[k], v) for k, v in vars(c).items())  # the original unchanged
    assert t.params["transforms"] == [{"translate": [1.0, -2.0, 3.5]}]
    assert "transforms" not in c.params


def test_scaled_about_point_and_default_centre() -> None:
    c = cumuli.gaussian_cumulus(seed=2)
    s = c.scaled(2.0, about=(0, 0, 0))
    np.testing.assert_allclose(s.centres, 2 * c.centres, rtol=1e-6)
    np.testing.assert_allclose(s.radii, 2 * c.radii, rtol=1e-6)
    s2 = c.scaled(0.5)
    np.testing.assert_allclose(s2.centre, c.centre, atol=1e-4)
    lo, hi = c.bbox
    lo2, hi2 = s2.bbox
    np.testing.assert_allclose(hi2 - lo2, (hi - lo) / 2, rtol=1e-5)
    for bad in (0, -1, float("nan")):
        with pytest.raises(ValueError, match="factor"):
            c.scaled(bad)


def test_merge_concatenates_and_checks_models() -> None:
    a = cumuli.gaussian_cumulus(seed=1)
    b = cumuli.gaussian_cumulus(seed=2, centre=(30, 0, 0))
    m = cumuli.merge([a, b])
    assert m.n == a.n + b.n
    assert np.array_equal(m.centres[: a.n], a.centres)
    assert m.params["generator"] == "merge" and len(m.params["parts"]) == 2
    assert a.merged(b).n == m.n
    with pytest.raises(ValueError, match="model"):
        cumuli.merge([a, cumuli.metaball_cumulus()])
    assert cumuli.merge([a.with_model("metaball"), cumuli.metaball_cumulus()]).model == "metaball"
    with pytest.raises(ValueError, match="empty"):
        cumuli.merge([])
    with pytest.raises(TypeError, match="Cloud"):
        cumuli.merge([a, "b"])


def test_with_model_any_cloud() -> None:
    c = cumuli.gaussian_cumulus(seed=0)
    m = c.with_model("metaball", phi=0.4)
    assert m.model == "metaball" and m.phi == 0.4 and c.model == "spheroid"
    with pytest.raises(ValueError, match="model"):
        c.with_model("voxels")


@pytest.mark.parametrize("ext", [".npz", ".json"])
def test_save_load_round_trip(tmp_path: Path, ext: str) -> None:
    c = cumuli.gaussian_cumulus(seed=5, centre=(1, 2, 3)).translated((0, 1, 0))
    path = c.save(tmp_path / f"cloud{ext}")
    assert path.exists() and not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    d = cumuli.load_cloud(path)
    assert np.array_equal(d.centres, c.centres)
    assert np.array_equal(d.radii, c.radii)
    assert np.array_equal(d.rotations, c.rotations)
    assert (d.model, d.kappa, d.phi) == (c.model, c.kappa, c.phi)
    assert d.stats == c.stats and d.params == c.params
    # The params rebuild the same cloud.
    args = d.params["args"]
    again = cumuli.gaussian_cumulus(**args)
    again = again.translated(d.params["transforms"][0]["translate"])
    assert np.array_equal(again.centres, d.centres)


def test_save_rejects_bad_paths_without_partial_files(tmp_path: Path) -> None:
    c = cumuli.gaussian_cumulus(seed=0)
    with pytest.raises(ValueError, match="npz or .json"):
        c.save(tmp_path / "cloud.txt")
    with pytest.raises(FileNotFoundError):
        c.save(tmp_path / "missing" / "cloud.npz")
    c.params["bad"] = object()
    with pytest.raises(TypeError, match="JSON"):
        c.save(tmp_path / "cloud.json")
    assert list(tmp_path.iterdir()) == []


def test_load_errors(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        cumuli.load_cloud(tmp_path / "nope.npz")
    empty = tmp_path / "empty.json"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match="empty"):
        cumuli.load_cloud(empty)
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(os.urandom(300))
    with pytest.raises(ValueError, match="garbage.npz"):
        cumuli.load_cloud(garbage)
    bad_json = tmp_path / "bad.json"
    bad_json.write_text('{"format": "cumuli.cloud", "version": 1, "centres": [[0, 0')
    with pytest.raises(ValueError, match="bad.json"):
        cumuli.load_cloud(bad_json)
    foreign = tmp_path / "foreign.json"
    foreign.write_text(json.dumps({"hello": 1}))
    with pytest.raises(ValueError, match="format"):
        cumuli.load_cloud(foreign)


def test_load_rejects_truncated_and_inconsistent(tmp_path: Path) -> None:
    c = cumuli.gaussian_cumulus(seed=3)
    good = c.save(tmp_path / "c.npz")
    data = good.read_bytes()
    cut = tmp_path / "cut.npz"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="cut.npz"):
        cumuli.load_cloud(cut)
    # Negative radii inside an otherwise valid file.
    doc = json.loads(c.save(tmp_path / "c.json").read_text())
    doc["radii"][0][0] = -1.0
    neg = tmp_path / "neg.json"
    neg.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="radii"):
        cumuli.load_cloud(neg)
    # An npz member declaring an enormous shape is refused before allocating.
    huge = tmp_path / "huge.npz"
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(huge, "w") as dst:
        for name in src.namelist():
            body = src.read(name)
            if name == "centres.npy":
                header = "{'descr': '<f4', 'fortran_order': False, 'shape': (4000000000, 3), }"
                header = header.ljust(117) + "\n"
                body = b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header.encode()
            dst.writestr(name, body)
    with pytest.raises(ValueError, match="centres"):
        cumuli.load_cloud(huge)


def test_bbox_of_rotated_ellipsoids_is_tight() -> None:
    # Surface points x = c + R·(r ⊙ u), u on the unit sphere: the box must hold every one of them
    # and be touched by them (the analytic half extent is reached at some u).
    rng = np.random.default_rng(8)
    n = 5
    q, _ = np.linalg.qr(rng.normal(size=(n, 3, 3)))
    rotations = (q * np.sign(np.linalg.det(q))[:, None, None]).astype(np.float32)
    radii = rng.uniform(0.5, 4.0, (n, 3)).astype(np.float32)
    centres = rng.uniform(-10, 10, (n, 3)).astype(np.float32)
    cloud = Cloud(centres, radii, rotations=rotations)
    u = rng.normal(size=(200_000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    pts = centres[:, None] + np.einsum("nkj,nmj->nmk", rotations, radii[:, None] * u[None])
    lo, hi = cloud.bbox
    flat = pts.reshape(-1, 3)
    assert (flat >= lo - 1e-4).all() and (flat <= hi + 1e-4).all()
    np.testing.assert_allclose(flat.min(axis=0), lo, atol=2e-2)
    np.testing.assert_allclose(flat.max(axis=0), hi, atol=2e-2)


# --- cloud files ------------------------------------------------------------------------------
def _npz_with(tmp_path: Path, name: str, patch) -> Path:
    path = tmp_path / name
    cumuli.gaussian_cumulus(n=6, seed=1).save(path)
    data = bytearray(path.read_bytes())
    patch(data)
    path.write_bytes(bytes(data))
    return path


def _set_all_headers(data: bytearray, offset_in_header: int, value: int, fmt: str) -> None:
    """Patch a field of every local (PK\\3\\4) and central (PK\\1\\2) zip header."""
    for sig, field in ((b"PK\x03\x04", offset_in_header), (b"PK\x01\x02", offset_in_header + 2)):
        start = 0
        while (at := data.find(sig, start)) >= 0:
            struct.pack_into(fmt, data, at + field, value)
            start = at + 4


@pytest.mark.parametrize(
    "corrupt",
    [
        "method",  # an unsupported compression method: zipfile raises NotImplementedError
        "encrypted",  # the encryption flag: zipfile raises RuntimeError (password required)
        "magic",  # a member that is not .npy: numpy raises a ValueError without the file name
    ],
)
@pytest.mark.parametrize("loader", ["cloud", "grid"])
def test_corrupt_npz_files_raise_value_error_naming_the_file(
    tmp_path: Path, corrupt: str, loader: str
) -> None:
    path = tmp_path / f"bad-{corrupt}.npz"
    if loader == "cloud":
        cumuli.gaussian_cumulus(n=6, seed=1).save(path)
    else:
        cloud, noise = cumuli.gaussian_cumulus(n=6, seed=1), cumuli.Noise(seed=1, size=8)
        cumuli.light_grid(cloud, cumuli.Sun(), noise, resolution=4).save(path)
    data = bytearray(path.read_bytes())
    if corrupt == "method":
        _set_all_headers(data, 8, 97, "<H")  # compression method field
    elif corrupt == "encrypted":
        _set_all_headers(data, 6, 1, "<H")  # general-purpose flags: bit 0 = encrypted
    else:
        with zipfile.ZipFile(path, "w") as zf:
            for member in ("centres", "radii", "rotations", "meta", "values"):
                zf.writestr(member + ".npy", b"NOTNUMPY" + b"\0" * 120)
        data = bytearray(path.read_bytes())
    path.write_bytes(bytes(data))
    load = cumuli.load_cloud if loader == "cloud" else cumuli.load_light_grid
    with pytest.raises(ValueError, match=path.name):
        load(path)
