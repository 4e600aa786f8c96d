"""What the volume files cost: writing and reading each format, and their sizes.

The default cumulus (``gaussian_cumulus(seed=1)``, noise seed 7) sampled by
``cumuli.density_volume`` on a 128-voxel lattice (its longest edge; 48 with ``--quick``) is
written with ``cumuli.write_volume`` and read back with ``cumuli.read_volume`` in every format
(``.vdb``, ``.vol``, and ``.nc`` / ``.zarr`` where xarray is installed). Each file's size is
compared with the dense float32 field's (the ``.vdb`` stores only the 8³ leaves the cloud
touches). Writes ``interchange.json`` and ``interchange.png`` under ``benchmarks/out/`` (or
``--out``).
"""

from __future__ import annotations

import importlib.util
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402

import cumuli as cu  # noqa: E402


def _size(path: Path) -> int:
    if path.is_dir():
        return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())
    return path.stat().st_size


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    quick = args.quick
    repeats = 2 if quick else 5
    edge = 48 if quick else 128
    field = cu.density_volume(cu.gaussian_cumulus(seed=1), cu.Noise(seed=7), resolution=edge)
    dense = field.values.nbytes
    formats = [".vdb", ".vol"]
    if importlib.util.find_spec("xarray") is not None:
        formats += [".nc", ".zarr"]
    common.log(f"field {field.values.shape[::-1]} ({dense / 2**20:.1f} MiB dense), {formats}")
    results = {}
    folder = Path(tempfile.mkdtemp())
    try:
        for ext in formats:
            path = folder / f"cloud{ext}"
            write = common.time_repeats(lambda p=path: cu.write_volume(p, field), repeats)[0]
            read = common.time_repeats(lambda p=path: cu.read_volume(p), repeats)[0]
            exact = bool(np.array_equal(cu.read_volume(path).density, field.values))
            size = _size(path)
            results[ext] = {
                "write_seconds": common.spread(write),
                "read_seconds": common.spread(read),
                "bytes": size,
                "size_over_dense": size / dense,
                "bit_exact": exact,
            }
            w_ms = 1e3 * results[ext]["write_seconds"]["median"]
            r_ms = 1e3 * results[ext]["read_seconds"]["median"]
            common.log(f"{ext}: write {w_ms:.1f} ms, read {r_ms:.1f} ms, {size / 2**20:.2f} MiB "
                       f"({size / dense:.2f} of dense), exact {exact}")  # fmt: skip
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    occupied = float((field.values != 0).mean())
    data = {
        "benchmark": "interchange",
        "quick": quick,
        "machine": common.machine_info(),
        "lattice": list(field.values.shape[::-1]),
        "dense_bytes": dense,
        "non_zero_fraction": occupied,
        "formats": results,
        "targets": {
            "round_trip_bit_exact": common.target(
                1, float(all(r["bit_exact"] for r in results.values())), ">="
            ),
        },
    }
    common.write_json(args.out / "interchange.json", data)
    plt = common.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.5), constrained_layout=True)
    names = list(results)
    x = np.arange(len(names))
    axes[0].bar(x - 0.2, [results[n]["write_seconds"]["median"] for n in names], 0.4, label="write")
    axes[0].bar(x + 0.2, [results[n]["read_seconds"]["median"] for n in names], 0.4, label="read")
    axes[0].set_xticks(x, names)
    axes[0].set_ylabel("seconds (median)")
    axes[0].legend()
    axes[1].bar(names, [results[n]["size_over_dense"] for n in names])
    axes[1].set_ylabel("file size / dense float32")
    fig.suptitle(f"volume files, lattice {tuple(field.values.shape[::-1])}")
    fig.savefig(args.out / "interchange.png", dpi=100)
    return 0


if __name__ == "__main__":
    sys.exit(main())
