"""CAF and billboard shading (spec §11.2, items 1–7), against a numpy reference and limit cases;
field CAFs with shadows between clouds; the comparison with cumuli's NDT light grid."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cumuli.light.caf import (
    BillboardShading,
    absorption_factors,
    field_absorption_factors,
    light_grid_at_boxes,
    quad_corners,
    rank_correlation,
    shade_points,
    vertex_colours,
)
from cumuli.model import seedbox_presets as presets
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BasisModel, BillboardCloud, SeedBox, seed_box_cloud
from cumuli.sky import Sun


def cloud_of(boxes, centres=None, box=None) -> BillboardCloud:
    b = np.asarray(boxes, dtype=np.float32)
    m = b.shape[0]
    if centres is None:
        centres = 0.5 * (b[:, 0] + b[:, 1])
        box = np.arange(m)
    centres = np.asarray(centres, np.float32)
    k = centres.shape[0]
    return BillboardCloud(
        boxes=b, box_level=np.zeros(m), box_seed=np.arange(m), box_direction=-np.ones(m),
        centres=centres, sizes=np.ones((k, 2)), texture=np.zeros(k), box=box,
        rotation=np.zeros(k),
    )  # fmt: skip


def reference_lengths(boxes, points, sun, overlap, owner=None):
    """numpy slab test: L per point (sum of chords or length of their union)."""
    boxes = np.asarray(boxes, np.float64)
    s = np.asarray(sun, np.float64)
    s = s / np.linalg.norm(s)
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for i, p in enumerate(np.asarray(points, np.float64)):
            t0 = np.full(boxes.shape[0], -np.inf)
            t1 = np.full(boxes.shape[0], np.inf)
            for k in range(3):
                lo, hi = boxes[:, 0, k], boxes[:, 1, k]
                if s[k] == 0.0:  # parallel to the slab: inside it or a miss
                    inside = (p[k] >= lo) & (p[k] <= hi)
                    t0 = np.where(inside, t0, np.inf)
                    continue
                ta, tb = (lo - p[k]) / s[k], (hi - p[k]) / s[k]
                t0 = np.maximum(t0, np.minimum(ta, tb))
                t1 = np.minimum(t1, np.maximum(ta, tb))
            hit = (t0 <= t1) & (t1 > 0)
            if owner is not None and owner[i] >= 0:
                hit[owner[i]] = False
            spans = sorted(zip(np.maximum(t0[hit], 0), t1[hit], strict=True))
            if overlap == "sum":
                out.append(sum(b - a for a, b in spans))
            else:
                total, cur = 0.0, None
                for a, b in spans:
                    if cur is not None and a <= cur[1]:
                        cur[1] = max(cur[1], b)
                    else:
                        if cur is not None:
                            total += cur[1] - cur[0]
                        cur = [a, b]
                if cur is not None:
                    total += cur[1] - cur[0]
                out.append(total)
    return np.array(out)


# --- 11.2.1–3 analytic path lengths ------------------------------------------------------------
def test_one_box_sun_up() -> None:
    h = 3.0
    c = cloud_of([[[-1, 0, -2], [1, h, 2]]])
    lt = absorption_factors(c, (0, 1, 0), max_distance=10.0)
    assert lt.length[0] == pytest.approx(h / 2, abs=1e-6)
    assert lt.caf[0] == pytest.approx(1 - h / (2 * 10.0), abs=1e-6)
    assert absorption_factors(c, (0, 1, 0), include_self=False).length[0] == 0.0


def test_two_stacked_boxes_sun_up() -> None:
    h = 2.0
    c = cloud_of([[[0, 0, 0], [1, h, 1]], [[0, h, 0], [1, 2 * h, 1]]])
    for overlap in ("sum", "union"):
        lt = absorption_factors(c, Sun((0, 1, 0)), max_distance=100.0, overlap=overlap)
        assert lt.length == pytest.approx([3 * h / 2, h / 2], abs=1e-6)


def test_oblique_sun_matches_the_slab_chords() -> None:
    # One box (2a, 2b, 2c) from its centre: exit at min_k half_k / |s_k|.
    a, b, cc = 2.0, 1.0, 3.0
    s = np.array([0.5, 0.7, -0.3])
    s /= np.linalg.norm(s)
    c = cloud_of([[[-a, -b, -cc], [a, b, cc]]])
    expect = min(a / abs(s[0]), b / abs(s[1]), cc / abs(s[2]))
    assert absorption_factors(c, s).length[0] == pytest.approx(expect, rel=1e-6)
    # A second box on the ray: the analytic chord through it is added.
    off = 12 * s
    c2 = cloud_of([[[-a, -b, -cc], [a, b, cc]], [off - [a, b, cc], off + [a, b, cc]]])
    lt = absorption_factors(c2, s)
    assert lt.length[0] == pytest.approx(expect + 2 * expect, rel=1e-5)


@pytest.mark.parametrize("n_boxes", [12, 300])  # brute force and the uniform grid
def test_matches_numpy_reference(n_boxes: int) -> None:
    rng = np.random.default_rng(n_boxes)
    centres = rng.normal(scale=6.0, size=(n_boxes, 3))
    half = rng.uniform(0.3, 2.0, size=(n_boxes, 3))
    boxes = np.stack([centres - half, centres + half], axis=1).astype(np.float32)
    c = cloud_of(boxes)
    for sun in ([0.3, 0.8, 0.2], [0, 1, 0], [-0.6, 0.2, 0.77]):
        for overlap in ("sum", "union"):
            for include_self in (True, False):
                lt = absorption_factors(c, sun, overlap=overlap, include_self=include_self)
                owner = None if include_self else np.arange(n_boxes)
                ref = reference_lengths(boxes, c.box_centres, sun, overlap, owner)
                assert np.allclose(lt.length, ref, rtol=1e-5, atol=1e-4)


# --- 11.2.4 sum vs union, ranges, limits, monotone along a column -------------------------------
def test_sum_union_limits_and_monotone_column() -> None:
    c = seed_box_cloud(presets.nimbus(), 3)
    sun = (0.2, 0.9, -0.3)
    s = absorption_factors(c, sun, overlap="sum")
    u = absorption_factors(c, sun, overlap="union")
    assert (s.length >= u.length - 1e-9).all() and (s.length > u.length + 1e-3).any()
    assert (s.caf <= u.caf + 1e-7).all()
    for lt in (s, u):
        assert lt.caf.min() >= 0 and lt.caf.max() <= 1
    assert (absorption_factors(c, sun, max_distance=math.inf).caf == 1).all()
    tiny = absorption_factors(c, sun, max_distance=1e-3)
    assert (tiny.caf[tiny.length >= 1e-3] == 0).all()
    e = absorption_factors(c, sun, max_distance=5.0, curve="exp")
    assert np.allclose(e.caf, np.exp(-3 * e.length / 5.0), rtol=1e-6)
    # Disjoint boxes: sum == union.
    d = cloud_of([[[0, 0, 0], [1, 1, 1]], [[0, 3, 0], [1, 4, 1]], [[0, 7, 0], [1, 9, 1]]])
    assert np.array_equal(
        absorption_factors(d, (0, 1, 0)).length,
        absorption_factors(d, (0, 1, 0), overlap="union").length,
    )
    # A column of touching boxes, points along the light direction: CAF never decreases upwards.
    col = cloud_of([[[0, y, 0], [1, y + 1.0, 1]] for y in range(8)],
                   centres=[[0.5, y, 0.5] for y in np.linspace(0.05, 7.95, 40)],
                   box=np.minimum((np.linspace(0.05, 7.95, 40)).astype(int), 7))  # fmt: skip
    caf = absorption_factors(col, (0, 1, 0), max_distance=9.0, at="billboard").caf
    assert (np.diff(caf) >= 0).all() and caf[0] < caf[-1]


# --- 11.2.5 invariances --------------------------------------------------------------------------
def test_translation_and_quarter_turn_invariance() -> None:
    c = seed_box_cloud(presets.cumulus(), 11)
    sun = np.array([0.35, 0.8, -0.45])
    base = absorption_factors(c, sun, max_distance=20.0)
    moved = absorption_factors(c.translated((123.0, -7.0, 55.0)), sun, max_distance=20.0)
    assert np.allclose(moved.caf, base.caf, atol=2e-5)
    turned = c.rotated_y(90, about=(0, 0, 0))
    sun_t = np.array([sun[2], sun[1], -sun[0]])  # the same rotation x' = z, z' = -x
    rot = absorption_factors(turned, sun_t, max_distance=20.0)
    assert np.allclose(rot.caf, base.caf, atol=1e-6)


# --- 11.2.6–7 directional term and colour --------------------------------------------------------
def test_directional_term_and_ambient_only_colour() -> None:
    c = seed_box_cloud(presets.cumulus(), 1)
    sun = Sun((0.0, 0.6, 0.8), colour=(1.0, 0.9, 0.8), intensity=2.0)
    centre = c.centre.astype(np.float64)
    s = np.array(sun.direction)
    perp = np.cross(s, [1.0, 0, 0])
    perp /= np.linalg.norm(perp)
    pts = np.array([centre + 5 * s, centre - 5 * s, centre + 5 * perp, centre], np.float32)
    bb = np.zeros(4, dtype=np.int64)
    sh = BillboardShading(d_min=0.2, d_max=0.9, k_amb=0.0)
    full = absorption_factors(c, sun, max_distance=math.inf)
    col = shade_points(c, pts, bb, sun, full, sh)
    rad = np.array(sun.radiance)
    d = col / rad
    assert np.allclose(d[0], 0.9, atol=1e-6) and np.allclose(d[1], 0.2, atol=1e-6)
    assert np.allclose(d[2], 0.55, atol=1e-6) and np.allclose(d[3], 0.55, atol=1e-6)
    k2 = shade_points(
        c, pts, bb, sun, full, BillboardShading(d_min=0.2, d_max=0.9, k_amb=0.0, k_dir=2.0)
    )
    assert np.allclose(k2[2] / rad, 0.2 + 0.7 * 0.25, atol=1e-6)
    # CAF = 0 everywhere: exactly the ambient colour.
    dark = absorption_factors(c, sun, max_distance=1e-6)
    assert (dark.caf == 0).all()
    sh2 = BillboardShading(ambient=(0.3, 0.4, 0.5), k_amb=0.7)
    amb = shade_points(c, pts, bb, sun, dark, sh2)
    assert (amb == np.float32(0.7) * np.array([0.3, 0.4, 0.5], np.float32)).all()
    # Default ambient: the sky's mean.
    from cumuli.sky import Sky

    sky = Sky.sunset()
    assert BillboardShading().ambient_colour(sky) == pytest.approx(
        tuple(0.5 * (np.array(sky.zenith) + np.array(sky.horizon)))
    )


def test_vertex_colours_match_a_numpy_reference() -> None:
    c = seed_box_cloud(presets.nimbus(), 5)
    sun = Sun((0.3, 0.8, 0.2), colour=(1.0, 0.95, 0.9))
    sky_light = Sun((0.0, 1.0, 0.0), colour=(0.2, 0.3, 0.5))
    lt = absorption_factors(c, sun)
    lt2 = absorption_factors(c, sky_light)
    right, up = np.array([0.8, 0.0, -0.6]), np.array([0.0, 1.0, 0.0])
    sh = BillboardShading(height_levels=((0.0, 0.6), (0.5, 0.9), (1.0, 1.0)), k_dir=1.5)
    got = vertex_colours(c, sun, lt, right, up, sh, extra=[(sky_light, lt2)])
    corners = quad_corners(c, right, up).astype(np.float64)
    # corners: v0 = p − ½w r′ − ½h u′ ...
    rho = np.radians(c.rotation.astype(np.float64))[:, None]
    r2 = np.cos(rho) * right + np.sin(rho) * up
    u2 = -np.sin(rho) * right + np.cos(rho) * up
    w, h = c.sizes[:, :1].astype(np.float64), c.sizes[:, 1:].astype(np.float64)
    v0 = c.centres - 0.5 * w * r2 - 0.5 * h * u2
    v2 = c.centres + 0.5 * w * r2 + 0.5 * h * u2
    assert np.allclose(corners[:, 0], v0, atol=1e-4) and np.allclose(corners[:, 2], v2, atol=1e-4)
    lo, hi = c.box_bounds()
    cc = 0.5 * (lo.astype(np.float64) + hi)
    f = (corners[..., 1] - lo[1]) / (hi[1] - lo[1])
    hfac = np.interp(f, [0.0, 0.5, 1.0], [0.6, 0.9, 1.0])
    amb = 0.5 * np.array(sh.ambient_colour())
    ref = np.zeros(corners.shape)
    for s, light in ((sun, lt), (sky_light, lt2)):
        off = corners - cc
        cosphi = (off @ np.array(s.direction)) / np.linalg.norm(off, axis=-1)
        d = 0.25 + 0.75 * ((1 + cosphi) / 2) ** 1.5
        ref += (light.caf[c.box][:, None] * d)[..., None] * np.array(s.radiance)
    ref = amb + hfac[..., None] * ref
    assert got.shape == (c.n_billboards, 4, 3)
    assert np.allclose(got, ref, atol=2e-5)


def test_light_record_checks_cloud_and_sun() -> None:
    c = seed_box_cloud(presets.cumulus(), 1)
    sun = Sun((0.3, 0.8, 0.2))
    lt = absorption_factors(c, sun)
    with pytest.raises(ValueError, match="another sun"):
        vertex_colours(c, Sun((0.8, 0.3, 0.2)), lt, (1, 0, 0), (0, 1, 0))
    with pytest.raises(ValueError, match="another cloud"):
        vertex_colours(seed_box_cloud(presets.cumulus(), 2), sun, lt, (1, 0, 0), (0, 1, 0))
    assert not lt.caf.flags.writeable
    assert not hasattr(c, "caf")  # never stored on the cloud


def test_per_billboard_caf_and_threads() -> None:
    c = seed_box_cloud(presets.rain(), 2)
    a = absorption_factors(c, (0.3, 0.9, 0.1), at="billboard", threads=1)
    b = absorption_factors(c, (0.3, 0.9, 0.1), at="billboard", threads=0)
    assert a.caf.shape == (c.n_billboards,) and np.array_equal(a.length, b.length)
    ref = reference_lengths(c.boxes, c.centres, (0.3, 0.9, 0.1), "sum")
    assert np.allclose(a.length, ref, rtol=1e-5, atol=1e-4)
    assert np.array_equal(a.billboard_caf(c), a.caf)
    box = absorption_factors(c, (0.3, 0.9, 0.1))
    assert np.array_equal(box.billboard_caf(c), box.caf[c.box])


# --- fields --------------------------------------------------------------------------------------
def test_field_caf_matches_clouds_and_shadows_between_clouds() -> None:
    v = seed_box_cloud(presets.cumulus(), 4)
    v = v.translated(-v.centre.astype(np.float64))
    sun = np.array([0.0, 1.0, 0.0])
    field = BillboardField([v], [[0, 0, 0], [100, 0, 0], [0, 30, 0]], yaw=[0, 90, 0])
    fl = field_absorption_factors(field, sun, max_distance=20.0)
    own = absorption_factors(v, sun, max_distance=20.0)
    assert np.allclose(fl.instance(0), own.caf) and np.allclose(fl.instance(2), own.caf)
    turned = absorption_factors(v.rotated_y(90, about=(0, 0, 0)), sun, max_distance=20.0)
    assert np.allclose(fl.instance(1), turned.caf, atol=1e-6)
    shadow = field_absorption_factors(field, sun, max_distance=20.0, shadow_between_clouds=True)
    # Instance 2 sits 30 units above instance 0 (same boxes): each box of 0 now also crosses its
    # own copy above (its full height), the others are unchanged.
    block = slice(int(shadow.first[0]), int(shadow.first[1]))
    extra = shadow.length[block] - fl.length[block]
    heights = (v.boxes[:, 1, 1] - v.boxes[:, 0, 1]).astype(np.float64)
    assert (extra >= heights - 1e-4).all()
    assert (shadow.instance(0) <= fl.instance(0)).all() and shadow.instance(0).sum() < fl.instance(
        0
    ).sum()
    assert np.array_equal(shadow.instance(1), fl.instance(1))
    assert np.array_equal(shadow.instance(2), fl.instance(2))
    again = field_absorption_factors(field, sun, max_distance=20.0, shadow_between_clouds=True,
                                     threads=1)  # fmt: skip
    assert np.array_equal(again.length, shadow.length)


# --- CAF vs the NDT light grid of the same boxes as ellipsoids -----------------------------------
@pytest.mark.parametrize("sun", [(0.3, 0.8, 0.2), (0.0, 1.0, 0.0), (-0.7, 0.4, 0.3)])
def test_caf_ranks_like_the_ndt_light_grid(sun) -> None:
    # The spec's default seed box (3 directions, reach ‖h‖): boxes overlap less than in the
    # compact cumulus preset, where "sum" counts more overlap twice (ρ ≈ 0.67 there).
    seed = SeedBox(levels=3, boxes_per_level=(1, 3), child_scale=(0.6, 1.0), flat_base=True)
    c = seed_box_cloud(BasisModel((seed,)), 3)
    caf = absorption_factors(c, sun, overlap="union").caf
    grid = light_grid_at_boxes(c, sun, resolution=20)
    rho = rank_correlation(caf, grid)
    assert rho > 0.8, rho
    assert rank_correlation(absorption_factors(c, sun).caf, grid) > 0.7


def test_shading_settings_round_trip() -> None:
    sh = BillboardShading(
        d_min=0.1, ambient=(0.2, 0.3, 0.4), height_levels=((0.0, 0.5), (1.0, 1.0)),
        max_distance=math.inf, overlap="union", caf_at="billboard", shading="fragment",
    )  # fmt: skip
    d = sh.to_dict()
    assert d["max_distance"] == "inf"
    import json

    assert BillboardShading.from_dict(json.loads(json.dumps(d))) == sh
    assert BillboardShading() == BillboardShading.from_dict(BillboardShading().to_dict())


def test_instance_vertex_colours_match_the_placed_cloud() -> None:
    from cumuli.light.caf import instance_vertex_colours

    v = seed_box_cloud(presets.nimbus(), 2)
    v = v.translated(-v.centre.astype(np.float64))
    field = BillboardField([v], [[10, 40, -5], [200, 44, 30]], yaw=[90, 180])
    sun = Sun((0.4, 0.8, -0.3))
    fl = field_absorption_factors(field, sun, max_distance=15.0)
    right, up = (0.6, 0.0, 0.8), (0.0, 1.0, 0.0)
    for i in range(2):
        placed = v.rotated_y(float(field.yaw[i]), about=(0, 0, 0)).translated(field.offsets[i])
        ref = vertex_colours(placed, sun, absorption_factors(placed, sun, max_distance=15.0),
                             right, up)  # fmt: skip
        got = instance_vertex_colours(field, i, sun, fl, right, up)
        assert np.allclose(got, ref, atol=1e-5)
    with pytest.raises(ValueError, match="another sun"):
        instance_vertex_colours(field, 0, Sun((0, 1, 0)), fl, right, up)
