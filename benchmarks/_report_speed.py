"""The issue-14 sections of RESULTS.md (``report.py``) that have no home in the paper's
sections: work per pixel of the 2018 marcher (bench_render_cpu) and frames across a Dask cluster
(bench_cluster)."""

from __future__ import annotations

from typing import Any

from report import table, verdict


def work_lines(render_cpu: dict[str, Any]) -> list[str]:
    """fBm evaluations per pixel off / skip / fast and the ÷2 target at mean |Δ| ≤ 2e-3."""
    work = render_cpu.get("work_per_pixel")
    if not work:
        return []
    w, h = render_cpu["image"]
    lines = ["### Work per pixel of the 2018 marcher (bench_render_cpu)", ""]
    lines.append(
        f"{w}×{h}, paper march, counted by the CPU twin (`return_stats=True`); variants: "
        + "; ".join(
            f"*{k}* = skipping {'on' if v['empty_space_skipping'] else 'off'}, "
            f"min_transmittance {v['min_transmittance']:g}"
            for k, v in render_cpu["work_variants"].items()
        )
        + ". Frame-time ratios are off / variant (> 1: faster)."
    )
    lines.append("")
    rows = []
    for scene, r in work.items():
        red, diff = r["fbm_reduction"], r["image_difference"]
        rows.append([
            scene,
            f"{r['off']['fbm_per_pixel']:.2f}",
            f"{r['fast']['fbm_per_pixel']:.2f}",
            f"{red['reached']:.2f} ({verdict(red['met'])})",
            f"{diff['reached']:.1e} ({verdict(diff['met'])})",
            f"{r['skip']['skipped_per_pixel']:.2f} of {r['off']['steps_per_pixel']:.2f}",
            f"{r['cpu_off_over_skip']:.2f} / {r['cpu_off_over_fast']:.2f}",
            f"{r['gl_off_over_skip']:.2f} / {r['gl_off_over_fast']:.2f}",
        ])  # fmt: skip
    lines += table(
        ["scene", "fBm/px off", "fBm/px fast", "off / fast (≥ 2)", "mean |Δ| fast (≤ 2e-3)",
         "skipped / steps per px", "CPU skip / fast", "GL skip / fast"],
        rows,
    )  # fmt: skip
    lines.append(
        "Skipping alone leaves the image bit-identical and the fBm count unchanged (the density "
        "models evaluate fBm only inside their support, which the candidate intervals already "
        "follow); it saves density evaluations of empty samples (metaball clouds). The fBm "
        "saving comes from the early exit."
    )
    return lines + [""] + hd_lines(render_cpu)


def hd_lines(render_cpu: dict[str, Any]) -> list[str]:
    """The 1080p physical frame on the CPU twin against its limit, per noise version."""
    hd = render_cpu.get("hd")
    if not hd or "target" not in hd:
        return []
    t = hd["target"]
    w, h = hd["image"]
    lines = [
        f"### A {w}×{h} physical frame on the CPU twin (bench_render_cpu)",
        "",
        f"{t.get('measure', '')}; median of the repeats.",
        "",
    ]
    rows = [
        [f"noise version {v}", f"{r['wall_s']['median']:.3f}", f"{r['fbm_bulk_share']:.0%}"]
        for v, r in sorted(hd["versions"].items())
    ]
    lines += table(["scene", "seconds", "share in the bulk fBm"], rows)
    reached = t.get("reached")
    shown = "n/a" if reached is None else f"{reached:.3f} s ({verdict(t.get('met'))})"
    lines.append(f"Target: ≤ {t['limit']:g} s on {hd['threads']} threads; reached {shown}.")
    st = hd.get("stages")
    if st:
        lines += [
            "",
            "What bounds it, each stage timed alone: the march {:.3f} s ({:,} samples, {:.0f} ns "
            "per sample and thread), the edge pass {:.3f} s ({:,} outline pixels of {:,} "
            "covered), the finish (air and resolve) {:.3f} s.".format(
                st["march"]["median"], st["march_samples"], st["march_ns_per_sample_thread"],
                st["edge_pass"]["median"], st["edge_pixels"], st["covered_pixels"],
                st["finish"]["median"],
            ),
        ]  # fmt: skip
    return lines + [""]


def cluster_lines(cluster: dict[str, Any]) -> list[str]:
    """Serial vs 1 and 2 Dask workers on the same frames (identical images)."""
    w, h = cluster["image"]
    lines = ["### Frames across a Dask cluster (bench_cluster)", ""]
    lines.append(
        f"{cluster['frames']} frames of {w}×{h}, {cluster['backend']} backend, one render thread "
        f"per frame, `LocalCluster` worker processes; {cluster['timing']}; images identical to the "
        f"serial ones: {verdict(cluster['images_identical'])}."
    )
    lines.append("")
    s = cluster["seconds"]
    lines += table(
        ["run", "seconds (median [min–max])"],
        [[k, f"{v['median']:.3f} [{v['min']:.3f}–{v['max']:.3f}]"] for k, v in s.items()],
    )
    r = cluster["ratios"]
    lines.append(
        f"2 workers over 1: ×{r['2_workers_speedup_over_1']:.2f}; 1 worker over serial: "
        f"{r['1_worker_over_serial']:.2f} (the cost of shipping scenes and images)."
    )
    return lines + [""]
