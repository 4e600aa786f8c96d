"""Write ``benchmarks/RESULTS.md`` from the benchmarks' JSON (the paper's §4 claims, per machine).

``python benchmarks/report.py --run benchmarks/out`` writes ``benchmarks/out/RESULTS.md``, the
report of that one run, and touches nothing else (what ``make bench`` does by default).
``python benchmarks/report.py --archive benchmarks/out`` copies a run's JSON and plots into
``benchmarks/results/<machine>/`` (``<machine>`` from the GL renderer string: ``llvmpipe``,
``nvidia-h200``, ...), then rewrites RESULTS.md with one section per folder under
``benchmarks/results/``. ``make bench`` does both after running every benchmark. Nothing here
judges speed by a threshold of its own: the verdicts compare the measured ratios with what the
paper states, and say so when a claim does not reproduce.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
REPORT = HERE / "RESULTS.md"
#: The JSON files a machine's section is written from (any may be missing).
FILES = (
    "distance", "speedups", "scaling", "light", "noise", "render", "animation", "particles",
    "particle_frames", "billboards", "render_cpu", "cluster",
)  # fmt: skip
#: Plots archived beside the JSON and shown in RESULTS.md (the others stay in benchmarks/out/:
#: the repository keeps few binaries).
PLOTS = ("distance", "speedups", "scaling", "particle_frames")


def machine_slug(renderer: str | None) -> str:
    """A folder name for a GL renderer string (``llvmpipe (LLVM 15...)`` -> ``llvmpipe``)."""
    text = str(renderer or "no-gl").lower()
    if "llvmpipe" in text:
        return "llvmpipe"
    head = text.split("/")[0]
    slug = re.sub(r"[^a-z0-9]+", "-", head).strip("-")
    return slug[:60] or "unknown"


def archive(run_dir: Path, results: Path = RESULTS) -> Path:
    """Copy the JSON and PNG files of one run into ``results/<machine>/``; returns that folder."""
    jsons = sorted(run_dir.glob("*.json"))
    if not jsons:
        raise FileNotFoundError(f"no benchmark JSON in {run_dir}")
    renderer = None
    for path in jsons:
        renderer = json.loads(path.read_text()).get("machine", {}).get("gl_renderer")
        if renderer:
            break
    target = results / machine_slug(renderer)
    target.mkdir(parents=True, exist_ok=True)
    plots = [run_dir / f"{name}.png" for name in PLOTS if (run_dir / f"{name}.png").is_file()]
    for path in [*jsons, *plots]:
        shutil.copy2(path, target / path.name)
    return target


def load(folder: Path) -> dict[str, dict[str, Any]]:
    out = {}
    for name in FILES:
        path = folder / f"{name}.json"
        if path.is_file():
            out[name] = json.loads(path.read_text())
    return out


# --- formatting ----------------------------------------------------------------------------------
def ms(spread: dict[str, float], digits: int = 1) -> str:
    """``median [min–max]`` in milliseconds."""
    f = f"{{:.{digits}f}}"
    return (
        f"{f.format(1e3 * spread['median'])} "
        f"[{f.format(1e3 * spread['min'])}–{f.format(1e3 * spread['max'])}]"
    )


def table(header: list[str], rows: list[list[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines + [""]


def verdict(ok: bool | None) -> str:
    return {True: "yes", False: "**no**", None: "n/a"}[ok]


# --- sections ------------------------------------------------------------------------------------
def machine_lines(data: dict[str, dict[str, Any]]) -> list[str]:
    first = next(iter(data.values()))
    m = first["machine"]
    lines = [
        f"- GL renderer: `{m.get('gl_renderer')}`",
        f"- CPU: {m.get('cpu_model')}, {m.get('cores')} cores; {m.get('platform')}",
        f"- Python {m.get('python')}, numpy {m.get('numpy')}, cumuli {m.get('cumuli')}",
    ]
    for name, d in data.items():
        mm = d["machine"]
        quick = " (**quick mode**: smoke-test sizes, not results)" if d.get("quick") else ""
        # Runs archived on different hosts of the same kind say which CPU each ran on.
        cpu = f", on {mm.get('cpu_model')}" if mm.get("cpu_model") != m.get("cpu_model") else ""
        lines.append(f"- `{name}.json`: commit `{mm.get('commit')}`, {mm.get('date')}{cpu}{quick}")
    if "frame_time" in first:
        lines.append(f"- Frame times: {first['frame_time']}")
    if first.get("size_note"):
        lines.append(f"- Sizes: {first['size_note']}")
    return lines + [""]


def distance_lines(d: dict[str, Any]) -> list[str]:
    lines = ["### Fig. 16 / Table 3: frame time against camera distance", ""]
    lines.append(
        f"Camera distance: {d['distance_definition']}; ms per frame, median [min–max] of "
        f"{d['repeats']} repeats; 0 is inside the cloud. Scenes: "
        + ", ".join(f"{n} ({s['primitives']} primitives)" for n, s in d["scenes"].items())
        + "."
    )
    lines.append("")
    for size, by_scene in d["curves"].items():
        names = list(by_scene)
        rows = []
        for i, dist in enumerate(d["distances"]):
            rows.append([dist] + [ms(by_scene[n][i]["frame_s"]) for n in names])
        lines.append(f"**{size}**")
        lines.append("")
        lines += table(["distance"] + names, rows)
    lines.append(
        "Table 3 analogue: the smallest sampled distance from which every farther one reaches "
        f"{d['realtime_fps']:.0f} fps (— : not reached at any sampled distance)."
    )
    lines.append("")
    t3 = d["table3_min_distance_30fps"]
    names = list(next(iter(t3.values())))
    rows = [[size] + ["—" if t3[size][n] is None else t3[size][n] for n in names] for size in t3]
    lines += table(["size"] + names, rows)
    paper = d["paper_table3_1920x1080"]
    lines.append(
        "The paper's Table 3 (1920×1080): "
        + "; ".join(
            f"{card}: cumulus {v['cumulus']}, mesh {v['mesh']}" for card, v in paper.items()
        )
        + "."
    )
    lines.append("")
    lines += table(
        ["goal", "measured (ms)", "met", "note"],
        [[t["name"], t["measured_ms"], verdict(t["met"]), t["note"]] for t in d["targets"]],
    )
    return lines


def speedup_verdicts(s: dict[str, Any]) -> dict[str, tuple[bool | None, str]]:
    """Each claim: (reproduced?, why) from the measured medians."""
    summ = s["summary"]
    hollow = summ["hollow"]["value"]
    light = summ["light"]
    sorts = summ["sort"]["value"]
    return {
        "hollow": (hollow >= 1.2, f"fps ratio {hollow:.2f} (paper ~1.3)"),
        "light": (
            light["value"] >= 1.8 and light["ndt_ms"] <= 10.0,
            f"naive/NDT {light['value']:.2f} (paper ~2: "
            f"{'yes' if light['value'] >= 1.8 else 'no'}); NDT {light['ndt_ms']:.1f} ms at 20³ "
            f"(paper < 10 ms: {'yes' if light['ndt_ms'] <= 10 else 'no'})",
        ),
        "sort": (
            sorts["quicksort"] >= 1.0 and sorts["oddeven"] >= 1.0,
            f"time / insertion: quicksort {sorts['quicksort']:.2f}, odd-even "
            f"{sorts['oddeven']:.2f}, none {sorts['none']:.2f}",
        ),
        "lod": (summ["lod"]["value"] > 1.0, f"fixed-step / LOD time {summ['lod']['value']:.2f}"),
        "march": (None, f"union / paper time {summ['march']['value']:.2f}"),
    }


def speedups_lines(s: dict[str, Any]) -> list[str]:
    lines = ["### The claimed speed-ups", ""]
    size = s["sort"]["size"]
    lines.append(f"Frames at {size}; ratios of medians within one run.")
    lines.append("")
    rows = []
    for key, (ok, why) in speedup_verdicts(s).items():
        rows.append([key, s["summary"][key]["claim"], why, verdict(ok)])
    lines += table(["claim", "paper", "measured", "reproduced"], rows)
    per_thread = s["light"]["threads"]
    lines.append(
        "Light precompute at 20³ (default cumulus seeds): "
        + "; ".join(
            f"{label}: NDT {v['ndt_ms_median']:.1f} ms (max {v['ndt_ms_max']:.1f}), naive/NDT "
            f"{v['naive_over_ndt_median']:.2f}"
            for label, v in per_thread.items()
        )
        + "."
    )
    lines.append("")
    rows = [[r["distance"], f"{r['lod_step']:.3f}", f"{r['fixed_over_lod']:.2f}",
             f"{r['image_mean_abs_diff']:.4f}"] for r in s["lod"]["rows"]]  # fmt: skip
    lines.append("LOD step against the fixed step 0.1 (cumulus):")
    lines.append("")
    lines += table(["distance", "LOD step", "fixed / LOD time", "mean abs image diff"], rows)
    return lines


def scaling_lines(s: dict[str, Any]) -> list[str]:
    lines = ["### Scaling: clouds and primitives per cloud", ""]
    lines.append(f"Frames at {s['size']}.")
    lines.append("")
    rows = [[r["clouds"], ms(r["frame_s"]), f"{r['coverage']:.2f}"] for r in s["clouds"]["rows"]]
    lines += table(["clouds", "ms per frame", "coverage"], rows)
    series = s["primitives"]["series"]
    names = list(series)
    n_rows = len(series[names[0]]["rows"])
    rows = []
    for i in range(n_rows):
        row = [series[names[0]]["rows"][i]["primitives"]]
        for n in names:
            r = series[n]["rows"][i]
            row.append(f"{ms(r['frame_s'])} (cov. {r['coverage']:.2f})")
        rows.append(row)
    lines += table(["primitives"] + [f"{n} ms" for n in names], rows)
    for n in names:
        fit = series[n]["linear_fit"]
        lines.append(
            f"- {n}: {1e6 * fit['slope_s_per_unit']:.1f} µs per primitive per frame, "
            f"intercept {1e3 * fit['intercept_s']:.1f} ms, R² {fit['r2']:.3f}"
        )
    lines.append(
        "- The paper (§4.1) predicts time linear in the primitives of a box; the *search* series "
        "isolates that term (same image, more primitives to test)."
    )
    return lines + [""]


def target_rows(targets: dict[str, dict[str, Any]], extra=None) -> list[list[Any]]:
    """Rows of issue targets in the benchmarks' ``{limit, comparison, reached, met}`` form, with
    today's method (``baseline``) and the ratio to it."""
    rows = []
    for name, t in targets.items():
        if "comparison" not in t:  # an older archive: {target, value, met}
            value = t.get("value")
            rows.append([name, t.get("target", "?"), "—" if value is None else f"{value:.3g}",
                         verdict(t.get("met")), "—"] + (extra(t) if extra else []))  # fmt: skip
            continue
        got = "—" if t.get("reached") is None else f"{t['reached']:.3g}"
        base = t.get("baseline") or {}
        if base.get("reached") is None:
            today = "—"
        else:
            ratio = "" if base.get("ratio") is None else f" (×{base['ratio']:.3g})"
            today = f"{base['method']} {base['reached']:.3g}{ratio}"
        row = [name, f"{t['comparison']} {t['limit']:.3g}", got, verdict(t["met"]), today]
        rows.append(row + (extra(t) if extra else []))
    return rows


def other_lines(data: dict[str, dict[str, Any]]) -> list[str]:
    lines: list[str] = []
    light = data.get("light")
    if light and "targets" in light:
        lines.append("### Light precompute (bench_light, issue targets, all cores)")
        lines.append("")

        def floor(t: dict[str, Any]) -> list[str]:
            f = t.get("fbm_floor_ms")
            diff = t.get("difference_from_ndt")
            d = "—" if not diff else f"{diff['max_abs']:.3f} / {diff['mean_abs']:.4f}"
            return ["—" if f is None else f"{f:.3g} ms", d]

        header = ["target", "limit", "reached", "met", "today's method (its value ×)"]
        lines += table(
            header + ["fBm alone (floor)", "max / mean |ΔL| vs NDT"],
            target_rows(light["targets"], floor),
        )
        lines.append(
            "The time targets are the `shared` method's (each sun-parallel line marched once); "
            "the floor is `Noise.fbm` alone on as many points as that march sampled."
        )
        lines.append("")
    noise = data.get("noise")
    if noise and "targets" in noise:
        lines.append(f"### fBm noise (bench_noise, {noise['points']:,} random points)")
        lines.append("")
        rows = [[name, f"{1e-6 * m['samples_per_s']['median']:.1f}",
                 f"{1e-6 * m['samples_per_s']['best']:.1f}"]
                for name, m in noise["methods"].items()]  # fmt: skip
        lines += table(["method", "M samples/s (median)", "M samples/s (best)"], rows)
        lines += table(
            ["target", "limit", "reached", "met", "today's method (its value ×)", "measure"],
            target_rows(noise["targets"], lambda t: [t.get("measure", "")]),
        )
    anim = data.get("animation")
    if anim and "targets" in anim:
        pre = anim["precompute"]
        lines.append("### Volume light precompute (bench_animation, Iwasaki 2011)")
        lines.append("")
        lines += table(
            ["target", "limit", "reached", "met", "today's method (its value ×)"],
            target_rows(anim["targets"]),
        )
        d = pre["sweep_minus_march"]
        lines.append(
            f"{pre['volumes']} volumes of {pre['resolution']}³ ({pre['settings']}): swept, mean "
            f"|Δ| / mean against marching: sun depth {d['sun_depth']:.3f}, sky SH "
            f"{d['sky_depth']:.3f}, point depths {d['point_depth']:.3f}, light {d['light']:.3f}."
        )
        lines.append("")
    render = data.get("render")
    if render:
        lines.append("### Render pass (bench_render)")
        lines.append("")
        rows = []
        for size, methods in render["methods"].items():
            rows.append([size] + [ms(methods[k]["wall_s"]) for k in sorted(methods)])
        first = next(iter(render["methods"].values()))
        lines += table(["size"] + [f"{k} wall ms" for k in sorted(first)], rows)
        lighting = render.get("lighting")
        if lighting:  # target: the physical mode costs at most 1.5× the paper mode
            lines += ["Physical lighting against the paper mode, frame-time ratio (limit 1.5):", ""]
            rows = [[size] + [f"{e[k]['reached']:.2f} ({verdict(e[k]['met'])})"
                              for k in ("gl_physical_over_paper", "cpu_physical_over_paper")]
                    for size, e in lighting.items()]  # fmt: skip
            lines += table(["size", "GL physical / paper", "CPU physical / paper"], rows)
    return lines


def _within(value: float | None, limit: float) -> bool | None:
    return None if value is None else value <= limit


def harris_lines(data: dict[str, dict[str, Any]]) -> list[str]:
    """Harris 2002 (bench_particles): which of [H] §4's claims reproduce, as ratios."""
    parts, frames = data.get("particles"), data.get("particle_frames")
    if not parts and not frames:
        return []
    lines = ["### Harris 2002 particle clouds (bench_particles)", ""]
    if parts:
        rows = []
        for c in parts["cases"]:
            if c["light_resolution"] != parts["settings"]["light_resolutions"][0]:
                continue
            rows.append([f"{c['particles']:,}"] + [
                "—" if k not in c["methods"] else f"{c['methods'][k]['per_light_s']:.3g}"
                for k in ("cpp_1_thread", "cpp_2_threads", "glsl_compute", "readback")
            ])  # fmt: skip
        nl = parts["settings"]["light_resolutions"][0]
        lines.append(f"(a) Light pass, seconds per light (N_L = {nl}):")
        lines.append("")
        lines += table(["particles", "C++ 1 thread", "C++ 2 threads", "GLSL", "read-back"], rows)
        claims = parts.get("claims", {})
        few = claims.get("few_thousand_under_1_s", {})
        many = claims.get("few_hundred_thousand_5_10_s_per_light", {})
        t3, t4 = few.get("readback_per_light_s_1e3"), few.get("readback_per_light_s_1e4")
        t5 = many.get("readback_per_light_s_1e5")
        # "A few thousand": 5 000 particles, between the measured 10³ and 10⁴ (linear in n).
        t5k = None if t3 is None or t4 is None else t3 + (t4 - t3) * 4000 / 9000
        rows = [
            ["a few thousand particles shade in < 1 s (read-back)",
             "—" if t5k is None else f"{t5k:.3g} s at 5 000 (10³: {t3:.3g} s, 10⁴: {t4:.3g} s)",
             verdict(_within(t5k, 1.0))],
            ["a few hundred thousand: 5–10 s per light (read-back)",
             "—" if t5 is None else f"{t5:.3g} s (10⁵)", verdict(_within(t5, 10.0))],
        ]  # fmt: skip
        lines += table(["[H] §4 claim (2002 PC)", "measured", "reproduces"], rows)
    if frames and frames.get("sweep"):
        sw = frames["sweep"]
        rows = [
            [p["clouds"], p["path"], ms(p["direct_s"]), ms(p["impostors_s"]),
             f"{p['ratio']:.2f}", f"{p['updates_per_frame']:.1f}"]
            for p in sw["points"]
        ]  # fmt: skip
        w, h = sw["size"]
        lines.append(
            f"(b) Fig. 8 sweep at {w}×{h}: clouds × 200 particles, {sw['frames_per_path']} frames "
            f"per path at {sw['speed_units_per_frame']} unit/frame, wall time per frame:"
        )
        lines.append("")
        lines += table(["clouds", "path", "direct ms", "impostors ms", "ratio",
                        "updates/frame"], rows)  # fmt: skip
        mean = sw["mean_ratio"]
        lines.append(
            f"[H]: impostors 3–5× faster on average over the range. Measured mean ratio "
            f"{mean:.2f}: reproduces {verdict(mean >= 3.0)}"
            + ("" if mean >= 3.0 else " (impostors faster, by less than 3×)" if mean > 1 else "")
            + "."
        )
        lines.append("")
    if frames and frames.get("big_clouds"):
        bc = frames["big_clouds"]
        rows = []
        for r in bc["runs"]:
            sky = r.get("variants", {}).get("skyworks")
            rows.append([f"{r['size'][0]}×{r['size'][1]}", f"{1 / r['direct_s']['median']:.1f}",
                         f"{1 / r['impostors_s']['median']:.1f}", f"{r['ratio']:.2f}",
                         f"{r['updates_per_frame']:.1f}",
                         "—" if sky is None else f"{sky['ratio']:.2f}"])  # fmt: skip
        lines.append(
            f"(c) {bc['clouds']} clouds, {bc['particles']:,} particles, fly-through "
            f"({bc.get('path', 'along the clouds')}):"
        )
        lines.append("")
        lines += table(["size", "direct fps", "impostors fps", "ratio", "updates/frame",
                        "ratio, SkyWorks' resolution rule"], rows)  # fmt: skip
        worst = min(r["ratio"] for r in bc["runs"])
        lines.append(
            f"[H]: about 7.5× at both sizes (GeForce 3). Measured {worst:.2f}× at worst: "
            f"reproduces (at least half the paper's ratio) {verdict(worst >= 3.75)}."
        )
        lines.append("")
    if frames and frames.get("popping"):
        pp = frames["popping"]
        rows = [
            [t["tolerance_deg"], t["updates"], f"{t['popping_mean']:.4f}",
             f"{t['mean_abs_error_vs_direct']:.2e}"]
            for t in pp["tolerances"]
        ]  # fmt: skip
        lines.append(
            f"(d) Popping along a slow orbit ({pp['orbit_deg_per_frame']}°/frame), and screen "
            "impostors with the eye inside a cloud:"
        )
        lines.append("")
        lines += table(["tolerance °", "updates", "popping (max abs Δ above direct)",
                        "mean abs Δ vs direct"], rows)  # fmt: skip
        pops = [t["popping_mean"] for t in pp["tolerances"]]
        monotone = all(a <= b for a, b in zip(pops, pops[1:], strict=False))
        ins = pp["inside"]
        rows = [[f"1/{f['factor']}", f"{1e3 * f['frame_s']:.1f}", f"{f['mean_abs_error']:.2e}"]
                for f in ins["factors"]]  # fmt: skip
        lines += table(["screen impostor", "frame ms", "mean abs Δ vs direct"], rows)
        quarter = next((f for f in ins["factors"] if f["factor"] == 4), None)
        lines.append(
            f"[H]: 0.15° imperceptible, up to 1° acceptable — popping grows with the tolerance: "
            f"{verdict(monotone)}. Inside clouds ¼ resolution per axis is enough: "
            + ("n/a" if quarter is None else
               f"mean abs Δ {quarter['mean_abs_error']:.2e} at {1e3 * quarter['frame_s']:.1f} ms "
               f"against {1e3 * ins['direct_frame_s']:.1f} ms direct: "
               f"{verdict(quarter['mean_abs_error'] < 1e-2)}")
            + "."
        )  # fmt: skip
        lines.append("")
    return lines


def section(name: str, data: dict[str, dict[str, Any]], folder: Path | None = None) -> list[str]:
    lines = [f"## {name}", ""] + machine_lines(data)
    if folder is not None:
        shown = [p for p in PLOTS if (folder / f"{p}.png").is_file()]
        lines += [f"![{p}](results/{folder.name}/{p}.png)" for p in shown] + ([""] if shown else [])
    if "distance" in data:
        lines += distance_lines(data["distance"])
    if "speedups" in data:
        lines += speedups_lines(data["speedups"])
    if "scaling" in data:
        lines += scaling_lines(data["scaling"])
    lines += other_lines(data) + harris_lines(data)
    if "billboards" in data:
        from _report_billboards import billboards_lines

        lines += billboards_lines(data["billboards"])
    from _report_speed import cluster_lines, work_lines

    if "render_cpu" in data:
        lines += work_lines(data["render_cpu"])
    if "cluster" in data:
        lines += cluster_lines(data["cluster"])
    if folder is not None:
        from _report_targets import targets_lines

        lines += targets_lines(folder, FILES)
    return lines


def write_report(results: Path = RESULTS, output: Path = REPORT) -> Path:
    folders = sorted(p for p in results.iterdir() if p.is_dir()) if results.is_dir() else []
    lines = [
        "# Benchmark results",
        "",
        "Written by `benchmarks/report.py` from the JSON in `benchmarks/results/<machine>/`; "
        "`make bench` reruns every benchmark, archives its JSON there and rewrites this file. "
        "Times are medians of repeats with [min–max]; methods are compared as ratios within one "
        "run. On Mesa's llvmpipe (software GL on the CPU) the paper's resolutions are divided by "
        "4 per edge and times are wall times; on a GPU the paper's sizes and GL timer queries are "
        "used. The paper's numbers come from 2009–2016 GPUs, so only ratios and trends compare.",
        "",
    ]
    if not folders:
        lines.append("No results yet: run `make bench`.")
    elif all(f.name == "llvmpipe" for f in folders):
        lines += [
            "**No GPU results yet.** The paper's resolutions, its Table 3 distances and the "
            "H100/H200 goals (1920×1080 cumulus at distance 32 in ≤ 1 ms, from inside in ≤ 4 ms) "
            "need a GPU: `make bench` on a machine with one writes `benchmarks/results/<gpu>/` "
            "beside `llvmpipe/` and a section for it here.",
            "",
            "Reading llvmpipe numbers: Mesa runs the fragment shader on the CPU cores, 8 pixels "
            "per SIMD lane group, so its costs are not a GPU's (memory latency hurts a GPU's "
            "quicksort more; a GPU's many cores hide per-primitive work that llvmpipe pays in "
            "full). A claim marked **no** is reported with its numbers, not tuned until it agrees.",
            "",
        ]
    for folder in folders:
        data = load(folder)
        if data:
            lines += section(folder.name, data, folder)
        elif any(folder.glob("*.json")):  # only benchmarks without a section of their own
            from _report_targets import targets_lines

            lines += [f"## {folder.name}", ""] + targets_lines(folder, FILES)
    text = "\n".join(lines).rstrip() + "\n"
    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = output.with_name(f".{output.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(output)
    return output


def write_run_report(run_dir: Path) -> Path:
    """``run_dir/RESULTS.md``: the report of one run's JSON (nothing is archived)."""
    data = load(run_dir)
    if not data:
        raise FileNotFoundError(f"no benchmark JSON in {run_dir}")
    first = next(iter(data.values()))
    slug = machine_slug(first.get("machine", {}).get("gl_renderer"))
    lines = [
        "# Benchmark results: this run",
        "",
        f"Written by `benchmarks/report.py --run {run_dir}` from the JSON beside this file; the "
        "committed results are `benchmarks/RESULTS.md` (`make bench ARCHIVE=1` adds this run "
        "to them). Times are medians of repeats with [min–max]; methods are compared as ratios "
        "within the run.",
        "",
        *section(slug, data),
    ]
    output = run_dir / "RESULTS.md"
    output.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")
    return output


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--run", type=Path, help="write RUN/RESULTS.md from this run's JSON (and nothing else)"
    )
    parser.add_argument("--archive", type=Path, help="copy this run folder's JSON into results/")
    parser.add_argument("--results", type=Path, default=RESULTS, help="folder of machine folders")
    parser.add_argument("--output", type=Path, default=REPORT, help="the Markdown file to write")
    args = parser.parse_args(argv)
    if args.run is not None:
        print(f"wrote {write_run_report(args.run)}")
        if args.archive is None:
            return 0
    if args.archive is not None:
        folder = archive(args.archive, args.results)
        print(f"archived {args.archive} -> {folder}")
    path = write_report(args.results, args.output)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
