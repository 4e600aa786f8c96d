"""The billboard-skies section of RESULTS.md (``report.py``; bench_billboards, Torchelsen & Musse
2005): which of [TM] §5's frame rates reproduce, directly and through impostors."""

from __future__ import annotations

from typing import Any

from report import ms, table, verdict


def _rate(r: dict[str, Any] | None, key: str) -> str:
    if r is None:
        return "—"
    return f"{r[key]:.1f} ({verdict(r['reaches_paper_rate'])})"


def _scene_rows(scenes: dict[str, Any]) -> list[list[Any]]:
    rows = []
    for name, r in scenes.items():
        key = "fps_mean" if r["compared"] == "mean" else "fps_median"
        runs = [_rate(r.get(x), key) for x in ("gl_impostors", "cpu_twin", "cpu_impostors")]
        rows.append([name, f"{r['paper_hz']:g} Hz ({r['compared']})", _rate(r, key),
                     f"{r['fps_min']:.1f}–{r['fps_max']:.1f}", *runs])  # fmt: skip
    return rows


def _slow_rows(scenes: dict[str, Any]) -> list[list[Any]]:
    """The flights at 1 unit per frame and the day at 1/27 s per frame, with and without
    impostors."""
    rows = []
    for name in ("nimbus", "rain"):
        slow = scenes.get(name, {}).get("slow")
        if slow:
            runs = [_rate(slow.get(x), "fps_median")
                    for x in ("gl_impostors", "cpu_twin", "cpu_impostors")]  # fmt: skip
            rows.append([f"{name}, {slow['units_per_frame']:g} unit/frame",
                         _rate(slow, "fps_median"), *runs])  # fmt: skip
    day = scenes.get("table1", {}).get("paper_rate")
    if day:
        for light in ("", "_steady_light"):
            label = "relit with CV" if not light else "steady light"
            rows.append([f"table1 at 1/27 s per frame, {label}",
                         _rate(day[f"gl{light}"], "fps_mean"),
                         _rate(day[f"gl{light}_impostors"], "fps_mean"), "—", "—"])  # fmt: skip
    return rows


def billboards_lines(b: dict[str, Any]) -> list[str]:
    """Torchelsen & Musse 2005 (bench_billboards): which of [TM] §5's frame rates reproduce,
    directly and through impostors."""
    lines = ["### Billboard skies (bench_billboards, Torchelsen & Musse 2005)", ""]
    render = b.get("render")
    if not render:
        return lines + ["No GL here: the render parts did not run.", ""]
    w, h = render["size"]
    lines.append(
        f"GL at {w}×{h} ({'llvmpipe: software GL' if render['software_gl'] else 'GPU'}); [TM] ran "
        "on a 2005 GeForce 6800 at an unstated size, so only 'reaches at least' and the ratios "
        "between its scenes compare. Each frame: the sprite list (cull, sort, vertex colours) "
        "and the draw; the Table 1 day also steps the weather and relights every frame. "
        "'imp.': the same frames through impostors (one per cloud and field instance)."
    )
    lines.append("")
    scenes = render["paper_scenes"]
    lines += table(["[TM] scene", "paper", "GL fps (reaches)", "GL min–max", "GL imp.",
                    "CPU twin", "CPU imp."], _scene_rows(scenes))  # fmt: skip
    slow = _slow_rows(scenes)
    if slow:
        lines += ["The flights at 1 unit per frame and the day at [TM]'s own frame spacing "
                  "(the direct rows above sample them sparsely, which no impostor survives):",
                  ""]  # fmt: skip
        lines += table(["run", "GL fps (reaches)", "GL imp.", "CPU twin", "CPU imp."], slow)
    if "nimbus" in scenes and "rain" in scenes:
        ours = scenes["nimbus"]["fps_median"] / scenes["rain"]["fps_median"]
        lines += [f"Nimbus (200 clouds) over rain (1000 clouds): [TM] ×2.0, cumuli ×{ours:.1f}.",
                  ""]  # fmt: skip
    rows = []
    for r in render["render_vs_clouds"].values():
        cpu = ms(r["cpu"]) if "cpu" in r else "—"
        rows.append([r["clouds"], r["sprites_drawn"], ms(r["gl"]), cpu])
    lines += table(["clouds", "billboards drawn", "GL ms", "CPU twin ms"], rows)
    imp = render.get("impostors", {})
    if imp.get("points"):
        speed = imp["speed_units_per_frame"]
        lines += [f"With and without impostors ({imp['frames_per_path']} frames per path at "
                  f"{speed:g} unit/frame, first frame apart):", ""]  # fmt: skip
        rows = [[p["clouds"], p["path"], *(f"{ms(p[x]['direct_s'])} / {ms(p[x]['impostors_s'])}"
                 f" (×{p[x]['ratio']:.2f})" for x in ("gl", "cpu")),
                 f"{p['gl']['updates_per_frame']:.1f} / {p['gl']['impostors_per_frame']:.0f}"]
                for p in imp["points"]]  # fmt: skip
        lines += table(["clouds", "path", "GL direct / impostors ms", "CPU direct / impostors ms",
                        "updates / shown"], rows)  # fmt: skip
    return lines
