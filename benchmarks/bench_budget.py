"""The budget: the inputs that used to expand into gigabytes or minutes, and what they cost now.

Each case is one of the inputs measured before the budget existed (a small scene file naming
three atlas recipes at their largest, a billboard field of 2²⁰ instances, a physical light at
``physical_resolution=256``, a ``density_volume`` of 1024³) and is now refused by the default
budget. Measured per case: wall time to the refusal, the Python heap's peak (tracemalloc) and
the growth of the process's peak resident memory while it ran, next to the cost the input was
estimated at and the budget. Then an accepted scene file, to compare the estimate with what
loading it really grew the process by.

Targets ({limit, reached, met}): each refusal within 1 s and 64 MiB of new resident memory (the
inputs took 65–149 s and 4.2–10.7 GB before), and an accepted scene's real growth within 2× its
estimate. No pass/fail on time. JSON + PNG under ``benchmarks/out/`` (``--out`` to change).
"""

from __future__ import annotations

import dataclasses
import json
import resource
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402
import numpy as np  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli import scene_cost  # noqa: E402
from cumuli.model import seedbox_presets as presets  # noqa: E402

#: What the inputs cost before the budget (the measurements that asked for it), for the record.
BEFORE = {
    "scene_three_atlases": {"seconds": 65.0, "bytes": 4.4e9},
    "field_2_20_instances": {"seconds": 121.0, "bytes": 5.1e9},
    "physical_resolution_256": {"seconds": 149.0, "bytes": 4.2e9},
    "density_volume_1024": {"seconds": 120.0, "bytes": None},
}


def _rss() -> int:
    """Peak resident memory of this process so far, bytes (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def _refusal(call) -> dict[str, Any]:
    rss0 = _rss()
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        call()
        message = None
    except ValueError as exc:
        message = str(exc)
    seconds = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return {
        "refused": message is not None,
        "message": message,
        "seconds": seconds,
        "python_peak_bytes": peak,
        "rss_growth_bytes": max(0, _rss() - rss0),
    }


def _atlas_scene(folder: Path, recipes: list[dict[str, Any]]) -> Path:
    clouds = [cu.seed_box_cloud(presets.cirrus(), seed=k).translated((30 * k, 0, 0))
              for k in range(len(recipes))]  # fmt: skip
    data = cu.Scene(clouds, noise=cu.Noise(seed=2, size=16)).to_dict()
    for entry, recipe in zip(data["clouds"], recipes, strict=True):
        entry["atlas"] = {"recipe": recipe}
    path = folder / f"atlases_{len(recipes)}.json"
    path.write_text(json.dumps(data))
    return path


def cases(folder: Path) -> dict[str, dict[str, Any]]:
    """The inputs, each refused by the default budget."""
    out: dict[str, dict[str, Any]] = {}
    big = [{"style": "sunny", "n": 256, "size": 512, "seed": k} for k in range(3)]
    path = _atlas_scene(folder, big)
    estimate = sum(c for _, c in scene_cost.scene_items(json.loads(path.read_text())))
    out["scene_three_atlases"] = {
        "file_bytes": path.stat().st_size,
        "estimate_bytes": estimate,
        **_refusal(lambda: cu.load_scene(path)),
    }
    cloud = cu.seed_box_cloud(presets.cumulus(), seed=1)
    offsets = np.zeros((1 << 20, 3), np.float32)
    from cumuli.model.billboard_field import BYTES_PER_BILLBOARD

    out["field_2_20_instances"] = {
        "estimate_bytes": (1 << 20) * cloud.n_billboards * BYTES_PER_BILLBOARD,
        **_refusal(lambda: cu.BillboardField([cloud], offsets)),
    }
    settings = cu.RenderSettings(lighting="physical", physical_resolution=256)
    scene = cu.Scene([cu.gaussian_cumulus(n=2, seed=1), cu.gaussian_cumulus(n=2, seed=2)
                      .translated((6, 0, 0))], settings=settings)  # fmt: skip
    out["physical_resolution_256"] = {
        "estimate_bytes": settings.physical_cost(2)[0],
        "estimate_samples": settings.physical_cost(2)[1],
        **_refusal(lambda: cu.render(scene, scene.default_camera(), 32, 24, backend="cpu")),
    }
    noise = cu.Noise(seed=1, size=32)
    out["density_volume_1024"] = {
        **_refusal(lambda: cu.density_volume(scene.clouds[0], noise, resolution=1024)),
    }
    for name, row in out.items():
        row["before"] = BEFORE[name]
    return out


def accepted(folder: Path, quick: bool) -> dict[str, Any]:
    """A scene file within the budget: its estimate against the real growth of loading it."""
    n, size = (64, 128) if quick else (256, 256)
    recipes = [{"style": "wispy", "n": n, "size": size, "seed": 100 + k} for k in range(3)]
    path = _atlas_scene(folder, recipes)
    estimate = sum(c for _, c in scene_cost.scene_items(json.loads(path.read_text())))
    rss0 = _rss()
    t0 = time.perf_counter()
    with cu.limits(scene_allowance=2 * estimate):
        cu.load_scene(path)
    return {
        "recipes": recipes,
        "file_bytes": path.stat().st_size,
        "estimate_bytes": estimate,
        "seconds": time.perf_counter() - t0,
        "rss_growth_bytes": max(0, _rss() - rss0),
    }


def plot(result: dict[str, Any], path: Path) -> None:
    plt = common.pyplot()
    names = list(result["cases"])
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
    before = [result["cases"][n]["before"]["seconds"] for n in names]
    now = [max(result["cases"][n]["seconds"], 1e-6) for n in names]
    x = np.arange(len(names))
    ax1.bar(x - 0.2, before, 0.4, label="before the budget")
    ax1.bar(x + 0.2, now, 0.4, label="refused now")
    ax1.set_yscale("log")
    ax1.set_xticks(x, [n.replace("_", "\n") for n in names], fontsize=7)
    ax1.set_ylabel("seconds")
    ax1.legend(fontsize=7)
    est = [result["cases"][n].get("estimate_bytes") or 0 for n in names]
    ax2.bar(x, np.array(est) / 2**30, 0.5, label="estimated cost")
    ax2.axhline(result["limits"]["memory"] / 2**30, color="k", lw=1, label="memory budget")
    ax2.set_xticks(x, [n.replace("_", "\n") for n in names], fontsize=7)
    ax2.set_ylabel("GiB")
    ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    args = common.parse_args(__doc__.splitlines()[0], argv)
    machine = common.machine_info()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        result: dict[str, Any] = {
            "benchmark": "budget",
            "description": "inputs that expanded, refused before they allocate; estimates",
            "quick": args.quick,
            "machine": machine,
            "limits": dataclasses.asdict(cu.get_limits()),
            "cases": cases(folder),
            "accepted_scene": accepted(folder, args.quick),
        }
    worst_s = max(r["seconds"] for r in result["cases"].values())
    worst_rss = max(r["rss_growth_bytes"] for r in result["cases"].values())
    acc = result["accepted_scene"]
    ratio = acc["rss_growth_bytes"] / acc["estimate_bytes"]
    result["all_refused"] = all(r["refused"] for r in result["cases"].values())
    result["targets"] = {
        "refusal_seconds": common.target(1.0, worst_s, "<="),
        "refusal_rss_growth_bytes": common.target(64 << 20, worst_rss, "<="),
        "accepted_growth_over_estimate": common.target(2.0, ratio, "<="),
    }
    json_path = common.write_json(args.out / "budget.json", result)
    plot(result, args.out / "budget.png")
    for name, r in result["cases"].items():
        common.log(
            f"{name}: refused={r['refused']} in {r['seconds'] * 1e3:.2f} ms, python peak "
            f"{r['python_peak_bytes'] / 2**20:.2f} MiB, RSS +{r['rss_growth_bytes'] / 2**20:.1f} "
            f"MiB (before: {r['before']['seconds']:.0f} s)"
        )
    common.log(
        f"accepted scene: estimate {acc['estimate_bytes'] / 2**20:.1f} MiB, RSS grew "
        f"{acc['rss_growth_bytes'] / 2**20:.1f} MiB in {acc['seconds']:.2f} s"
    )
    for name, t in result["targets"].items():
        common.log(common.show_target(name, t))
    common.log(f"wrote {json_path} and {args.out / 'budget.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
