"""Render the reference views' Mitsuba descriptions (``mitsuba_views.py export``) with Mitsuba 3.

Needs only ``mitsuba`` and ``numpy`` (no cumuli), so that it runs on any machine Mitsuba runs
on — a GPU (``--variant cuda_ad_rgb``) renders every view in minutes where ``scalar_rgb`` takes
hours. For each ``<view>.npz`` of ``--specs`` it writes ``<view>.npz`` into ``--out`` with:

- ``T``: the transmittance along the camera rays (albedo 0 under a constant environment of
  radiance 1, one bounce), ``--t-spp`` samples;
- ``ms``: every scattering order under the sun and the sky (``volpath``,
  ``max_depth = rr_depth = 512``), rendered in chunks of ``--chunk`` samples with their own
  seeds into two independent halves until the halves' relative difference ``|A − B|/(A + B)``
  (the noise of their mean) has a median below ``--noise`` over the cloud-covered 4×4 blocks,
  or ``--max-spp``/``--budget`` seconds are reached;
- ``ladder``: independent images at 1, 2, 4, … ``--ladder-max`` samples (Mitsuba's error
  against its own converged image at each count, for ``benchmarks/bench_fidelity.py``).

With ``--ladder-only`` it renders only ladder images, at ``--ladder-min`` … ``--ladder-max``
samples (each with the seed a whole run gives that count), into ``<view>.ladder.npz``:
``mitsuba_views.py ladder`` adds their errors to a committed reference's ladder.

Each output is rewritten after every pair of chunks (atomically) with the halves' sums, and a
rerun resumes from it: an interrupted run keeps what it rendered.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

BLOCK, COVERED = 4, 0.5


def build(mi, spec, kind: str, spp: int, max_depth: int = 512) -> object:
    """The Mitsuba scene of one image of a description: ``ms`` or ``T`` (``max_depth`` the
    path's vertices for ``ms``: 2 is single scattering)."""
    lo, hi = spec["box"][0], spec["box"][1]
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    cam = spec["camera"]
    width, height = (int(v) for v in spec["size"])
    transmittance = kind == "T"
    phase = ",".join(f"{v:.8g}" for v in spec["phase"])
    # The phase's forward cone goes straight on (δ-M): σt' = σt(1 − f·ϖ), ϖ' = ϖ(1 − f)/(1 − f·ϖ).
    f, albedo = float(spec.get("peak_share", 0.0)), float(spec["albedo"])
    scale = 1.0 if transmittance else 1.0 - f * albedo
    albedo = 0.0 if transmittance else albedo * (1.0 - f) / (1.0 - f * albedo)
    grid = mi.VolumeGrid(np.ascontiguousarray(spec["sigma_t"][..., None], np.float32))
    scene = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": 1 if transmittance else int(max_depth),
                       "rr_depth": 512},
        "medium_0": {
            "type": "cube",
            "bsdf": {"type": "null"},
            "to_world": mi.ScalarTransform4f().translate(centre.tolist()).scale(half.tolist()),
            "interior": {
                "type": "heterogeneous",
                "albedo": albedo,
                "phase": {"type": "tabphase", "values": phase},
                "sigma_t": {
                    "type": "gridvolume",
                    "grid": grid,
                    "to_world": mi.ScalarTransform4f().translate(lo.tolist())
                    .scale((hi - lo).tolist()),
                },
                "scale": scale,
            },
        },
        "sensor": {
            "type": "perspective",
            "fov": float(cam[9]),
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=cam[0:3].tolist(), target=cam[3:6].tolist(), up=cam[6:9].tolist()
            ),
            "film": {"type": "hdrfilm", "width": width, "height": height,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": int(spp)},
        },
    }  # fmt: skip
    if transmittance:
        scene["sky"] = {"type": "constant", "radiance": {"type": "rgb", "value": [1.0] * 3}}
    else:
        scene["sun"] = {
            "type": "directional",
            "direction": (-spec["sun_direction"]).tolist(),
            "irradiance": {"type": "rgb", "value": spec["sun_radiance"].tolist()},
        }
        scene["sky"] = {"type": "envmap", "bitmap": mi.Bitmap(spec["environment"])}
    return mi.load_dict(scene)


def blocks(img: np.ndarray) -> np.ndarray:
    h, w = img.shape[0] // BLOCK * BLOCK, img.shape[1] // BLOCK * BLOCK
    shape = (h // BLOCK, BLOCK, w // BLOCK, BLOCK, *img.shape[2:])
    return img[:h, :w].reshape(shape).mean(axis=(1, 3))


def half_noise(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    """Median over ``mask`` blocks of ``|A − B|/(A + B)``: the relative noise of their mean."""
    ba, bb = blocks(a.mean(-1)), blocks(b.mean(-1))
    rel = np.abs(ba - bb) / np.maximum(ba + bb, 1e-12)
    return float(np.median(rel[mask]))


def render(mi, scene, spp: int, seed: int) -> np.ndarray:
    return np.asarray(mi.render(scene, spp=spp, seed=seed), np.float64)[..., :3]


def save(path: Path, **arrays) -> None:
    tmp = path.with_name(path.stem + ".tmp.npz")
    np.savez(tmp, **arrays)
    os.replace(tmp, path)


def ladder_seed(spp: int) -> int:
    """The seed of the ladder image at ``spp`` (a power of two) samples."""
    return 10_000 + int(np.log2(spp))


def render_ladder(mi, spec_path: Path, out: Path, args: argparse.Namespace) -> None:
    """Only the ladder images at ``--ladder-min`` … ``--ladder-max`` samples, into
    ``<view>.ladder.npz`` (with the seconds each took)."""
    spec = dict(np.load(spec_path))
    spec["sigma_t"] = np.load(spec_path.with_name(str(spec["field"])))["sigma_t"]
    name = spec_path.stem
    counts = [2**i for i in range(int(np.log2(args.ladder_min)), int(np.log2(args.ladder_max)) + 1)]
    scene = build(mi, spec, "ms", counts[0])
    images, seconds = [], []
    for n in counts:
        t0 = time.time()
        images.append(render(mi, scene, n, ladder_seed(n)))
        seconds.append(time.time() - t0)
        print(f"{name}: ladder {n} spp in {seconds[-1]:.1f} s", flush=True)
    save(out / f"{name}.ladder.npz", ladder=np.stack(images).astype(np.float32),
         ladder_spp=np.array(counts), seconds=np.array(seconds), variant=mi.variant(),
         mitsuba=mi.__version__)  # fmt: skip


def render_view(mi, spec_path: Path, out: Path, args: argparse.Namespace) -> None:
    spec = dict(np.load(spec_path))
    spec["sigma_t"] = np.load(spec_path.with_name(str(spec["field"])))["sigma_t"]
    name = spec_path.stem
    t0 = time.time()
    scene_t = build(mi, spec, "T", args.t_spp)
    t_img = render(mi, scene_t, args.t_spp, 50_000)[..., 0]
    mask = blocks(1.0 - t_img) >= COVERED
    print(f"{name}: T {args.t_spp} spp in {time.time() - t0:.1f} s, {mask.sum()} blocks",
          flush=True)  # fmt: skip
    scene = build(mi, spec, "ms", args.chunk)
    ladder_spp = [2**i for i in range(int(np.log2(args.ladder_max)) + 1)]
    done = out / f"{name}.npz"
    if done.exists():  # resume the halves of an interrupted run
        st = np.load(done)
        ladder, sums = list(st["ladder"]), [st["a"], st["b"]]
        counts, seconds, k = [int(st["na"]), int(st["nb"])], float(st["seconds"]), int(st["k"])
    else:
        ladder = [render(mi, scene, n, ladder_seed(n)) for n in ladder_spp]
        sums = [np.zeros_like(ladder[0]), np.zeros_like(ladder[0])]
        counts, seconds, k = [0, 0], 0.0, 0
    noise = np.inf
    while True:
        t1 = time.time()
        img = render(mi, scene, args.chunk, k)
        seconds += time.time() - t1
        sums[k % 2] += img * args.chunk
        counts[k % 2] += args.chunk
        k += 1
        if min(counts) == 0:
            continue
        noise = half_noise(sums[0] / counts[0], sums[1] / counts[1], mask)
        print(f"{name}: {sum(counts)} spp, {seconds:.1f} s, noise {noise:.4f}", flush=True)
        if counts[0] == counts[1]:  # write a balanced state
            save(out / f"{name}.npz", ms=(sums[0] + sums[1]) / sum(counts), T=t_img,
                 ladder=np.stack(ladder).astype(np.float32), ladder_spp=np.array(ladder_spp),
                 spp=sum(counts),
                 seconds=seconds, noise=noise, t_spp=args.t_spp, variant=mi.variant(),
                 mitsuba=mi.__version__, a=sums[0], b=sums[1], na=counts[0], nb=counts[1],
                 k=k)  # fmt: skip
            if noise < args.noise or sum(counts) >= args.max_spp or seconds > args.budget:
                break


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--specs", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--views", default="")
    parser.add_argument("--variant", default="scalar_rgb")
    parser.add_argument("--noise", type=float, default=0.005)
    parser.add_argument("--chunk", type=int, default=256)
    parser.add_argument("--max-spp", type=int, default=16384)
    parser.add_argument("--t-spp", type=int, default=1024)
    parser.add_argument("--ladder-max", type=int, default=256)
    parser.add_argument("--ladder-min", type=int, default=1)
    parser.add_argument("--ladder-only", action="store_true", help="only the ladder images")
    parser.add_argument("--budget", type=float, default=120.0, help="seconds per view (ms)")
    args = parser.parse_args(argv)
    import mitsuba as mi

    try:
        mi.set_variant(args.variant)
    except Exception as exc:  # noqa: BLE001 - report and fall back
        print(f"variant {args.variant} unavailable ({exc}); scalar_rgb", flush=True)
        mi.set_variant("scalar_rgb")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    names = args.views.split(",") if args.views else None
    for spec_path in sorted(Path(args.specs).glob("[!f]*.npz")):
        if names is None or spec_path.stem in names:
            try:
                (render_ladder if args.ladder_only else render_view)(mi, spec_path, out, args)
            except Exception as exc:  # noqa: BLE001 - e.g. no OptiX for a GPU variant
                if mi.variant() == "scalar_rgb":
                    raise
                print(f"{mi.variant()} failed ({exc}); scalar_rgb from here", flush=True)
                mi.set_variant("scalar_rgb")
                (render_ladder if args.ladder_only else render_view)(mi, spec_path, out, args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
