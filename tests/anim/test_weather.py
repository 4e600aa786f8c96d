"""Weather: climatic variation, wind, destroy/respawn, layers (spec §11.4, items 1–7), Table 1,
fields, save/load."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cumuli.anim import weather_presets
from cumuli.anim.weather import CloudLayer, Schedule, SkyState, Weather, load_weather
from cumuli.model import seedbox_presets as presets
from cumuli.model.billboard_field import BillboardField

AREA = ((-500.0, -500.0), (500.0, 500.0))


@pytest.fixture(scope="module")
def models():
    return presets.cumulus(), presets.nimbus()


def one_layer(models, wind, counts=(100,), cvs=(0.0,), cv=0.0, seed=1, boundary="respawn",
              variants=4, fade_time=10.0) -> Weather:  # fmt: skip
    states = tuple(
        SkyState(c, (models[i % 2],), variants=variants, count=n)
        for i, (c, n) in enumerate(zip(cvs, counts, strict=True))
    )
    layer = CloudLayer(40.0, 8.0, wind, states, boundary=boundary, fade_time=fade_time)
    return Weather(AREA, [layer], cv=cv, seed=seed)


def radii(w: Weather, layer: int = 0) -> np.ndarray:
    return np.asarray(w._radii[layer])


# --- 1. advection -------------------------------------------------------------------------------
def test_advection_is_exact(models) -> None:
    w = one_layer(models, (3.0, -2.0))
    a = w.instances(0)
    t0 = w.t
    for dt in (0.5, 1.25, 0.1, 2.0, 0.15):
        w.step(dt)
    b = w.instances(0)
    common, ia, ib = np.intersect1d(a["id"], b["id"], return_indices=True)
    assert common.size > 50
    dt = w.t - t0
    assert np.allclose(b["x"][ib], a["x"][ia] + 3.0 * dt, rtol=0, atol=1e-9)
    assert np.allclose(b["z"][ib], a["z"][ia] - 2.0 * dt, rtol=0, atol=1e-9)
    assert np.array_equal(b["y"][ib], a["y"][ia]) and np.array_equal(b["yaw"][ib], a["yaw"][ia])


# --- 2. bounds and upwind spawns (χ²) ------------------------------------------------------------
@pytest.mark.parametrize("wind", [(6.0, 8.0), (-9.0, 3.0), (0.0, -5.0)])
def test_spawns_on_upwind_edges_in_proportion(models, wind) -> None:
    w = one_layer(models, wind, counts=(60,))
    (x0, z0), (x1, z1) = AREA
    r = radii(w)
    speed = math.hypot(*wind)
    for _ in range(1500):
        w.step(1.0)
        d = w.instances(0)
        rr = r[d["variant"]]
        assert (d["x"] >= x0 - rr - 1e-9).all() and (d["x"] <= x1 + rr + 1e-9).all()
        assert (d["z"] >= z0 - rr - 1e-9).all() and (d["z"] <= z1 + rr + 1e-9).all()
        new = d["t0"] == w.t  # spawned in this step: still at the spawn point
        st = w.layer_stats(0)
        assert int(new.sum()) == len(st["last_spawn_edge"])
        for x, z, rad in zip(d["x"][new], d["z"][new], rr[new], strict=True):
            on = [
                wind[0] > 0 and x == x0 - rad and z0 <= z <= z1,
                wind[0] < 0 and x == x1 + rad and z0 <= z <= z1,
                wind[1] > 0 and z == z0 - rad and x0 <= x <= x1,
                wind[1] < 0 and z == z1 + rad and x0 <= x <= x1,
            ]
            assert any(on)  # R outside an upwind edge
    edges = np.array(w.layer_stats(0)["spawn_edges"], dtype=float)
    weights = np.array([max(wind[0], 0) * 1000, max(-wind[0], 0) * 1000,
                        max(wind[1], 0) * 1000, max(-wind[1], 0) * 1000]) / speed  # fmt: skip
    up = weights > 0
    assert (edges[~up] == 0).all()
    expected = edges.sum() * weights[up] / weights[up].sum()
    chi2 = float(((edges[up] - expected) ** 2 / expected).sum())
    assert edges.sum() > 200
    dof = int(up.sum()) - 1
    if dof:
        assert chi2 < {1: 10.83, 2: 13.82, 3: 16.27}[dof]  # p = 0.001


# --- 3. counts at constant CV --------------------------------------------------------------------
@pytest.mark.parametrize("wind,n_star", [((10.0, 0.0), 100), ((6.0, 8.0), 100), ((0.0, -5.0), 400),
                                         ((3.0, 0.0), 20), ((-3.0, -9.0), 100)])  # fmt: skip
def test_counts_follow_the_target(models, wind, n_star) -> None:
    w = one_layer(models, wind, counts=(n_star,))
    transit = 1000.0 / (abs(wind[0]) + abs(wind[1]))
    dt = 1.0
    for _ in range(int(transit / dt)):
        w.step(dt)
    counts = []
    for _ in range(int(3 * transit / dt)):
        w.step(dt)
        n = sum(w.counts()[0])
        counts.append(n)
        assert n_star - 2 * math.sqrt(n_star) <= n <= n_star
    assert abs(np.mean(counts) - n_star) <= max(0.02 * n_star, 2.0)


# --- 4. composition after a CV step -------------------------------------------------------------
def test_composition_after_a_cv_step(models) -> None:
    wind = (10.0, 0.0)
    states = (SkyState(0.0, (models[0],), variants=3, count=300),
              SkyState(1.0, (models[1],), variants=3, count=300))  # fmt: skip
    sched = Schedule([(0.0, 0.2), (50.0, 0.2), (50.001, 0.7)])
    w = Weather(AREA, [CloudLayer(40.0, 8.0, wind, states)], cv=sched, seed=5)
    n0 = w.counts()[0]
    assert abs(n0[1] / sum(n0) - 0.2) < 3 * math.sqrt(0.2 * 0.8 / sum(n0))
    for _ in range(50 + 2 * 100 + 20):  # the step, then > 2 transit times (100 s each)
        w.step(1.0)
    n = np.array(w.counts()[0])
    frac = n[1] / n.sum()
    assert abs(frac - 0.7) <= 3 * math.sqrt(0.7 * 0.3 / n.sum())
    assert w.cv == pytest.approx(0.7)


# --- 5. Table 1 ----------------------------------------------------------------------------------
def test_table1_targets_exact() -> None:
    w = weather_presets.table1(seed=0)
    high, low = w.layers
    assert [s.count for s in high.states] == [50, 100]
    assert [s.count for s in low.states] == [100, 200, 400]
    assert [len(s.models) for s in low.states] == [3, 3, 3] and high.states[0].variants == 10
    expect = {0.0: (50, 100), 0.25: (75, 150), 0.5: (100, 200), 0.75: (100, 300), 1.0: (100, 400)}
    for cv, (a, b) in expect.items():
        assert (high.target(cv), low.target(cv)) == (a, b)
        assert (w._sim.target(0, cv), w._sim.target(1, cv)) == (a, b)
    for cv in np.linspace(0.5, 1.0, 11):
        assert high.target(cv) == 100  # the upper layer clamps at Sky 2
    assert [sum(c) for c in w.counts()] == [50, 100]  # populated at t = 0
    assert w.schedule(300.0) == pytest.approx(0.5) and w.schedule(900.0) == 1.0
    assert len(w.variants[0]) == 20 and len(w.variants[1]) == 90
    for _ in range(300):
        w.step(1.0)
    assert w.targets() == [100, 200]
    f = w.fields()
    assert [x.n for x in f] == [sum(c) for c in w.counts()]
    assert isinstance(f[1], BillboardField) and f[1].kind == "billboard_field"
    d = w.instances(1)
    assert np.allclose(f[1].offsets[:, 0], d["x"]) and np.array_equal(f[1].state, d["state"])
    assert (abs(f[1].offsets[:, 1] - 40.0) <= 4.0).all()
    sky, scale = w.sky()
    assert 0.5 <= scale <= 1.0


# --- 6. zero wind --------------------------------------------------------------------------------
def test_zero_wind_fades(models) -> None:
    sched = Schedule([(0.0, 0.0), (20.0, 1.0), (40.0, 1.0), (60.0, 0.0)])
    w = one_layer(models, (0.0, 0.0), counts=(30, 80), cvs=(0.0, 1.0), cv=sched, fade_time=5.0)
    start = w.instances(0)
    for _ in range(100):
        w.step(0.5)
        d = w.instances(0)
        common, ia, ib = np.intersect1d(start["id"], d["id"], return_indices=True)
        assert np.array_equal(d["x"][ib], start["x"][ia])  # nothing moves
        live = sum(w.counts()[0])
        assert live == w.targets()[0]
        fading_in = np.isfinite(d["fade_in"])
        ages = w.t - d["fade_in"][fading_in]
        steady = np.isinf(d["fade_out"][fading_in])
        alpha_in = d["alpha"][fading_in & np.isinf(d["fade_out"])]
        assert np.allclose(alpha_in, np.clip(ages[steady] / 5.0, 0, 1))
        out = np.isfinite(d["fade_out"])
        assert (w.t - d["fade_out"][out] < 5.0 + 1e-9).all()  # removed once faded
    st = w.layer_stats(0)
    assert st["faded_out"] > 0 and st["spawn_edges"] == [0, 0, 0, 0]


def test_wrap_keeps_the_count_exact(models) -> None:
    w = one_layer(models, (8.0, 3.0), counts=(50,), boundary="wrap")
    for _ in range(400):
        w.step(1.0)
        assert sum(w.counts()[0]) == 50
    st = w.layer_stats(0)
    assert st["wrapped"] > 20 and st["destroyed"] == 0


# --- 7. determinism, save/load ----------------------------------------------------------------
def dts(n: int) -> list[float]:
    return [0.25 + 0.5 * ((k * 7) % 5) for k in range(n)]


def same_state(a: Weather, b: Weather) -> bool:
    for i in range(len(a.layers)):
        x, y = a.instances(i), b.instances(i)
        if not all(np.array_equal(x[k], y[k]) for k in x):
            return False
        sx, sy = a.layer_stats(i), b.layer_stats(i)
        if any(sx[k] != sy[k] for k in ("quota", "events", "spawn_edges", "destroyed")):
            return False
    return a.t == b.t


def test_determinism_and_save_load(tmp_path) -> None:
    a, b = weather_presets.table1(seed=4), weather_presets.table1(seed=4)
    for dt in dts(40):
        a.step(dt)
        b.step(dt)
    assert same_state(a, b)
    c = weather_presets.table1(seed=5)
    for dt in dts(40):
        c.step(dt)
    assert not same_state(a, c)
    path = a.save(tmp_path / "sky.npz")
    loaded = load_weather(path)
    assert same_state(a, loaded) and loaded.to_dict() == a.to_dict()
    for dt in dts(60):
        a.step(dt)
        loaded.step(dt)
    assert same_state(a, loaded)
    fa, fl = a.fields(), loaded.fields()
    for x, y in zip(fa, fl, strict=True):
        assert np.array_equal(x.offsets, y.offsets) and np.array_equal(x.alpha, y.alpha)
        assert all(np.array_equal(p.centres, q.centres) for p, q in zip(x.variants, y.variants,
                                                                        strict=True))  # fmt: skip
    assert not [p for p in tmp_path.iterdir() if ".tmp" in p.name]


def test_three_layers_and_schedule() -> None:
    w = weather_presets.three_layers(seed=1)
    assert len(w.layers) == 3 and len({layer.altitude for layer in w.layers}) == 3
    for _ in range(10):
        w.step(1.0)
    ys = [f.offsets[:, 1].mean() for f in w.fields()]
    assert ys[0] > ys[1] > ys[2]
    s = Schedule([(0.0, 0.0), (10.0, 1.0)])
    assert s(-5) == 0.0 and s(5) == 0.5 and s(50) == 1.0 and Schedule(0.3)(100) == 0.3


def test_weather_does_not_depend_on_threads(models) -> None:
    state = SkyState(0.0, models, variants=3, count=40)
    layer = CloudLayer(40.0, 8.0, (4.0, 1.0), (state,))
    a = Weather(AREA, [layer], cv=0.0, seed=9, threads=1)
    b = Weather(AREA, [layer], cv=0.0, seed=9, threads=0)
    for dt in dts(30):
        a.step(dt)
        b.step(dt)
    assert same_state(a, b)
    for p, q in zip(a.variants[0], b.variants[0], strict=True):
        assert np.array_equal(p.centres, q.centres) and np.array_equal(p.boxes, q.boxes)
