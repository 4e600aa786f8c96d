"""The physical mode against Mitsuba 3 on more views (``tests/references/mitsuba_views.py``).

The default cumulus back-lit, top-lit and at sunset, a dense metaball cloud and a thin
L-system cloud, each rendered by Mitsuba 3 with cumuli's own phase function tabulated (the
approximate Mie phase of the physical default) and compared with cumuli's physical default (no
haze) on the covered 4×4-pixel blocks, GL and CPU. (The references treat the Mie phase's
diffraction peak, the light scattered within 2.6° of straight on, as unscattered: the δ-M
similarity relation, exact away from the sun's direction and free of the fireflies the peak
gives a path tracer; ``mitsuba_views.phase_table``.) The goal on every view: cloud mean within
±5 %, block median ≤ 10 %, p90 ≤ 25 %, mean |ΔT| ≤ 0.01. Where a view does not reach it,
:data:`GUARDS` holds the measured value with a small margin (a regression guard, not the goal)
and the docs (``docs/fidelity.md``) report the gap.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import cumuli as cu
from cumuli.light import physical as phys
from cumuli.light.physical import phase_values

REFS = Path(__file__).resolve().parents[1] / "references"
sys.path.insert(0, str(REFS))
import mitsuba_views as mv  # noqa: E402

RECORD = json.loads((REFS / "views.json").read_text())
NAMES = [n for n in mv.VIEWS if n in RECORD and mv.view_file(n).exists()]

#: The goal on every view (absolute values of the signed mean error).
GOAL = {"mean_ratio": 0.05, "block_median": 0.10, "block_p90": 0.25, "transmittance": 0.01}

#: Looser bounds where a view misses the goal: the worst of GL and CPU as measured plus a margin
#: of about one point (0.003 for ΔT), keyed by (view, metric); every other pair is held to GOAL.
#: None today: with the constants fitted on the side-lit, back-lit, metaball, top-lit and L-system
#: views (``cumuli.light.physical.FIT_VIEWS``) every view meets the goal on GL (llvmpipe, LLVM
#: 15.0.6) and the CPU twin alike — the held-out sunset view as well (docs/fidelity.md).
GUARDS: dict[tuple[str, str], float] = {}


def bound(view: str, metric: str) -> float:
    return GUARDS.get((view, metric), GOAL[metric])


@pytest.fixture(scope="module", params=NAMES)
def view(request) -> str:
    return request.param


def test_views_are_recorded_small_and_for_todays_medium() -> None:
    assert NAMES == list(mv.VIEWS)  # every view has its reference
    for name in NAMES:
        ref = cu.read_image(mv.view_file(name))
        assert ref.shape == (mv.HEIGHT, mv.WIDTH, 4), name
        rec = RECORD[name]
        assert rec["noise_median_block"] < 0.05, name  # two independent halves
        assert rec["voxel"] == mv.voxel(name), name  # the field's voxels as exported today
        # the reference is at least as good as Mitsuba's own 4-sample image
        assert rec["ladder"]["4"]["block_median"] > rec["noise_median_block"], name
        scene, camera = mv.VIEWS[name]()
        now = scene.settings.to_dict()
        for key in ("extinction_scale", "albedo", "phase", "droplet_diameter", "octaves",
                    "gain", "lacunarity", "frequency", "kappa", "haze"):  # fmt: skip
            assert rec["settings"][key] == now[key], (name, key)
        assert rec["camera"] == json.loads(json.dumps(camera.to_dict())), name
        assert np.allclose(rec["sun"]["direction"], scene.sun.direction), name
        assert (mv.blocks(ref[..., 3]) >= mv.COVERED).sum() >= 100, name


def test_the_phase_table_is_cumulis_phase() -> None:
    """The tabulated phase given to Mitsuba is cumuli's Mie phase outside the forward cone,
    renormalised; the cone's share goes straight on (δ-M)."""
    scene, _ = mv.VIEWS[NAMES[0]]()
    assert scene.settings.phase == "mie"
    c = np.linspace(-1.0, 1.0, mv.PHASE_NODES)
    table, f = mv.phase_table(scene)
    h = c[1] - c[0]
    assert 2 * np.pi * np.sum((table[1:] + table[:-1]) / 2 * h) == pytest.approx(1.0, abs=1e-6)
    assert 0.3 < f < 0.6  # the diffraction peak: nearly half the light within 2.6°
    assert np.all(table[c > mv.PEAK_COS + h] == 0.0)
    probe = np.array([-0.9, -0.3, 0.0, 0.5, 0.9, 0.99])
    expect = phase_values(scene.settings, probe) / (1.0 - f)
    assert np.interp(probe, c, table) == pytest.approx(expect, rel=1e-3)


@pytest.mark.parametrize("backend", ["cpu", pytest.param("gl", marks=pytest.mark.gl)])
def test_physical_default_matches_mitsuba(view: str, backend: str) -> None:
    scene, camera = mv.VIEWS[view]()
    img = cu.render(scene, camera, mv.WIDTH, mv.HEIGHT, backend=backend)
    e = mv.block_errors(img, cu.read_image(mv.view_file(view)))
    report = f"{view}/{backend}: " + ", ".join(f"{k} {v:.4g}" for k, v in e.items())
    assert e["blocks"] >= 100, report
    assert abs(e["mean_ratio"]) <= bound(view, "mean_ratio"), report
    assert e["block_median"] <= bound(view, "block_median"), report
    assert e["block_p90"] <= bound(view, "block_p90"), report
    assert e["transmittance"] <= bound(view, "transmittance"), report


def test_guards_are_only_where_the_goal_is_missed() -> None:
    """A guard is looser than the goal; no guard for a view that is not a reference."""
    for (name, metric), value in GUARDS.items():
        assert name in mv.VIEWS and value > GOAL[metric], (name, metric)


def test_the_fit_and_held_out_views_split_the_references() -> None:
    """The constants were fitted on FIT_VIEWS alone; every other reference view tests them."""
    fit, held = set(phys.FIT_VIEWS), set(phys.HELD_OUT_VIEWS)
    assert fit and held and not fit & held
    assert fit | held == {"sidelit", *mv.VIEWS}
