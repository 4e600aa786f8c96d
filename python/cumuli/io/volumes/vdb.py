"""OpenVDB files (``.vdb``), written and read in Python from the documented file format.

What is written: file format 224 (OpenVDB 6 and later read it), one ``FloatGrid`` named
``density`` (tree ``Tree_float_5_4_3``: root → 32³ internal → 16³ internal → 8³ leaves), no
compression but OpenVDB's active-mask one (only active values are stored, the inactive ones
being the background), full float32. Only leaves holding a non-zero voxel are stored (the grid
is sparse where the cloud is empty); a voxel is active where its value is non-zero, the
background is 0.
The index-to-world transform is an ``AffineMap``: voxel ``(i, j, k)`` (x, y, z) sits at
``lo + (ijk + ½)·voxel``, the texel-centre convention of :mod:`cumuli.io.volumes`. Grid
metadata carries the attributes plus ``class = "fog volume"`` and the dense extent
(``cumuli_box_min``, ``cumuli_box_max``, ``cumuli_shape``) so that the file reads back exactly.

What is read: the first float grid named ``density`` (else the first float grid) of a file of
format 222 or later, with or without active-mask, zip or blosc compression (blosc needs
``numcodecs`` or ``blosc``), full or half float, tiles included; its transform must be an
axis-aligned scale and translation. A grid without cumuli's extent metadata is read over the
bounding box of its active voxels and tiles.
"""

from __future__ import annotations

import struct
import uuid
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from cumuli._util.atomic import atomic_target
from cumuli.io.volumes.data import VolumeData

MAGIC = 0x56444220
FILE_VERSION = 224
#: Oldest file format read: per-node mask compression (OpenVDB 3.0, 2014).
MIN_FILE_VERSION = 222
TREE_TYPE = "Tree_float_5_4_3"
HALF_SUFFIX = "_HalfFloat"
GRID_NAME = "density"
# Node log2 sizes: leaf 3, lower internal 4, upper internal 5 (total 3, 7, 12).
LOG2 = (5, 4, 3)
TOTAL = (12, 7, 3)
COMPRESS_ZIP, COMPRESS_ACTIVE_MASK, COMPRESS_BLOSC = 0x1, 0x2, 0x4
NO_MASK_OR_INACTIVE_VALS, NO_MASK_AND_ALL_VALS = 0, 6


# --- writing ---------------------------------------------------------------------------------
def _string(s: str) -> bytes:
    b = s.encode("utf-8")
    return struct.pack("<I", len(b)) + b


def _meta_value(value: Any) -> tuple[str, bytes]:
    if isinstance(value, bool):
        return "bool", struct.pack("<?", value)
    if isinstance(value, (int, np.integer)):
        return "int64", struct.pack("<q", int(value))
    if isinstance(value, (float, np.floating)):
        return "double", struct.pack("<d", float(value))
    if isinstance(value, str):
        return "string", value.encode("utf-8")
    arr = np.asarray(value)
    if arr.shape == (3,) and arr.dtype.kind in "iu":
        return "vec3i", arr.astype("<i4").tobytes()
    if arr.shape == (3,) and arr.dtype.kind == "f":
        return "vec3d", arr.astype("<f8").tobytes()
    raise TypeError(f"metadata value {value!r} has no OpenVDB metadata type")


def _metamap(meta: dict[str, Any]) -> bytes:
    out = [struct.pack("<i", len(meta))]
    for name, value in meta.items():
        type_name, raw = _meta_value(value)
        out += [_string(name), _string(type_name), struct.pack("<I", len(raw)), raw]
    return b"".join(out)


def _mask_bytes(bits: np.ndarray) -> bytes:
    return np.packbits(bits.astype(bool), bitorder="little").tobytes()


def _leaf_blocks(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Leaf origins ``(n, 3)`` (x, y, z) and their 512 values in OpenVDB's order (z fastest)
    for the 8³ blocks holding a non-zero voxel."""
    d, h, w = values.shape
    pad = [(-n) % 8 for n in (w, h, d)]
    a = np.pad(values.transpose(2, 1, 0), [(0, pad[0]), (0, pad[1]), (0, pad[2])])
    wb, hb, db = (s // 8 for s in a.shape)
    blocks = a.reshape(wb, 8, hb, 8, db, 8).transpose(0, 2, 4, 1, 3, 5).reshape(-1, 512)
    keep = np.flatnonzero((blocks != 0).any(axis=1))
    ijk = np.stack(np.unravel_index(keep, (wb, hb, db)), -1) * 8
    return ijk.astype(np.int64), np.ascontiguousarray(blocks[keep], dtype="<f4")


def _child_index(origin: np.ndarray, level: int) -> np.ndarray:
    """Index of a child's origin inside its parent at ``level`` (0: upper, 1: lower)."""
    dim = 1 << TOTAL[level]
    shift, log2 = TOTAL[level + 1], LOG2[level]
    i = ((origin & (dim - 1)) >> shift).astype(np.int64)
    return (i[:, 0] << (2 * log2)) + (i[:, 1] << log2) + i[:, 2]


def _internal_topology(level: int, child_bits: np.ndarray) -> bytes:
    no_tiles = bytes((1 << (3 * LOG2[level])) // 8)
    return _mask_bytes(child_bits) + no_tiles + bytes([NO_MASK_OR_INACTIVE_VALS])


def _tree(values: np.ndarray) -> tuple[bytes, bytes]:
    """(topology, buffers) of the sparse float tree of ``values`` (``[z, y, x]``)."""
    origins, leaves = _leaf_blocks(values)
    keys = [origins >> TOTAL[0], origins >> TOTAL[1]]
    order = np.lexsort((_child_index(origins, 1), _child_index(origins, 0),
                        keys[0][:, 2], keys[0][:, 1], keys[0][:, 0]))  # fmt: skip
    origins, leaves = origins[order], leaves[order]
    upper = origins >> TOTAL[0]
    lower = origins >> TOTAL[1]
    topo = [struct.pack("<f", 0.0)]
    roots = np.unique(upper, axis=0) if len(origins) else np.zeros((0, 3), np.int64)
    topo.append(struct.pack("<II", 0, len(roots)))
    for root in roots:
        in_root = np.flatnonzero((upper == root).all(axis=1))
        lowers = np.unique(lower[in_root], axis=0)
        lower_origins = lowers << TOTAL[1]
        bits = np.zeros(1 << (3 * LOG2[0]), bool)
        bits[_child_index(lower_origins, 0)] = True
        topo.append(struct.pack("<3i", *(int(v) for v in root << TOTAL[0])))
        topo.append(_internal_topology(0, bits))
        # children in index order = the lexsort order above
        for lo in lowers[np.argsort(_child_index(lower_origins, 0), kind="stable")]:
            in_lower = in_root[(lower[in_root] == lo).all(axis=1)]
            bits = np.zeros(1 << (3 * LOG2[1]), bool)
            bits[_child_index(origins[in_lower], 1)] = True
            topo.append(_internal_topology(1, bits))
            topo += [_mask_bytes(leaves[i] != 0) for i in in_lower]
    head = bytes([NO_MASK_OR_INACTIVE_VALS])
    buffers = [_mask_bytes(leaf != 0) + head + leaf[leaf != 0].tobytes() for leaf in leaves]
    return b"".join(topo), b"".join(buffers)


def _affine(box: tuple, shape_xyz: tuple[int, int, int]) -> bytes:
    lo, hi = (np.asarray(b, np.float64) for b in box)
    voxel = (hi - lo) / np.asarray(shape_xyz, np.float64)
    m = np.diag([*voxel, 1.0])
    m[3, :3] = lo + 0.5 * voxel
    return _string("AffineMap") + m.astype("<f8").tobytes()


def encode(data: VolumeData) -> bytes:
    """The bytes of a ``.vdb`` file holding ``data`` (see the module docstring)."""
    values = data.values
    shape_xyz = tuple(int(s) for s in values.shape[::-1])
    meta = {str(k): v for k, v in data.attrs.items()}
    meta.update({
        "class": "fog volume", "name": GRID_NAME, "is_saved_as_half_float": False,
        "cumuli_box_min": np.asarray(data.box[0], np.float64),
        "cumuli_box_max": np.asarray(data.box[1], np.float64),
        "cumuli_shape": np.asarray(shape_xyz, np.int32),
    })  # fmt: skip
    topology, buffers = _tree(values)
    head = b"".join([
        struct.pack("<qIII?", MAGIC, FILE_VERSION, 10, 0, True),
        str(uuid.uuid4()).encode("ascii"), _metamap({"creator": "cumuli"}),
        struct.pack("<i", 1),
        _string(GRID_NAME), _string(TREE_TYPE), _string(""),
    ])  # fmt: skip
    grid = b"".join([
        struct.pack("<I", COMPRESS_ACTIVE_MASK), _metamap(meta), _affine(data.box, shape_xyz),  # type: ignore[arg-type]
        struct.pack("<i", 1), topology,
    ])  # fmt: skip
    grid_pos = len(head) + 24
    block_pos = grid_pos + len(grid)
    end_pos = block_pos + len(buffers)
    return head + struct.pack("<qqq", grid_pos, block_pos, end_pos) + grid + buffers


def write(path: Path, data: VolumeData) -> None:
    """Write ``data`` as an OpenVDB file (atomically)."""
    raw = encode(data)
    with atomic_target(path) as tmp:
        tmp.write_bytes(raw)


# --- reading ---------------------------------------------------------------------------------
class _Reader:
    """A cursor over a file's bytes that raises ``ValueError`` where they end too soon."""

    def __init__(self, raw: bytes, path: Path) -> None:
        self.raw, self.pos, self.path = raw, 0, path

    def take(self, n: int) -> bytes:
        if n < 0 or self.pos + n > len(self.raw):
            raise ValueError(
                f"{self.path}: truncated or malformed OpenVDB file (at byte {self.pos})"
            )
        out = self.raw[self.pos : self.pos + n]
        self.pos += n
        return out

    def unpack(self, fmt: str) -> tuple:
        return struct.unpack("<" + fmt, self.take(struct.calcsize("<" + fmt)))

    def string(self) -> str:
        (n,) = self.unpack("I")
        return self.take(n).decode("utf-8", "replace")

    def array(self, dtype: str, count: int) -> np.ndarray:
        return np.frombuffer(self.take(np.dtype(dtype).itemsize * count), dtype)

    def mask(self, bits: int) -> np.ndarray:
        return np.unpackbits(self.array("u1", bits // 8), bitorder="little").astype(bool)


_META_TYPES = {"bool": "?", "int32": "i", "int64": "q", "float": "f", "double": "d",
               "vec3i": "3i", "vec3s": "3f", "vec3d": "3d"}  # fmt: skip


def _read_metamap(r: _Reader) -> dict[str, Any]:
    (count,) = r.unpack("i")
    if count < 0:
        raise ValueError(f"{r.path}: malformed OpenVDB metadata count {count}")
    meta: dict[str, Any] = {}
    for _ in range(count):
        name, type_name = r.string(), r.string()
        (size,) = r.unpack("I")
        raw = r.take(size)
        fmt = _META_TYPES.get(type_name)
        if type_name == "string":
            meta[name] = raw.decode("utf-8", "replace")
        elif fmt is not None and struct.calcsize("<" + fmt) == size:
            value = struct.unpack("<" + fmt, raw)
            meta[name] = value[0] if len(value) == 1 else tuple(value)
    return meta


def _read_transform(r: _Reader) -> tuple[np.ndarray, np.ndarray]:
    """(voxel size, world position of index 0) of an axis-aligned map."""
    kind = r.string()
    if kind == "AffineMap":
        m = r.array("<f8", 16).reshape(4, 4)
        if np.abs(m[:3, :3] - np.diag(np.diag(m[:3, :3]))).max() > 0:
            raise ValueError(f"{r.path}: rotated or sheared OpenVDB transforms are not supported")
        return np.diag(m[:3, :3]).copy(), m[3, :3].copy()
    vecs = {"ScaleMap": 5, "UniformScaleMap": 5, "ScaleTranslateMap": 6,
            "UniformScaleTranslateMap": 6, "TranslationMap": 1}.get(kind)  # fmt: skip
    if vecs is None:
        raise ValueError(f"{r.path}: OpenVDB transform {kind!r} is not supported")
    v = r.array("<f8", 3 * vecs).reshape(vecs, 3)
    if kind == "TranslationMap":
        return np.ones(3), v[0].copy()
    if vecs == 5:
        return v[0].copy(), np.zeros(3)
    return v[1].copy(), v[0].copy()


def _read_data(r: _Reader, count: int, compression: int, dtype: str) -> np.ndarray:
    size = np.dtype(dtype).itemsize * count
    if count == 0 and dtype == "<f2":  # OpenVDB's half writer writes nothing for no values
        return np.zeros(0, dtype)
    if not compression & (COMPRESS_ZIP | COMPRESS_BLOSC):
        return r.array(dtype, count)
    (nbytes,) = r.unpack("q")
    if nbytes <= 0:
        raw = r.take(-nbytes)
    elif size == 0:  # an empty block (no active values): nothing to decompress
        r.take(nbytes)
        raw = b""
    elif compression & COMPRESS_BLOSC:
        raw = _blosc_decompress(r.take(nbytes), r.path)
    else:
        raw = zlib.decompress(r.take(nbytes))
    if len(raw) != size:
        raise ValueError(f"{r.path}: a compressed OpenVDB block has {len(raw)} bytes, not {size}")
    return np.frombuffer(raw, dtype)


def _blosc_decompress(raw: bytes, path: Path) -> bytes:
    try:
        from numcodecs import blosc  # type: ignore[import-not-found]
    except ImportError:
        try:
            import blosc  # type: ignore[import-not-found,no-redef]
        except ImportError:
            raise OSError(
                f"{path} is blosc-compressed: install numcodecs (pip install cumuli[xarray]) "
                "or blosc to read it"
            ) from None
    return bytes(blosc.decompress(raw))


def _compressed_values(
    r: _Reader, count: int, active: np.ndarray, compression: int, dtype: str, background: float
) -> np.ndarray:
    """A node's ``count`` values (OpenVDB's per-node mask compression); inactive values are
    the background."""
    (meta,) = r.unpack("B")
    if meta > NO_MASK_AND_ALL_VALS:
        raise ValueError(f"{r.path}: malformed OpenVDB node (compression metadata {meta})")
    if meta in (2, 4, 5):
        r.array(dtype, 2 if meta == 5 else 1)
    if meta in (3, 4, 5):
        r.mask(count)
    if compression & COMPRESS_ACTIVE_MASK and meta != NO_MASK_AND_ALL_VALS:
        got = _read_data(r, int(active.sum()), compression, dtype)
        out = np.full(count, background, np.float32)
        out[active] = got
        return out
    out = _read_data(r, count, compression, dtype).astype(np.float32)
    return np.where(active, out, np.float32(background))


class _Tree:
    def __init__(self) -> None:
        self.leaves: list[tuple[np.ndarray, np.ndarray]] = []  # (origin, active mask)
        self.tiles: list[tuple[np.ndarray, int, float]] = []  # (origin, edge, value)


def _read_internal(r: _Reader, level: int, origin: np.ndarray, tree: _Tree, ctx: tuple) -> None:
    compression, dtype, background = ctx
    n = 1 << (3 * LOG2[level])
    children, active = r.mask(n), r.mask(n)
    values = _compressed_values(r, n, active, compression, dtype, background)
    log2, shift = LOG2[level], TOTAL[level + 1]
    idx = np.arange(n)
    offs = np.stack([idx >> (2 * log2), (idx >> log2) & ((1 << log2) - 1),
                     idx & ((1 << log2) - 1)], -1) << shift  # fmt: skip
    for i in np.flatnonzero(active & ~children):
        tree.tiles.append((origin + offs[i], 1 << shift, float(values[i])))
    for i in np.flatnonzero(children):
        if level == 0:
            _read_internal(r, 1, origin + offs[i], tree, ctx)
        else:
            tree.leaves.append((origin + offs[i], r.mask(512)))


def _read_grid(r: _Reader, half: bool) -> tuple[dict[str, Any], np.ndarray, np.ndarray, Any]:
    (compression,) = r.unpack("I")
    meta = _read_metamap(r)
    voxel, origin0 = _read_transform(r)
    (buffers,) = r.unpack("i")
    if buffers != 1:
        raise ValueError(f"{r.path}: OpenVDB trees with {buffers} buffers are not supported")
    dtype = "<f2" if half else "<f4"
    (background,) = r.unpack("f")
    tiles, children = r.unpack("II")
    tree = _Tree()
    ctx = (compression, dtype, background)
    for _ in range(tiles):
        x, y, z, value, on = r.unpack("3if?")
        if on:
            tree.tiles.append((np.array([x, y, z]), 1 << TOTAL[0], value))
    for _ in range(children):
        _read_internal(r, 0, np.array(r.unpack("3i"), np.int64), tree, ctx)
    blocks = []
    for leaf_origin, _topo in tree.leaves:
        mask = r.mask(512)
        tree.leaves[len(blocks)] = (leaf_origin, mask)
        blocks.append((leaf_origin, _compressed_values(r, 512, mask, compression, dtype,
                                                       background)))  # fmt: skip
    return meta, voxel, origin0, (tree, blocks, background)


def _dense(meta: dict[str, Any], voxel: np.ndarray, origin0: np.ndarray, parts: Any) -> tuple:
    tree, blocks, background = parts
    if {"cumuli_box_min", "cumuli_box_max", "cumuli_shape"} <= meta.keys():
        lo_ijk = np.zeros(3, np.int64)
        shape = np.asarray(meta["cumuli_shape"], np.int64)
        box = (tuple(meta["cumuli_box_min"]), tuple(meta["cumuli_box_max"]))
    else:
        starts, ends = [], []
        for (o, mask), _vals in zip(tree.leaves, blocks, strict=True):
            if mask.any():
                ijk = np.argwhere(mask.reshape(8, 8, 8))
                starts.append(o + ijk.min(axis=0))
                ends.append(o + ijk.max(axis=0) + 1)
        starts += [o for o, _, _ in tree.tiles]
        ends += [o + e for o, e, _ in tree.tiles]
        if not starts:
            raise ValueError("the OpenVDB grid is empty (no active voxels or tiles)")
        lo_ijk = np.min(starts, axis=0)
        shape = np.max(ends, axis=0) - lo_ijk
        lo = origin0 + (lo_ijk - 0.5) * voxel
        box = (tuple(map(float, lo)), tuple(map(float, lo + shape * voxel)))
    if np.prod(shape) > 1 << 30:
        raise ValueError(f"the OpenVDB grid's extent {tuple(shape)} exceeds 2^30 voxels")
    dense = np.full(tuple(shape[::-1]), background, np.float32)  # [z, y, x]
    for o, e, value in tree.tiles:
        a, b = np.maximum(o - lo_ijk, 0), np.minimum(o + e - lo_ijk, shape)
        if (b > a).all():
            dense[a[2] : b[2], a[1] : b[1], a[0] : b[0]] = value
    for o, vals in blocks:
        block = vals.reshape(8, 8, 8).transpose(2, 1, 0)
        a = o - lo_ijk
        b = np.minimum(a + 8, shape)
        c = np.maximum(a, 0)
        if (b > c).all():
            s = c - a
            dense[c[2] : b[2], c[1] : b[1], c[0] : b[0]] = block[
                s[2] : s[2] + b[2] - c[2], s[1] : s[1] + b[1] - c[1], s[0] : s[0] + b[0] - c[0]
            ]
    return dense, box


def decode(raw: bytes, path: Path) -> VolumeData:
    """The ``density`` float grid (else the first float grid) of an OpenVDB file's bytes."""
    r = _Reader(raw, path)
    magic, version = r.unpack("qI")
    if magic != MAGIC:
        raise ValueError(f"{path} is not an OpenVDB file (bad magic number)")
    if version < MIN_FILE_VERSION:
        raise ValueError(f"{path}: OpenVDB file format {version} is older than {MIN_FILE_VERSION}")
    r.unpack("II?")
    r.take(36)
    _read_metamap(r)
    (count,) = r.unpack("i")
    chosen = None
    for _ in range(count):
        name, type_name, _parent = r.string(), r.string(), r.string()
        grid_pos, _block_pos, end_pos = r.unpack("qqq")
        base = type_name.removesuffix(HALF_SUFFIX)
        if base == TREE_TYPE and (chosen is None or name.split("\x1e")[0] == GRID_NAME):
            if chosen is None or chosen[0].split("\x1e")[0] != GRID_NAME:
                chosen = (name, type_name.endswith(HALF_SUFFIX), grid_pos)
        r.pos = end_pos
    if chosen is None:
        raise ValueError(f"{path} holds no float grid")
    r.pos = chosen[2]
    meta, voxel, origin0, parts = _read_grid(r, chosen[1])
    if (voxel <= 0).any():
        raise ValueError(f"{path}: the grid's voxel size {tuple(voxel)} is not positive")
    dense, box = _dense(meta, voxel, origin0, parts)
    skip = {"class", "name", "is_saved_as_half_float", "cumuli_box_min", "cumuli_box_max",
            "cumuli_shape", "file_bbox_min", "file_bbox_max", "file_mem_bytes",
            "file_voxel_count", "file_compression", "file_delayed_load"}  # fmt: skip
    attrs = {k: v for k, v in meta.items() if k not in skip}
    return VolumeData(dense, box, attrs)


def read(path: Path) -> VolumeData:
    """Read an OpenVDB file's density grid (see the module docstring)."""
    return decode(Path(path).read_bytes(), Path(path))
