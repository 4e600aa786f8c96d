"""What the physical mode's sharp volumes cost and what they buy: an endless-animation frame
drawn trilinearly (today's read) against the tricubic read with and without the fBm detail.

One database volume of the docs' evolving cumulus at 16³, 32³ and 64³ (16³, 32³ with
``--quick``) is lit once in the physical mode and drawn at 640 × 360 (160 × 90 quick) on GL
and on the C++ twin, each read: ``linear`` (trilinear, no detail), ``cubic`` (tricubic
B-spline, no detail), ``sharp`` (tricubic + detail 0.5, the default). Quality, from the same
run: the share of the horizontal luminance gradient's energy at the voxel period of a 32³
volume seen along z (the cell edges; target: the cubic read below half the trilinear one), and
the luminance spread p95/p5 over the cloud of the 64³ frame, today's σt = 1 against the mode's
(target ≥ 4: shaded, not a flat blob; not measured with ``--quick``). Writes
``sharp_volumes.json`` and ``sharp_volumes.png`` under ``benchmarks/out/`` (or ``--out``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402
import numpy as np  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.testing import cell_pattern_energy  # noqa: E402

READS = {
    "linear": {"detail": 0.0, "reconstruction": "linear"},
    "cubic": {"detail": 0.0, "reconstruction": "cubic"},
    "sharp": {},
}
SUN = cu.Sun(direction=(0.8, 0.6, 0.0), intensity=10.0)
LUMA = np.array([0.2126, 0.7152, 0.0722])
CUBE = ((-16.0, -16.0, -16.0), (16.0, 16.0, 16.0))


def frame(resolution: int) -> tuple[np.ndarray, tuple]:
    cloud = cu.gaussian_cumulus(centre=(0, 0, 0), seed=1)
    db = cu.evolving_cloud_volumes(
        cloud, cu.Noise(seed=7), 1, resolution, growth=0.25, wind=(0.08, 0.03, 0),
        density_scale=2.0, frequency=0.3, seed=3,
    )  # fmt: skip
    return db[0], db.box


def side_camera(box: tuple) -> cu.Camera:
    lo, hi = np.array(box[0]), np.array(box[1])
    c = (lo + hi) / 2
    return cu.Camera(
        position=(c[0], c[1] + 2, c[2] + 1.3 * (hi - lo).max()), target=tuple(c), fov=40
    )


def spread(img: np.ndarray) -> float:
    lum = img[..., :3] @ LUMA
    cover = img[..., 3] > 0.9
    p5, p95 = np.percentile(lum[cover], [5, 95])
    return float(p95 / p5)


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    machine = common.machine_info()
    quick = args.quick
    repeats = 1 if quick else 3
    width, height = (160, 90) if quick else (640, 360)
    resolutions = (16, 32) if quick else (16, 32, 64)
    common.log(f"GL renderer: {machine['gl_renderer']}")
    times: dict[str, dict[str, float]] = {}
    with cu.Renderer() as renderer:
        for res in resolutions:
            dens, box = frame(res)
            cam = side_camera(box)
            for read, kw in READS.items():
                scene = cu.Scene([cu.VolumeCloud(density=dens, box=box, **kw)], sun=SUN)
                lit = cu.prepare_light(scene, progress=False)
                for backend in ("gl", "cpu"):

                    def draw(
                        lit: cu.LitScene = lit, backend: str = backend, cam: cu.Camera = cam
                    ) -> None:
                        if backend == "gl":
                            renderer.render(lit, cam, width, height)
                        else:
                            cu.render_cpu(lit, cam, width, height, progress=False)

                    name = f"{res}_{read}_{backend}"
                    times[name] = common.spread(common.time_repeats(draw, repeats)[0])
                    common.log(f"{name}: {1e3 * times[name]['median']:.1f} ms")
    ratios = {
        f"{res}_{read}_over_linear_{b}": times[f"{res}_{read}_{b}"]["median"]
        / times[f"{res}_linear_{b}"]["median"]
        for res in resolutions
        for read in ("cubic", "sharp")
        for b in ("gl", "cpu")
    }
    # Quality: cell edges of a 32³ volume seen along z (a voxel ≈ 10 px at 640 × 360).
    dens, _ = frame(32)
    dist = 400.0
    cam = cu.Camera(position=(0.0, 0.0, dist), target=(0.0, 0.0, 0.0),
                    fov=math.degrees(2 * math.atan(18.0 / dist)))  # fmt: skip
    qw, qh = (320, 180) if quick else (640, 360)
    energy = {}
    for read in ("linear", "cubic"):
        scene = cu.Scene([cu.VolumeCloud(density=dens, box=CUBE, **READS[read])], sun=SUN)
        image = cu.render_cpu(scene, cam, qw, qh, progress=False)
        energy[read] = cell_pattern_energy(image, qh / 36)
    common.log(f"voxel-period gradient energy: {energy}")
    targets = {
        "cell_edges_cubic_over_linear": common.target(
            0.5,
            energy["cubic"] / energy["linear"],
            "<=",
            baseline={"method": "trilinear", "reached": energy["linear"], "ratio": None},
        ),  # fmt: skip
    }
    spreads = {}
    if not quick:
        dens, box = frame(64)
        cam = side_camera(box)
        for name, kw in (("sigma_t_1_linear", {"sigma_t": 1.0, **READS["linear"]}), ("sharp", {})):
            scene = cu.Scene([cu.VolumeCloud(density=dens, box=box, **kw)], sun=SUN)
            spreads[name] = spread(cu.render_cpu(scene, cam, 320, 180, progress=False))
    targets["frame_64_luminance_spread"] = common.target(
        4.0, spreads.get("sharp"), ">=",
        baseline={"method": "sigma_t=1, trilinear", "reached": spreads.get("sigma_t_1_linear"),
                  "ratio": None},
    )  # fmt: skip
    for name, t in targets.items():
        common.log(common.show_target(name, t))
    data = {
        "benchmark": "sharp_volumes",
        "quick": quick,
        "machine": machine,
        "image": [width, height],
        "resolutions": list(resolutions),
        "seconds": times,
        "ratios": ratios,
        "voxel_band_energy": energy,
        "luminance_spread_64": spreads,
        "targets": targets,
    }
    common.write_json(args.out / "sharp_volumes.json", data)
    plt = common.pyplot()
    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    names = list(times)
    ax.barh(names, [times[n]["median"] for n in names])
    ax.set_xscale("log")
    ax.set_xlabel("seconds (median)")
    ax.set_title(f"volume frame draws, {width}×{height}")
    fig.savefig(args.out / "sharp_volumes.png", dpi=100)
    return 0


if __name__ == "__main__":
    sys.exit(main())
