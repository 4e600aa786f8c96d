"""Reference images of the physical mode's scene, rendered by Mitsuba 3 (``pip install
cumuli[reference]``): rerun with ``python tests/references/mitsuba_reference.py``.

The scene (:func:`reference_scene`) is the default cumulus (``gaussian_cumulus(seed=1)``, noise
seed 7) under a sun 35° above the horizon from the side (+x) and the default sky, seen from −z
at 160×120. Mitsuba gets the same medium: ``cumuli.density_volume`` (the extinction field
``σt = extinction_scale·ρ`` on a texel-centre lattice of 0.1-unit voxels, Mitsuba's
``gridvolume`` over the same box), albedo ϖ and Henyey–Greenstein ``g`` from the settings, the sun
as a ``directional`` emitter (its ``direction`` is the way light travels, ``−Sun.direction``;
``irradiance = Sun.radiance``) and ``Sky.radiance`` as a lat-long ``envmap``. Four images:

- ``physical_ms.exr``: ``volpath`` with every scattering order (``max_depth = rr_depth = 512``:
  Russian roulette gives fireflies in this thick medium);
- ``physical_ms_sun.exr``: the same with the sun alone (the sky's share is the difference, light
  being additive);
- ``physical_ss.exr``: one scattering event (``max_depth = 2``), sun and sky;
- ``physical_transmittance.exr``: ``T`` along the camera rays (albedo 0 under a uniform
  environment of radiance 1).

Each is rendered in chunks with their own seeds into two independent halves; the script stops
when the halves' relative difference ``|A − B|/(A + B)`` (the noise of their mean) has a median
below ``--noise`` over the cloud-covered 4×4 blocks (block alpha ≥ 0.5), and writes the mean of
both halves with a JSON record (samples, seconds, measured noise). Partial sums are kept under
``--work`` so that an interrupted run resumes.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import cumuli as cu
from cumuli.interchange.mitsuba import sky_environment

HERE = Path(__file__).resolve().parent
WIDTH, HEIGHT = 160, 120
#: Voxel edge of the density volume handed to Mitsuba (world units).
VOXEL = 0.1
#: Blocks whose mean alpha reaches this are "cloud-covered" (the comparison's blocks).
COVERED = 0.5
BLOCK = 4
FILES = {
    "ms": "physical_ms.exr",
    "ms_sun": "physical_ms_sun.exr",
    "ss": "physical_ss.exr",
    "transmittance": "physical_transmittance.exr",
}


def reference_scene() -> tuple[cu.Scene, cu.Camera]:
    """The compared scene: default cumulus, sun 35° up from +x, default sky, physical settings."""
    elevation = math.radians(35.0)
    sun = cu.Sun(
        direction=(math.cos(elevation), math.sin(elevation), 0.0),
        colour=(1.0, 0.97, 0.92),
        intensity=6.0,
    )
    scene = cu.Scene(
        clouds=[cu.gaussian_cumulus(seed=1)],
        sun=sun,
        sky=cu.Sky(),
        # The references were rendered from the table noise: pinned, whatever the default.
        noise=cu.Noise(seed=7, version=1),
        # No air: Mitsuba's scene has none (aerial perspective and aureole off).
        settings=cu.RenderSettings(
            lighting="physical", phase="hg", haze=0.0, resolve=False, air_extinction=0.0
        ),
    )
    camera = cu.Camera(position=(0.0, 2.0, -45.0), target=(0.0, 1.0, 0.0), fov=38.0)
    return scene, camera


def blocks(img: np.ndarray, size: int = BLOCK) -> np.ndarray:
    """Means of ``size``×``size`` pixel blocks of an ``(H, W, ...)`` image."""
    h, w = img.shape[0] // size * size, img.shape[1] // size * size
    shape = (h // size, size, w // size, size, *img.shape[2:])
    return img[:h, :w].reshape(shape).mean(axis=(1, 3))


def covered_blocks(transmittance: np.ndarray) -> np.ndarray:
    """The cloud-covered blocks: block mean of ``1 − T`` at least :data:`COVERED`."""
    return blocks(1.0 - transmittance) >= COVERED


def environment(scene: cu.Scene, width: int = 1024) -> np.ndarray:
    """``Sky.radiance`` as Mitsuba's lat-long envmap (``cumuli.interchange.mitsuba``)."""
    return sky_environment(scene, width)


def mitsuba_scene(kind: str, scene: cu.Scene, camera: cu.Camera, field, spp: int, seed: int):
    """The scene of one image, from ``cu.to_mitsuba``: every order (``ms``), the sun alone
    (``ms_sun``), one scattering event (``ss``) or the transmittance (albedo 0 under a constant
    environment of radiance 1)."""
    import mitsuba as mi

    depth = {"ms": 512, "ms_sun": 512, "ss": 2, "transmittance": 1}[kind]
    transmittance = kind == "transmittance"
    return mi.load_dict(cu.to_mitsuba(
        scene, camera, WIDTH, HEIGHT, spp=spp, seed=seed, max_depth=depth, rr_depth=512,
        sun=not transmittance, sky=1.0 if transmittance else kind != "ms_sun",
        albedo=0.0 if transmittance else None, fields=[field],
    ))  # fmt: skip


def half_noise(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    """Median over ``mask`` blocks of ``|A − B|/(A + B)``: the relative noise of their mean."""
    ba, bb = blocks(a.mean(-1)), blocks(b.mean(-1))
    rel = np.abs(ba - bb) / np.maximum(ba + bb, 1e-12)
    return float(np.median(rel[mask]))


def render_kind(kind: str, args: argparse.Namespace, field, mask: np.ndarray | None) -> dict:
    import mitsuba as mi

    scene, camera = reference_scene()
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    state_path = work / f"{kind}.npz"
    sums = [np.zeros((HEIGHT, WIDTH, 3)), np.zeros((HEIGHT, WIDTH, 3))]
    counts, seconds, chunk_index = [0, 0], 0.0, 0
    if state_path.exists():
        st = np.load(state_path)
        sums = [st["a"], st["b"]]
        counts = [int(st["na"]), int(st["nb"])]
        seconds, chunk_index = float(st["seconds"]), int(st["chunks"])
    chunk = {"ss": 4 * args.chunk, "transmittance": 4 * args.chunk}.get(kind, args.chunk)
    limit = {"ss": 8 * args.max_spp, "transmittance": 2 * args.max_spp}.get(kind, args.max_spp)
    noise = math.inf
    while True:
        if min(counts) > 0:
            noise = (
                half_noise(sums[0] / counts[0], sums[1] / counts[1], mask)
                if mask is not None
                else 0.0
            )
            done = kind == "transmittance" and sum(counts) >= args.transmittance_spp
            print(f"{kind}: {sum(counts)} spp, {seconds:.0f} s, noise {noise:.4f}", flush=True)
            if done or (kind != "transmittance" and noise < args.noise) or sum(counts) >= limit:
                break
        t0 = time.time()
        img = np.asarray(mi.render(mitsuba_scene(kind, scene, camera, field, chunk, chunk_index)))
        seconds += time.time() - t0
        half = chunk_index % 2
        sums[half] += img[..., :3] * chunk
        counts[half] += chunk
        chunk_index += 1
        np.savez(state_path, a=sums[0], b=sums[1], na=counts[0], nb=counts[1], seconds=seconds,
                 chunks=chunk_index)  # fmt: skip
    mean = (sums[0] + sums[1]) / sum(counts)
    rgba = np.concatenate([mean, np.ones((HEIGHT, WIDTH, 1))], -1).astype(np.float32)
    cu.write_image(HERE / FILES[kind], rgba)
    return {"spp": sum(counts), "halves_spp": counts, "seconds": round(seconds, 1),
            "noise_median_block": noise, "file": FILES[kind]}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kinds", default="transmittance,ss,ms,ms_sun")
    parser.add_argument("--noise", type=float, default=0.025, help="target median block noise")
    parser.add_argument("--chunk", type=int, default=32, help="spp per multiple-scattering chunk")
    parser.add_argument("--max-spp", type=int, default=2048)
    parser.add_argument("--transmittance-spp", type=int, default=512)
    parser.add_argument("--variant", default="scalar_rgb")
    parser.add_argument("--work", default=str(HERE / "_work"))
    args = parser.parse_args(argv)
    import mitsuba as mi

    mi.set_variant(args.variant)
    scene, camera = reference_scene()
    lo, hi = scene.clouds[0].layer_box()
    edge = int(math.ceil(float(np.max(hi - lo)) / VOXEL))
    t0 = time.time()
    field = cu.density_volume(scene.clouds[0], scene.noise, scene.settings, edge)
    print(f"density volume {field.values.shape[::-1]} in {time.time() - t0:.1f} s", flush=True)
    record_path = HERE / "physical_reference.json"
    record = json.loads(record_path.read_text()) if record_path.exists() else {}
    record.update({
        "mitsuba": mi.__version__, "variant": args.variant, "size": [WIDTH, HEIGHT],
        "density_volume": list(field.values.shape[::-1]), "voxel": VOXEL, "box": field.box,
        "scene": scene.to_dict() | {"clouds": "gaussian_cumulus(seed=1)"},
        "camera": camera.to_dict(), "noise_target": args.noise,
    })  # fmt: skip
    mask = None
    t_path = HERE / FILES["transmittance"]
    for kind in args.kinds.split(","):
        if kind != "transmittance" and mask is None:
            mask = covered_blocks(cu.read_image(t_path)[..., 0])
        record[kind] = render_kind(kind, args, field, mask)
        record_path.write_text(json.dumps(record, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
