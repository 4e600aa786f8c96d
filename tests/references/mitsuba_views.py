"""The reference views of the physical mode against Mitsuba 3: scenes, export and comparison.

Each view (:data:`VIEWS`) is a cumuli scene and camera at 160×120 in the physical mode with its
default phase function (the approximate Mie phase of 20 µm droplets) and no haze (Mitsuba has no
air). :func:`export_spec` turns one into a self-contained Mitsuba description (the extinction
field on a texel-centre lattice of :func:`voxel` units, the sky as a lat-long map, the sun,
the camera and the phase function tabulated from cumuli's own,
``cumuli.light.physical.phase_values``, its diffraction peak within 2.6° of straight on treated
as unscattered: :func:`phase_table`) that ``mitsuba_batch.py`` renders with Mitsuba alone, on
any machine. The committed result of a view is one RGBA EXR ``view_<name>.exr``: RGB the
multiple-scattering image (sun and sky, every order), alpha the coverage ``1 − T`` (``T``
rendered with albedo 0 under a constant environment of radiance 1); ``views.json`` records the
samples, the reference's own noise, Mitsuba's error at a ladder of sample counts and the voxel
edge of the field.

Regenerate (any machine with Mitsuba; a GPU makes it minutes)::

    python tests/references/mitsuba_views.py export --out specs/
    python tests/references/mitsuba_batch.py --specs specs/ --out renders/ --variant cuda_ad_rgb
    python tests/references/mitsuba_views.py collect --renders renders/

Longer ladders for committed references (Mitsuba's error at more samples, without rendering
the reference again)::

    python tests/references/mitsuba_batch.py --specs specs/ --out renders/ --ladder-only \
        --ladder-min 8 --ladder-max 32
    python tests/references/mitsuba_views.py ladder --renders renders/
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

import cumuli as cu
from cumuli.interchange.mitsuba import sky_environment
from cumuli.light.physical import phase_values

HERE = Path(__file__).resolve().parent
WIDTH, HEIGHT = 160, 120
#: Voxel edge of the extinction field handed to Mitsuba (world units).
VOXEL = 0.1
#: Views whose field needs finer voxels than :data:`VOXEL`: the metaball cumulus's sharp edges
#: and the L-system cloud's thin strands lose coverage (|ΔT|) on the 0.1-unit lattice.
VOXELS: dict[str, float] = {"metaball": 0.05, "lsystem": 0.04}
#: Blocks whose mean coverage reaches this are "cloud-covered" (the comparison's blocks).
COVERED = 0.5
BLOCK = 4
#: Nodes of the tabulated phase function, uniform in cos θ over [−1, 1] (Mitsuba's ``tabphase``).
PHASE_NODES = 40001
FOV = 38.0
#: The forward cone (cos θ, 2.6°) whose scattering the references treat as unscattered.
PEAK_COS = 0.999


def settings() -> cu.RenderSettings:
    """The compared settings: the physical default (Mie phase, resolve pass), no haze, no air
    (Mitsuba renders neither)."""
    return cu.RenderSettings(haze=0.0, air_extinction=0.0)


def _sun(elevation: float, azimuth: float, colour=(1.0, 0.97, 0.92), intensity=6.0) -> cu.Sun:
    """A sun ``elevation`` degrees up, ``azimuth`` degrees from +x towards +z."""
    e, a = math.radians(elevation), math.radians(azimuth)
    direction = (math.cos(e) * math.cos(a), math.sin(e), math.cos(e) * math.sin(a))
    return cu.Sun(direction=direction, colour=colour, intensity=intensity)


def _framed(cloud: cu.Cloud, fill: float = 0.95) -> cu.Camera:
    """A camera on −z looking at the cloud's box centre, far enough that the box fits."""
    lo, hi = (np.asarray(b, np.float64) for b in cloud.layer_box())
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    tv = math.tan(math.radians(FOV / 2))
    dist = fill * max(half[0] / (tv * WIDTH / HEIGHT), half[1] / tv) + half[2]
    pos = (float(centre[0]), float(centre[1] + 0.05 * dist), float(centre[2] - dist))
    return cu.Camera(position=pos, target=tuple(float(v) for v in centre), fov=FOV)


def _cumulus_camera() -> cu.Camera:
    return cu.Camera(position=(0.0, 2.0, -45.0), target=(0.0, 1.0, 0.0), fov=FOV)


def _scene(cloud: cu.Cloud, sun: cu.Sun) -> cu.Scene:
    return cu.Scene(
        clouds=[cloud], sun=sun, sky=cu.Sky(), noise=cu.Noise(7, version=1), settings=settings()
    )


def backlit() -> tuple[cu.Scene, cu.Camera]:
    """The default cumulus with the sun behind it, 20° up: about 10° beyond its top limb."""
    return _scene(cu.gaussian_cumulus(seed=1), _sun(20.0, 90.0)), _cumulus_camera()


def toplit() -> tuple[cu.Scene, cu.Camera]:
    """The default cumulus under a sun 80° up."""
    return _scene(cu.gaussian_cumulus(seed=1), _sun(80.0, 20.0)), _cumulus_camera()


def sunset() -> tuple[cu.Scene, cu.Camera]:
    """The default cumulus under a low, orange sun 4° up, from the side and slightly ahead."""
    sun = _sun(4.0, -30.0, colour=(1.0, 0.62, 0.36), intensity=5.0)
    return _scene(cu.gaussian_cumulus(seed=1), sun), _cumulus_camera()


def metaball() -> tuple[cu.Scene, cu.Camera]:
    """A dense metaball cumulus (the paper's model), side-lit by a sun 35° up."""
    cloud = cu.metaball_cumulus(seed=3)
    return _scene(cloud, _sun(35.0, 0.0)), _framed(cloud)


def lsystem() -> tuple[cu.Scene, cu.Camera]:
    """A thin L-system cloud (the paper's grammar), lit from the side and above (sun 50° up)."""
    cloud = cu.lsystem_cloud(seed=2)
    return _scene(cloud, _sun(50.0, -40.0)), _framed(cloud)


#: Name → (scene, camera) of every reference view (the side-lit HG view of
#: ``mitsuba_reference.py`` is the original one and is not repeated here).
VIEWS: dict[str, Callable[[], tuple[cu.Scene, cu.Camera]]] = {
    "backlit": backlit,
    "toplit": toplit,
    "sunset": sunset,
    "metaball": metaball,
    "lsystem": lsystem,
}
#: Views defined but without a committed reference (none today; a new view starts here).
EXTRA_VIEWS: dict[str, Callable[[], tuple[cu.Scene, cu.Camera]]] = {}


def voxel(name: str) -> float:
    """The voxel edge of view ``name``'s field in its Mitsuba description."""
    return VOXELS.get(name, VOXEL)


def view_file(name: str) -> Path:
    """The committed RGBA reference of a view (RGB radiance, alpha coverage ``1 − T``)."""
    return HERE / f"view_{name}.exr"


def blocks(img: np.ndarray, size: int = BLOCK) -> np.ndarray:
    """Means of ``size``×``size`` pixel blocks of an ``(H, W, ...)`` image."""
    h, w = img.shape[0] // size * size, img.shape[1] // size * size
    shape = (h // size, size, w // size, size, *img.shape[2:])
    return img[:h, :w].reshape(shape).mean(axis=(1, 3))


def block_errors(img: np.ndarray, ref: np.ndarray) -> dict[str, float]:
    """An RGBA image against an RGBA reference, on the reference's covered 4×4 blocks, with
    the tests' metric (``cumuli.testing.compare_images``: block means of the RGB mean): the
    signed ratio of the blocks' mean radiance − 1, the median and 90th percentile of the blocks'
    relative error, the mean |ΔT| of the blocks, and the same relative error pixel by pixel
    over the covered pixels (reported, not bounded: a reference is Monte Carlo noise pixel by
    pixel)."""
    mask = blocks(ref[..., 3]) >= COVERED
    la, lb = img[..., :3].mean(-1), ref[..., :3].mean(-1)
    a, b = blocks(la)[mask], blocks(lb)[mask]
    rel = np.abs(a / np.maximum(b, 1e-12) - 1.0)
    pmask = ref[..., 3] >= COVERED
    prel = np.abs(la[pmask] / np.maximum(lb[pmask], 1e-12) - 1.0)
    dt = np.abs(blocks(img[..., 3])[mask] - blocks(ref[..., 3])[mask])
    return {
        "blocks": int(mask.sum()),
        "mean_ratio": float(a.sum() / b.sum() - 1.0),
        "block_median": float(np.median(rel)),
        "block_p90": float(np.percentile(rel, 90)),
        "transmittance": float(dt.mean()),
        "pixel_median": float(np.median(prel)),
        "pixel_p90": float(np.percentile(prel, 90)),
    }


def phase_table(
    scene: cu.Scene, nodes: int = PHASE_NODES, keep_peak: bool = False
) -> tuple[np.ndarray, float]:
    """cumuli's phase function as Mitsuba's ``tabphase``, its forward peak treated as unscattered.

    Returns ``(table, f)``: ``nodes`` values uniform in cos θ over [−1, 1] (forward = +1), each
    the mean of the phase over its node's cell (so that the table integrates like the phase),
    with the cone ``cos θ ≥`` :data:`PEAK_COS` removed and the rest renormalised; ``f`` is the
    share of the scattered light in that cone. The medium then scatters ``(1 − f)·σs`` and the
    cone's share goes straight on (``σt' = σt(1 − f·ϖ)``, ``ϖ' = ϖ(1 − f)/(1 − f·ϖ)``; the
    δ-M similarity relation): the same light everywhere except within the cone's angle of the
    sun's direction, and none of the fireflies that the Mie phase's diffraction peak (a tenth of
    its light within 0.3°) gives a path tracer's sun connections. ``keep_peak``: the whole
    phase, its cone kept (``f`` is still its share): the medium as it is, for single scattering
    (whose sun connections never fall in the cone on these views)."""
    c = np.linspace(-1.0, 1.0, nodes)
    h = c[1] - c[0]
    lo, hi = np.maximum(c - h / 2, -1.0), np.minimum(c + h / 2, 1.0)
    out, whole = np.empty(nodes), np.empty(nodes)
    peak = c > PEAK_COS - 2 * h
    for cells, k in ((~peak, 16), (peak, 4096)):
        t = (np.arange(k) + 0.5) / k
        pts = lo[cells, None] + (hi - lo)[cells, None] * t[None, :]
        vals = phase_values(scene.settings, pts)
        out[cells] = np.where(pts < PEAK_COS, vals, 0.0).mean(axis=1)
        if keep_peak:
            whole[cells] = vals.mean(axis=1)
    f = 1.0 - 2 * np.pi * float(np.sum((out[1:] + out[:-1]) / 2 * h))
    return (whole if keep_peak else out / (1.0 - f)), f


def reference_field(name: str, scene: cu.Scene) -> cu.ExtinctionField:
    """The extinction field view ``name``'s Mitsuba description holds: its cloud voxelised on
    :func:`voxel` units over the cloud's layer box (the longest edge rounded up)."""
    cloud = scene.clouds[0]
    lo, hi = cloud.layer_box()
    edge = int(math.ceil(float(np.max(np.asarray(hi) - np.asarray(lo))) / voxel(name)))
    return cu.density_volume(cloud, scene.noise, scene.settings, edge)


def export_spec(name: str, path: Path) -> None:
    """Write view ``name`` as a Mitsuba-only description (``.npz``) for ``mitsuba_batch.py``."""
    scene, camera = (VIEWS | EXTRA_VIEWS)[name]()
    field = reference_field(name, scene)
    table, f = phase_table(scene)
    values = np.ascontiguousarray(field.values, np.float32)
    # Views of one cloud share its field: stored once, named by its content.
    key = hashlib.sha256(values.tobytes()).hexdigest()[:12]
    field_path = path.with_name(f"field_{key}.npz")
    if not field_path.exists():
        np.savez_compressed(field_path, sigma_t=values)
    np.savez_compressed(
        path,
        field=field_path.name,
        box=np.asarray(field.box, np.float64),
        albedo=float(scene.settings.albedo),
        phase=table,
        peak_share=f,
        sun_direction=np.asarray(scene.sun.direction, np.float64),
        sun_radiance=np.asarray(scene.sun.radiance, np.float64),
        environment=sky_environment(scene, 1024).astype(np.float32),
        camera=np.array([*camera.position, *camera.target, *camera.up, camera.fov], np.float64),
        size=np.array([WIDTH, HEIGHT]),
    )


def collect(renders: Path) -> dict:
    """Write each rendered view's RGBA EXR and ``views.json`` from ``mitsuba_batch.py``'s output."""
    record_path = HERE / "views.json"
    record = json.loads(record_path.read_text()) if record_path.exists() else {}
    for name in VIEWS | EXTRA_VIEWS:
        src = renders / f"{name}.npz"  # written by mitsuba_batch.py
        if not src.exists():
            continue
        r = np.load(src)
        rgba = np.concatenate([r["ms"], 1.0 - r["T"][..., None]], -1).astype(np.float32)
        cu.write_image(view_file(name), rgba, alpha="keep")
        ladder = {}
        for spp, img in zip(r["ladder_spp"], r["ladder"], strict=True):
            test = np.concatenate([img, rgba[..., 3:]], -1)
            ladder[int(spp)] = block_errors(test, rgba)
        scene, camera = (VIEWS | EXTRA_VIEWS)[name]()
        record[name] = {
            "doc": (VIEWS | EXTRA_VIEWS)[name].__doc__,
            "variant": str(r["variant"]),
            "mitsuba": str(r["mitsuba"]),
            "spp": int(r["spp"]),
            "seconds": float(r["seconds"]),
            "noise_median_block": float(r["noise"]),
            "transmittance_spp": int(r["t_spp"]),
            "voxel": voxel(name),
            "ladder": ladder,
            "phase_peak": {"cos": PEAK_COS, "share": phase_table(scene)[1]},
            "sun": {
                "direction": list(scene.sun.direction),
                "colour": list(scene.sun.colour),
                "intensity": scene.sun.intensity,
            },
            "camera": camera.to_dict(),
            "settings": scene.settings.to_dict(),
        }
    record_path.write_text(json.dumps(record, indent=1, default=float) + "\n")
    return record


def add_ladder(renders: Path) -> dict:
    """Add the errors of ``mitsuba_batch.py --ladder-only``'s images (``<view>.ladder.npz``)
    to the committed views' ladders in ``views.json`` (against the committed reference)."""
    record_path = HERE / "views.json"
    record = json.loads(record_path.read_text())
    for name in record:
        src = renders / f"{name}.ladder.npz"
        if not src.exists() or not view_file(name).exists():
            continue
        r = np.load(src)
        rgba = cu.read_image(view_file(name))
        ladder = record[name]["ladder"]
        for spp, img, sec in zip(r["ladder_spp"], r["ladder"], r["seconds"], strict=True):
            test = np.concatenate([img, rgba[..., 3:]], -1)
            ladder[str(int(spp))] = block_errors(test, rgba) | {
                "seconds": float(sec),
                "variant": str(r["variant"]),
            }
        record[name]["ladder"] = dict(sorted(ladder.items(), key=lambda kv: int(kv[0])))
    record_path.write_text(json.dumps(record, indent=1, default=float) + "\n")
    return record


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    ex = sub.add_parser("export", help="write each view's Mitsuba description")
    ex.add_argument("--out", required=True)
    ex.add_argument("--views", default=",".join(VIEWS))
    co = sub.add_parser("collect", help="write the EXRs and views.json from the renders")
    co.add_argument("--renders", required=True)
    la = sub.add_parser("ladder", help="add --ladder-only renders to the views' ladders")
    la.add_argument("--renders", required=True)
    args = parser.parse_args(argv)
    if args.command == "ladder":
        add_ladder(Path(args.renders))
    elif args.command == "export":
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        for name in args.views.split(","):
            export_spec(name, out / f"{name}.npz")
            print(f"exported {name}", flush=True)
    else:
        collect(Path(args.renders))
    return 0


if __name__ == "__main__":
    sys.exit(main())
