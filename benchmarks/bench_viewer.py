"""How interactive the notebook viewer feels: preview frames per second while the mouse drags
and the full frame's latency after it stops, per backend and lighting mode.

The default scene (``cumuli.demo.default_scene``, the paper's Fig. 10: three cumuli at sunset)
is driven through `cumuli.jupyter.session.ViewerSession` as `cumuli.Viewer` drives it: the light
step made once (the sun does not move), then a drag of many small orbit steps, each answered by
a 240 × 135 preview (march settings `PREVIEW_SETTINGS`) encoded as the PNG the browser gets,
then the 960 × 540 full frame after the stop (light reused). The same previews at the full
frame's march settings are timed as the baseline. Targets: ≥ 8 preview frames/s, ≤ 1 s for the
full frame. ``--quick``: 120 × 68 previews, a 320 × 180 full frame, few frames; targets not
judged. Writes ``viewer.json`` and ``viewer.png`` under ``benchmarks/out/`` (or ``--out``).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.demo import default_scene  # noqa: E402
from cumuli.jupyter import session as viewer_session  # noqa: E402
from cumuli.light.prepare import clear_memo  # noqa: E402

FPS_TARGET = 8.0
FULL_TARGET = 1.0
BURSTS = 4


def _drag(s: viewer_session.ViewerSession, frames: int) -> list[float]:
    """Seconds per preview frame (orbit step, render, PNG) over a drag of ``frames`` steps."""
    out = []
    for _ in range(frames):
        t0 = time.perf_counter()
        s.rotate(6.0, 1.5)
        s.png(s.render(preview=True))
        out.append(time.perf_counter() - t0)
    return out


def _full(s: viewer_session.ViewerSession, repeats: int) -> list[float]:
    """Seconds for the full frame (render + PNG) after a stop, the camera moved each time."""
    out = []
    for _ in range(repeats):
        s.rotate(6.0, 1.5)
        t0 = time.perf_counter()
        s.png(s.render(preview=False))
        out.append(time.perf_counter() - t0)
    return out


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    machine = common.machine_info()
    quick = args.quick
    preview, full = ((120, 68), (320, 180)) if quick else ((240, 135), (960, 540))
    frames, repeats = (BURSTS, 1) if quick else (16 * BURSTS, 5)
    common.log(f"GL renderer: {machine['gl_renderer']}; preview {preview}, full {full}")
    cases = {}
    for mode in ("paper", "physical"):
        scene = default_scene(cu.RenderSettings(lighting=mode))
        for backend in ("gl", "cpu"):
            s = viewer_session.ViewerSession(
                scene, size=full, preview_size=preview, backend=backend
            )
            clear_memo()  # the light step timed afresh (a sun slider's cost)
            t0 = time.perf_counter()
            s.lit()
            light = time.perf_counter() - t0
            s.render(preview=True)  # warm-up: shaders compiled, caches filled
            s.render(preview=False)
            # The drag in short bursts, alternating with the baseline (previews at the full
            # frame's march settings) so that a shared machine's drift touches both alike.
            cheap, baseline = [], []
            saved = dict(viewer_session.PREVIEW_SETTINGS)
            for _ in range(BURSTS):
                cheap += _drag(s, frames // BURSTS)
                viewer_session.PREVIEW_SETTINGS.clear()
                try:
                    baseline += _drag(s, frames // BURSTS)
                finally:
                    viewer_session.PREVIEW_SETTINGS.update(saved)
            drag, plain = common.spread(cheap), common.spread(baseline)
            stop = common.spread(_full(s, repeats))
            fps = 1.0 / drag["median"]
            base_fps = 1.0 / plain["median"]
            key = f"{backend}_{mode}"
            cases[key] = {
                "backend": backend,
                "lighting": mode,
                "light_seconds": light,
                "preview_seconds": drag,
                "preview_fps": fps,
                "preview_fps_full_march": base_fps,
                "full_seconds": stop,
                "targets": {
                    "preview_fps": common.target(
                        FPS_TARGET, None if quick else fps, ">=",
                        baseline={"method": "full march settings",
                                  "reached": None if quick else base_fps,
                                  "ratio": fps / base_fps},
                    ),
                    "full_frame_seconds": common.target(
                        FULL_TARGET, None if quick else stop["median"], "<="
                    ),
                },
            }  # fmt: skip
            common.log(
                f"{key}: light {light:.2f} s; preview {fps:.1f} fps ({base_fps:.1f} at full "
                f"march); full frame {stop['median']:.2f} s"
            )
            for name, t in cases[key]["targets"].items():
                common.log("  " + common.show_target(name, t))
    data = {
        "benchmark": "viewer",
        "quick": quick,
        "machine": machine,
        "scene": "default_scene",
        "preview_size": list(preview),
        "full_size": list(full),
        "preview_settings": dict(viewer_session.PREVIEW_SETTINGS),
        "cases": cases,
    }
    common.write_json(args.out / "viewer.json", data)
    plt = common.pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6), constrained_layout=True)
    names = list(cases)
    a.barh(names, [cases[n]["preview_fps"] for n in names], label="preview march")
    a.barh(names, [cases[n]["preview_fps_full_march"] for n in names], height=0.4,
           label="full march")  # fmt: skip
    a.axvline(FPS_TARGET, color="k", ls="--", label=f"target {FPS_TARGET:g} fps")
    a.set_xlabel("preview frames per second (median)")
    a.set_title(f"while dragging, {preview[0]}×{preview[1]}")
    a.legend(fontsize=8)
    b.barh(names, [cases[n]["full_seconds"]["median"] for n in names], label="full frame")
    b.axvline(FULL_TARGET, color="k", ls="--", label=f"target {FULL_TARGET:g} s")
    b.set_xlabel("seconds (median)")
    b.set_title(f"after the stop, {full[0]}×{full[1]} (light reused)")
    b.legend(fontsize=8)
    fig.savefig(args.out / "viewer.png", dpi=100)
    return 0


if __name__ == "__main__":
    sys.exit(main())
