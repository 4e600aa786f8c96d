"""Equal-quality speed against Mitsuba 3: how long Mitsuba needs to be as close as cumuli.

Per reference view of ``tests/references/mitsuba_views.py`` (the default cumulus back-lit, a
dense metaball cloud, a thin L-system cloud; 160×120, the physical default without haze):

- **cumuli's error**: its render (CPU twin, 2 threads) against Mitsuba's converged image, with
  the tests' metric (``mitsuba_views.block_errors``: the relative error of 4×4-block means of
  the RGB mean over the covered blocks — median and p90 — and the same per pixel);
- **cumuli's time**: the whole render from nothing memoised (light step + draw,
  ``cumuli.light.prepare.clear_memo`` before each repeat) and the draw alone (a `LitScene`
  from ``prepare_light``), median of the repeats;
- **Mitsuba's error at n samples** per pixel: from the reference run's ladder (independent
  images at 1, 2, 4, … 32 spp against the converged image, ``views.json``);
- **Mitsuba's time at n samples**: measured here (``scalar_rgb``, the scene loaded once, a
  render at 1 and at 4 spp: ``t(n) = t₁ + (n − 1)·(t₄ − t₁)/3``), for the references' medium
  (the Mie phase's forward peak as unscattered light, which spares Mitsuba work);
- **the samples Mitsuba needs to reach cumuli's error**: interpolated on log-log axes between
  the ladder's two counts around cumuli's error; beyond the ladder, a straight line through its
  errors on log-log axes (least squares), solved for cumuli's error and said to be
  extrapolated; never less than 1 spp (Mitsuba renders no fewer);
- **the equal-quality speed-up**: Mitsuba's time at those samples over cumuli's whole time and
  over its draw alone, for the block median (the targets) and the block p90.

Targets: ≥ 100× end to end and ≥ 1000× draw only on every view (the minimum over the views;
``met`` is null in --quick, which times one view and Mitsuba at 1 spp only). Nothing passes or
fails on time.
"""

from __future__ import annotations

import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "references"))

import _common as common  # noqa: E402
import mitsuba_views as mv  # noqa: E402
import numpy as np  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.light.prepare import clear_memo  # noqa: E402

THREADS = 2
TARGET_WHOLE = 100.0
TARGET_DRAW = 1000.0
METRICS = ("block_median", "block_p90", "pixel_median")


def spp_needed(ladder: dict[str, dict[str, float]], metric: str, error: float) -> dict[str, Any]:
    """Samples per pixel at which Mitsuba's ``metric`` reaches ``error``: within the ladder's
    errors, interpolated on log-log axes between the two counts around it (the errors taken as
    their running minimum, so that they fall with the samples); outside them, the least-squares
    log-log line through the whole ladder, solved, and ``extrapolated``."""
    spp = np.array(sorted(int(k) for k in ladder), np.float64)
    err = np.array([ladder[str(int(n))][metric] for n in spp], np.float64)
    slope, intercept = np.polyfit(np.log(spp), np.log(err), 1)
    falling = np.minimum.accumulate(err)
    inside = bool(falling.min() <= error <= falling.max())
    if inside:
        # A run of equal errors counts from its first count (np.interp wants them distinct).
        first = np.concatenate([[True], falling[1:] < falling[:-1]])
        n = math.exp(
            float(np.interp(-math.log(error), -np.log(falling[first]), np.log(spp[first])))
        )
    else:
        n = math.exp((math.log(error) - intercept) / slope) if slope < 0 else math.inf
    return {
        "spp": n,
        "slope": float(slope),
        "extrapolated": not inside,
        "ladder_spp": spp.astype(int).tolist(),
        "ladder_error": err.tolist(),
    }


def cumuli_times(scene: cu.Scene, camera: cu.Camera, repeats: int) -> dict[str, Any]:
    """Whole (light + draw, nothing memoised) and draw-only times of the CPU twin."""

    def whole() -> np.ndarray:
        clear_memo()
        return cu.render_cpu(scene, camera, mv.WIDTH, mv.HEIGHT, threads=THREADS)

    lit = cu.prepare_light(scene, threads=THREADS, progress=False)
    runs = common.interleaved_repeats(
        {
            "whole": whole,
            "draw": lambda: cu.render_cpu(lit, camera, mv.WIDTH, mv.HEIGHT, threads=THREADS),
        },
        repeats,
    )
    return {name: common.spread(wall) for name, (wall, _cpu) in runs.items()}


def mitsuba_times(name: str, quick: bool) -> dict[str, Any]:
    """Mitsuba's render time here at 1 (and 2) spp of a view, its scene loaded once."""
    try:
        import mitsuba as mi
    except ImportError:
        return {"available": False, "reason": "mitsuba is not installed (pip install mitsuba)"}
    import mitsuba_batch as mb

    mi.set_variant("scalar_rgb")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{name}.npz"
        mv.export_spec(name, path)
        spec = dict(np.load(path))
        spec["sigma_t"] = np.load(path.with_name(str(spec["field"])))["sigma_t"]
    scene = mb.build(mi, spec, "ms", 1)
    t = {}
    for n in (1,) if quick else (1, 4):
        t0 = time.perf_counter()
        mb.render(mi, scene, n, 90_000 + n)
        t[n] = time.perf_counter() - t0
    per_spp = (t[4] - t[1]) / 3 if 4 in t and t[4] > t[1] else t[1]
    return {"available": True, "variant": "scalar_rgb", "t1_s": t[1], "t4_s": t.get(4),
            "per_spp_s": per_spp}  # fmt: skip


def mitsuba_time_at(m: dict[str, Any], spp: float) -> float:
    n = max(spp, 1.0)
    return m["t1_s"] + (n - 1.0) * m["per_spp_s"]


def bench_view(name: str, record: dict[str, Any], repeats: int, quick: bool) -> dict[str, Any]:
    scene, camera = mv.VIEWS[name]()
    ref = cu.read_image(mv.view_file(name))
    img = cu.render_cpu(scene, camera, mv.WIDTH, mv.HEIGHT, threads=THREADS)
    errors = mv.block_errors(img, ref)
    times = cumuli_times(scene, camera, repeats)
    mits = mitsuba_times(name, quick)
    out: dict[str, Any] = {
        "doc": mv.VIEWS[name].__doc__,
        "cumuli_error": errors,
        "cumuli_s": times,
        "mitsuba": mits,
        "reference": {k: record[k] for k in ("spp", "noise_median_block", "variant")},
        "equal_quality": {},
    }
    for metric in METRICS:
        need = spp_needed(record["ladder"], metric, errors[metric])
        row: dict[str, Any] = {"cumuli_error": errors[metric], **need}
        if mits["available"]:
            tm = mitsuba_time_at(mits, need["spp"])
            row["mitsuba_s"] = tm
            row["speedup_whole"] = tm / times["whole"]["median"]
            row["speedup_draw"] = tm / times["draw"]["median"]
        out["equal_quality"][metric] = row
    return out


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    record = json.loads((mv.HERE / "views.json").read_text())
    names = [n for n in mv.VIEWS if n in record and mv.view_file(n).exists()]
    if args.quick:
        names = names[-1:]
    repeats = 1 if args.quick else 9
    views = {}
    for name in names:
        common.log(f"view {name} ...")
        views[name] = v = bench_view(name, record[name], repeats, args.quick)
        eq = v["equal_quality"]["block_median"]
        whole, draw = v["cumuli_s"]["whole"]["median"], v["cumuli_s"]["draw"]["median"]
        line = (f"  cumuli block median {eq['cumuli_error']:.3f}, whole {whole:.3f} s, draw "
                f"{draw:.3f} s; Mitsuba needs {eq['spp']:.2f} spp")  # fmt: skip
        if "speedup_whole" in eq:
            line += (f" = {eq['mitsuba_s']:.2f} s: {eq['speedup_whole']:.1f}x whole, "
                     f"{eq['speedup_draw']:.1f}x draw")  # fmt: skip
        common.log(line)
    measured = not args.quick and all(v["mitsuba"]["available"] for v in views.values())

    def worst(key: str) -> float | None:
        if not measured:
            return None
        return min(v["equal_quality"]["block_median"][key] for v in views.values())

    targets = {
        "speedup_whole": common.target(TARGET_WHOLE, worst("speedup_whole"), ">="),
        "speedup_draw": common.target(TARGET_DRAW, worst("speedup_draw"), ">="),
    }
    data = {
        "benchmark": "fidelity",
        "machine": common.machine_info(),
        "quick": bool(args.quick),
        "threads": THREADS,
        "size": [mv.WIDTH, mv.HEIGHT],
        "repeats": repeats,
        "metric": "block_median (targets); block_p90 and pixel_median reported",
        "views": views,
        "targets": targets,
    }
    path = common.write_json(args.out / "fidelity.json", data)
    for tname, t in targets.items():
        common.log(common.show_target(tname, t, "x"))
    plot(views, args.out / "fidelity.png")
    common.log(f"wrote {path}")
    return 0


def plot(views: dict[str, Any], path: Path) -> None:
    plt = common.pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for i, (name, v) in enumerate(views.items()):
        eq = v["equal_quality"]["block_median"]
        colour = f"C{i}"
        ax.loglog(eq["ladder_spp"], eq["ladder_error"], "o-", color=colour, label=f"Mitsuba {name}")
        ax.axhline(eq["cumuli_error"], color=colour, ls="--", lw=1)
        if math.isfinite(eq["spp"]):
            ax.plot([eq["spp"]], [eq["cumuli_error"]], "x", color=colour, ms=10)
    ax.set_xlabel("Mitsuba samples per pixel")
    ax.set_ylabel("median block error vs converged")
    ax.set_title("Mitsuba's error per spp; dashed: cumuli's physical default")
    ax.legend(fontsize=7)
    fig.tight_layout()
    common.save_figure(fig, path)


if __name__ == "__main__":
    sys.exit(main())
