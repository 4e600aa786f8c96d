"""fBm throughput: C++ core on 1 and 2 threads, GLSL on the headless GL device, pyfastnoiselite.

All methods evaluate 5-octave fBm (w = 1/2, s = 2) at the same random points (uniform in
[-50, 50]³, 1 M of them; 100 k with --quick). Reported per method: median / best / worst wall
time of the repeats, samples per second, and the process CPU time (for single-threaded methods it
gives per-thread speed that is robust to other load on a shared machine). GLSL is timed twice:
the dispatch alone with a GL timer query (GL_TIME_ELAPSED) and the wall time of the whole call
(upload, dispatch, read-back; the program and lattice texture are made once, outside the timing).
On llvmpipe, GLSL is also timed with the driver limited to 1 and 2 threads (Mesa's
``LP_NUM_THREADS``, read when the driver is loaded, so each runs in a child process of this script
started with the variable set): ``glsl_*_1_thread`` / ``glsl_*_2_threads`` and their 2-vs-1 ratios.

pyfastnoiselite (FastNoiseLite, NoiseType_Value, FractalType_FBm, 5 octaves, gen_from_coords) is
the reference point: a hashed value noise, single-threaded (its CPU time equals its wall time;
the JSON records the ratio), timed interleaved with the C++ kernels so that both see the same
machine. pyfastnoisesimd (FastNoiseSIMD, ``NoiseType.ValueFractal`` with FBM, 5 octaves, one
worker, ``genFromCoords``; the best SIMD noise library on PyPI: it hashes its lattice values and
reads no table) is timed beside it, interleaved the same way; where it is not installed (it has
no wheel for Python 3.11 and builds only without pip's build isolation) ``skipped`` says so.

SIMD: the C++ fBm is also timed on 1 thread with every kernel this CPU runs
(``cpp_1_thread_scalar``, and ``cpp_1_thread_<level>_<fetch>`` for each wide level, avx2 and
avx512, and each lattice fetch, gather / loads / cells; interleaved, selected with
``cumuli.noise.set_simd_level`` and ``set_simd_fetch``, each timed call after an untimed one so
that every kernel runs from its own warm caches); "scalar" is the portable kernel (today's
method before the hand-written SIMD paths), the others give bit-identical values. The ratios
``cpp_1_thread_<level>_<fetch>_over_gather`` compare each fetch with the gathers, per CPU-second.
The C++ methods without a kernel in their name (``cpp_1_thread``, ``cpp_2_threads``, GLSL) use
the default noise (``cu.Noise(seed=7)``: version 2, the hash); the fetches time the table of
version 1 (the paper's noise), and ``cpp_1_thread_<level>_hash`` the hash kernel, which computes
the lattice values from a hash of the seed and the texel instead of reading them.
Targets, each ``{limit, comparison, reached, met}``, judge the DEFAULT kernel (the widest level's
kernel for the default noise version: ``<level>_hash``), with a ``baseline`` (value and ratio):
≥ 100 M samples/s per thread and ≥ 7× pyfastnoiselite per thread (CPU time), against today's
scalar path; ≥ 1.0× pyfastnoisesimd's value fBm per thread (CPU time,
``cpp_per_thread_vs_fastnoisesimd``), with the table kernel (version 1, the widest level and
its fetch) as the baseline beside it; ≥ 1.8× from 1 to 2 threads (only meaningful when two
cores are free; the load average is recorded). The thread counts are interleaved with each timed
call after an untimed one of its own (the pool's helper thread awake, as in a run of calls); the
"cold" ratio beside it times each 2-thread call right after a 1-thread one, so it includes waking
the helper from sleep.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _common as common  # noqa: E402

import cumuli as cu  # noqa: E402
from cumuli.noise import SIMD_FETCHES  # noqa: E402

OCTAVES = 5
TARGET_MSPS = 100.0
TARGET_VS_FASTNOISE = 7.0
TARGET_2_THREADS = 1.8
TARGET_VS_FASTNOISESIMD = 1.0
#: llvmpipe thread counts GLSL is timed at (each in a child process with LP_NUM_THREADS set).
LLVMPIPE_THREADS = (1, 2)
#: Command-line flag that makes this script a GLSL timing child (see `glsl_worker`).
WORKER_FLAG = "--glsl-worker"


def random_points(count: int) -> np.ndarray:
    """The benchmark's points: uniform in [-50, 50]³, the same in the parent and its children."""
    return np.random.default_rng(0).uniform(-50.0, 50.0, (count, 3)).astype(np.float32)


def _thread_suffix(n: int) -> str:
    return "1_thread" if n == 1 else f"{n}_threads"


def _method(count: int, wall: list[float], cpu: list[float], **extra: Any) -> dict[str, Any]:
    w = common.spread(wall)
    c = common.spread(cpu)
    return {
        "wall_s": w,
        "cpu_s": c,
        "samples_per_s": common.rate(count, w),
        "samples_per_cpu_s": count / c["min"] if c["min"] > 0 else None,
        "samples_per_cpu_s_median": count / c["median"] if c["median"] > 0 else None,
        "cpu_over_wall": c["median"] / w["median"] if w["median"] > 0 else None,
        **extra,
    }


def bench_cpp(
    noise: cu.Noise, pts: np.ndarray, repeats: int, thread_counts: list[int], settle: int = 1
) -> dict[int, dict[str, Any]]:
    """The C++ fBm on each thread count, repeats interleaved across the counts.

    With ``settle=1`` each timed call follows an untimed one on the same thread count, as in a
    user's run of calls (a light pass, a sweep): the core's pool thread is then awake. With
    ``settle=0`` every 2-thread call follows a 1-thread one, so its helper starts from ≥ 8 ms
    asleep, and waking an idle vCPU can take milliseconds on a shared VM (the "cold" figures).
    """
    timed = common.interleaved_repeats(
        {n: (lambda n=n: noise.fbm(pts, octaves=OCTAVES, threads=n)) for n in thread_counts},
        repeats,
        settle=settle,
    )
    return {n: _method(len(pts), wall, cpu, threads=n) for n, (wall, cpu) in timed.items()}


def bench_simd(
    noise: cu.Noise,
    pts: np.ndarray,
    repeats: int,
    others: dict[str, Callable[[], Any]] | None = None,
    hashed: cu.Noise | None = None,
) -> dict[str, dict[str, Any]]:
    """The C++ fBm on 1 thread with every kernel this CPU runs, repeats interleaved across them
    and with ``others`` (single-threaded methods to compare with, e.g. pyfastnoiselite), so that
    a shared machine's drift touches all alike.

    Keys: ``scalar``, and ``<level>_<fetch>`` for each wide level and lattice fetch
    (``avx2_gather``, ..., ``avx512_cells``), with ``hashed`` (a version-2 noise) its kernel on
    each wide level (``avx2_hash``, ``avx512_hash``), then the keys of ``others``.
    """
    from cumuli.noise import set_simd_fetch, set_simd_level, simd_levels

    def at(level: str, fetch: str) -> Any:
        source = hashed if fetch == "hash" else noise
        assert source is not None

        def run() -> np.ndarray:
            set_simd_level(level)
            set_simd_fetch("auto" if fetch == "hash" else fetch)
            try:
                return source.fbm(pts, octaves=OCTAVES, threads=1)
            finally:
                set_simd_level("auto")
                set_simd_fetch("auto")

        return run

    kernels = {"scalar": ("scalar", "auto")} | {
        f"{lvl}_{fetch}": (lvl, fetch)
        for lvl in simd_levels()
        if lvl != "scalar"
        for fetch in (*SIMD_FETCHES, *(("hash",) if hashed is not None else ()))
    }
    # One untimed call before each timed one: the cells fetch reads a 4.4 MB table of the cells,
    # the others the 1.1 MB lattice, and each would otherwise start from the other's caches.
    fns = {k: at(*v) for k, v in kernels.items()} | (others or {})
    timed = common.interleaved_repeats(fns, repeats, settle=1)
    return {
        k: _method(
            len(pts), wall, cpu, threads=1, simd_level=kernels[k][0],
            simd_fetch=None if k == "scalar" else kernels[k][1],
        ) if k in kernels else _method(len(pts), wall, cpu)
        for k, (wall, cpu) in timed.items()
    }  # fmt: skip


def bench_glsl(noise: cu.Noise, pts: np.ndarray, repeats: int) -> dict[str, Any]:
    from cumuli import gl

    out: dict[str, Any] = {}
    with gl.GLContext() as context, gl.FbmProgram(noise, context) as program:
        for exact in (False, True):
            gpu_ns: list[int] = []
            dispatch: list[float] = []

            def call(
                exact: bool = exact, gpu_ns: list[int] = gpu_ns, dispatch: list[float] = dispatch
            ) -> None:
                program(pts, octaves=OCTAVES, exact=exact)
                gpu_ns.append(int(program.gpu_time_ns or 0))
                dispatch.append(float(program.dispatch_wall_s or 0.0))

            wall, cpu = common.time_repeats(call, repeats)
            query = common.spread([ns * 1e-9 for ns in gpu_ns[-repeats:]])
            disp = common.spread(dispatch[-repeats:])
            # A timer query that reads far less than the dispatch took did not see the work
            # (llvmpipe runs compute synchronously inside glDispatchCompute, outside queries).
            query_valid = query["median"] >= 0.1 * disp["median"]
            key = "glsl_exact" if exact else "glsl_texture"
            out[key] = _method(
                len(pts),
                wall,
                cpu,
                gpu_query_s=query,
                gpu_query_valid=query_valid,
                dispatch_wall_s=disp,
                dispatch_samples_per_s=common.rate(len(pts), disp),
                gpu_samples_per_s=common.rate(len(pts), query if query_valid else disp),
                gpu_time_source="GL timer query" if query_valid else "dispatch → glFinish wall",
                renderer=context.renderer,
                lookup="texelFetch + float weights" if exact else "texture() LINEAR/REPEAT",
            )
    return out


def llvmpipe_threads_running() -> int | None:
    """How many llvmpipe rasteriser threads ("llvmpipe-N") this process runs; None without /proc.

    Mesa starts LP_NUM_THREADS of them when the driver loads, so this confirms that the variable
    took effect (its compute-shader pool has the same size but no telling name).
    """
    tasks = Path("/proc/self/task")
    if not tasks.is_dir():
        return None
    count = 0
    for task in tasks.iterdir():
        try:
            count += (task / "comm").read_text().startswith("llvmpipe-")
        except OSError:
            pass
    return count


def glsl_worker(argv: list[str]) -> int:
    """Child-process mode: time GLSL fBm (`bench_glsl`) and write its methods as JSON.

    Run by `bench_glsl_llvmpipe_threads` with LP_NUM_THREADS in the environment; the points are
    rebuilt from their count with `random_points`, so the child times the parent's points.
    """
    parser = argparse.ArgumentParser(prog=f"bench_noise.py {WORKER_FLAG}")
    parser.add_argument("--points", type=int, required=True)
    parser.add_argument("--repeats", type=int, required=True)
    parser.add_argument("--json", type=Path, required=True)
    args = parser.parse_args(argv)
    methods = bench_glsl(cu.Noise(seed=7), random_points(args.points), args.repeats)
    common.write_json(
        args.json,
        {
            "methods": methods,
            "lp_num_threads": os.environ.get("LP_NUM_THREADS"),
            "llvmpipe_threads_running": llvmpipe_threads_running(),
        },
    )
    return 0


def bench_glsl_llvmpipe_threads(
    count: int, repeats: int, threads: int, timeout: float
) -> dict[str, Any]:
    """GLSL timings (`bench_glsl`) in a child process whose llvmpipe runs on ``threads`` threads.

    Returns the child's methods, each with ``llvmpipe_threads`` (requested) and
    ``llvmpipe_threads_running`` (counted in the child) added. Raises ``RuntimeError`` when the
    child fails.
    """
    env = dict(os.environ, LP_NUM_THREADS=str(threads))
    with tempfile.TemporaryDirectory(prefix="bench_noise_glsl_") as tmp:
        out = Path(tmp) / "glsl.json"
        cmd = [sys.executable, str(Path(__file__).resolve()), WORKER_FLAG]
        cmd += ["--points", str(count), "--repeats", str(repeats), "--json", str(out)]
        res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
        if res.returncode != 0 or not out.is_file():
            tail = (res.stderr or res.stdout).strip().splitlines()[-5:]
            raise RuntimeError(f"GLSL child with LP_NUM_THREADS={threads} failed: {tail}")
        child = json.loads(out.read_text())
    methods: dict[str, Any] = child["methods"]
    for m in methods.values():
        m["llvmpipe_threads"] = threads
        m["llvmpipe_threads_running"] = child["llvmpipe_threads_running"]
    return methods


def fastnoise_call(pts: np.ndarray) -> Callable[[], Any]:
    """pyfastnoiselite's value fBm at ``pts``, as a call to time (ImportError without it)."""
    from pyfastnoiselite.pyfastnoiselite import FastNoiseLite, FractalType, NoiseType

    fnl = FastNoiseLite(7)
    fnl.noise_type = NoiseType.NoiseType_Value
    fnl.fractal_type = FractalType.FractalType_FBm
    fnl.fractal_octaves = OCTAVES
    fnl.fractal_gain = 0.5
    fnl.fractal_lacunarity = 2.0
    fnl.frequency = 1.0
    coords = np.ascontiguousarray(pts.T, dtype=np.float32)  # it wants (3, N)
    return lambda: fnl.gen_from_coords(coords)


def fastnoisesimd_call(pts: np.ndarray) -> Callable[[], Any]:
    """pyfastnoisesimd's value fBm (FastNoiseSIMD, ``NoiseType.ValueFractal``, FBM) at ``pts``
    on one worker thread, as a call to time (ImportError without it)."""
    import pyfastnoisesimd as fns

    noise = fns.Noise(seed=7, numWorkers=1)
    noise.noiseType = fns.NoiseType.ValueFractal
    noise.fractal.fractalType = fns.FractalType.FBM
    noise.fractal.octaves = OCTAVES
    noise.fractal.gain = 0.5
    noise.fractal.lacunarity = 2.0
    noise.frequency = 1.0
    coords = fns.empty_coords(len(pts))  # (3, N), aligned for its SIMD loads
    coords[:] = pts.T
    return lambda: noise.genFromCoords(coords)


#: What each library compared with is, in the JSON.
LIBRARIES = {
    "pyfastnoiselite": ("FastNoiseLite value fBm, gen_from_coords", fastnoise_call),
    "pyfastnoisesimd": (
        "FastNoiseSIMD ValueFractal FBM, genFromCoords, 1 worker",
        fastnoisesimd_call,
    ),
}
#: pyfastnoisesimd has no wheel for Python 3.11: pip builds it, which needs numpy and wheel at
#: build time (``pip install --no-build-isolation pyfastnoisesimd``).
FASTNOISESIMD_HINT = "pip install wheel && pip install --no-build-isolation pyfastnoisesimd"


def plot(result: dict[str, Any], path: Path) -> None:
    plt = common.pyplot()
    methods = result["methods"]
    names = list(methods)
    med = np.array([methods[n]["samples_per_s"]["median"] for n in names]) / 1e6
    lo = med - np.array([methods[n]["samples_per_s"]["worst"] for n in names]) / 1e6
    hi = np.array([methods[n]["samples_per_s"]["best"] for n in names]) / 1e6 - med
    fig, ax = plt.subplots(figsize=(7.5, 3.8))
    ax.bar(names, med, yerr=[lo, hi], capsize=4, color="#6a8fc7", label="wall time")
    gl_names = [n for n in names if "gpu_samples_per_s" in methods[n]]
    if gl_names:
        gpu = [methods[n]["gpu_samples_per_s"]["median"] / 1e6 for n in gl_names]
        ax.scatter(gl_names, gpu, color="#c7506a", zorder=3, label="GPU dispatch only")
    per_cpu = [(methods[n]["samples_per_cpu_s"] or 0) / 1e6 for n in names]
    ax.scatter(names, per_cpu, color="k", marker="x", zorder=3, label="per CPU-second (best)")
    ax.set_ylabel("M samples / s")
    m = result["machine"]
    ax.set_title(
        f"5-octave fBm, {result['points']:,} points\n{m['cpu_model']} ×{m['cores']}; "
        f"GL: {m['gl_renderer'] or 'unavailable'}",
        fontsize=9,
    )
    ax.legend(fontsize=8)
    ax.tick_params(axis="x", labelsize=7)
    plt.setp(ax.get_xticklabels(), rotation=30, ha="right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == [WORKER_FLAG]:
        return glsl_worker(argv[1:])
    args = common.parse_args(__doc__.splitlines()[0], argv)
    count = 100_000 if args.quick else 1_000_000
    repeats = 3 if args.quick else 11
    pts = random_points(count)
    noise = cu.Noise(seed=7)  # the default version: the kernel the targets judge
    table, hashed = cu.Noise(seed=7, version=1), cu.Noise(seed=7, version=2)
    machine = common.machine_info()
    common.log(f"machine: {machine['cpu_model']} ×{machine['cores']}, GL: {machine['gl_renderer']}")

    methods: dict[str, Any] = {}
    skipped: dict[str, str] = {}
    from cumuli.noise import preferred_simd_fetch, simd_fetch, simd_level

    cpp = bench_cpp(noise, pts, repeats, [1, 2] + ([0] if machine["cores"] > 2 else []))
    methods["cpp_1_thread"], methods["cpp_2_threads"] = cpp[1], cpp[2]
    if 0 in cpp:
        methods["cpp_all_threads"] = cpp[0]
    cold = bench_cpp(noise, pts, repeats, [1, 2], settle=0)
    methods["cpp_1_thread_cold"], methods["cpp_2_threads_cold"] = cold[1], cold[2]
    widest, fetch = simd_level(), simd_fetch()
    # The wide kernel of each version: the table's reads with the preferred fetch, the hash's
    # computes its values (the fetch does not apply to it).
    version_fetch = {1: fetch, 2: "hash"}
    for key in ("cpp_1_thread", "cpp_2_threads", "cpp_all_threads"):
        if key in methods:
            methods[key]["simd_level"] = widest
            wide = widest != "scalar"
            methods[key]["simd_fetch"] = version_fetch[noise.version] if wide else None
            methods[key]["noise_version"] = noise.version
    others: dict[str, Callable[[], Any]] = {}
    for name, (_, make) in LIBRARIES.items():
        try:
            others[name] = make(pts)
        except ImportError as exc:
            hint = f"; it builds with `{FASTNOISESIMD_HINT}`" if name == "pyfastnoisesimd" else ""
            skipped[name] = f"not installed ({exc}){hint}"
            common.log(f"{name}: {skipped[name]}")
    simd = bench_simd(table, pts, repeats, others, hashed)
    for name, m in simd.items():
        if name in others:
            methods[name] = m | {"noise": LIBRARIES[name][0]}
        else:
            methods[f"cpp_1_thread_{name}"] = m
    glsl_threads: list[int] = []
    if machine["gl_renderer"]:
        methods.update(bench_glsl(noise, pts, repeats))
        if "llvmpipe" in machine["gl_renderer"].lower():
            for n in LLVMPIPE_THREADS:
                try:
                    child = bench_glsl_llvmpipe_threads(
                        count, repeats, n, timeout=300 if args.quick else 1800
                    )
                except (RuntimeError, subprocess.TimeoutExpired) as exc:
                    skipped[f"glsl_llvmpipe_{_thread_suffix(n)}"] = str(exc)
                    continue
                for key, m in child.items():
                    methods[f"{key}_{_thread_suffix(n)}"] = m
                glsl_threads.append(n)
        else:
            skipped["glsl_llvmpipe_threads"] = (
                f"LP_NUM_THREADS only applies to llvmpipe, the renderer is {machine['gl_renderer']}"
            )
    else:
        skipped["glsl"] = machine.get("gl_unavailable_reason", "no GL")

    def med(name: str) -> float:
        return methods[name]["samples_per_s"]["median"]

    ratios: dict[str, float] = {
        "cpp_2_threads_over_1": med("cpp_2_threads") / med("cpp_1_thread"),
        # Each 2-thread call right after a 1-thread one (its helper thread woken from sleep).
        "cpp_2_threads_over_1_cold": med("cpp_2_threads_cold") / med("cpp_1_thread_cold"),
        # Best of the interleaved repeats: what the two cores give when nothing else runs.
        "cpp_2_threads_over_1_best": methods["cpp_2_threads"]["samples_per_s"]["best"]
        / methods["cpp_1_thread"]["samples_per_s"]["best"],
        # Work per CPU-second with 2 threads relative to 1: near 1 means the threads do not slow
        # each other down, so the wall-time speed-up is limited only by free cores.
        "cpp_2_threads_cpu_efficiency": methods["cpp_2_threads"]["samples_per_cpu_s"]
        / methods["cpp_1_thread"]["samples_per_cpu_s"],
    }
    targets: dict[str, Any] = {}
    # The default kernel (the default noise version's on the widest level) and the table's.
    kernel = f"{widest}_{version_fetch[noise.version]}" if widest != "scalar" else widest
    table_kernel = f"{widest}_{fetch}" if widest != "scalar" else widest
    best, scalar = methods[f"cpp_1_thread_{kernel}"], methods["cpp_1_thread_scalar"]
    table_best = methods[f"cpp_1_thread_{table_kernel}"]
    ratios["cpp_1_thread_widest_over_scalar"] = (
        best["samples_per_s"]["median"] / scalar["samples_per_s"]["median"]
    )
    for lvl in ("avx2", "avx512"):
        # The lattice fetches of one level (same bits), per CPU-second: > 1 where one beats the
        # gathers.
        gather = methods.get(f"cpp_1_thread_{lvl}_gather")
        for other in SIMD_FETCHES[1:]:
            if gather is not None and f"cpp_1_thread_{lvl}_{other}" in methods:
                ratios[f"cpp_1_thread_{lvl}_{other}_over_gather"] = (
                    methods[f"cpp_1_thread_{lvl}_{other}"]["samples_per_cpu_s_median"]
                    / gather["samples_per_cpu_s_median"]
                )
    # The default fetch (the CPU's preferred one) against the fastest fetch of the widest level
    # in this run, per CPU-second: 1 where the preference holds on this machine.
    fetch_rates = {
        f: methods[f"cpp_1_thread_{widest}_{f}"]["samples_per_cpu_s_median"]
        for f in SIMD_FETCHES
        if f"cpp_1_thread_{widest}_{f}" in methods
    }
    if fetch_rates:
        fastest = max(fetch_rates.values())
        ratios["cpp_1_thread_default_fetch_over_fastest"] = (
            table_best["samples_per_cpu_s_median"] / fastest
        )
    # Per thread: samples per CPU-second of the one thread (median of the repeats), which other
    # processes on a shared machine do not dilute; the wall-time rate is recorded beside it.
    targets["cpp_per_thread_msps"] = common.target(
        TARGET_MSPS,
        best["samples_per_cpu_s_median"] / 1e6,
        ">=",
        measure=f"M samples per CPU-second, 1 thread, default kernel {kernel} (noise version "
        f"{noise.version}), median of repeats",
        baseline={
            "method": "scalar",
            "reached": scalar["samples_per_cpu_s_median"] / 1e6,
            "ratio": best["samples_per_cpu_s_median"] / scalar["samples_per_cpu_s_median"],
        },
        reached_best=best["samples_per_cpu_s"] / 1e6,
        reached_wall_median=best["samples_per_s"]["median"] / 1e6,
    )
    if "pyfastnoiselite" in methods:
        ratios["cpp_1_thread_over_fastnoise"] = med("cpp_1_thread") / med("pyfastnoiselite")
        # Per-thread speed from CPU time is robust to other processes on a shared machine.
        fnl_cpu = methods["pyfastnoiselite"]["samples_per_cpu_s"]
        ratios["cpp_1_thread_over_fastnoise_cpu_time"] = (
            methods["cpp_1_thread"]["samples_per_cpu_s"] / fnl_cpu
        )
        # Judged on CPU time: both run on one thread, and CPU seconds do not count the time
        # other processes take the core away (the wall-time ratio is in `ratios` too).
        value = best["samples_per_cpu_s"] / fnl_cpu
        base = scalar["samples_per_cpu_s"] / fnl_cpu
        targets["cpp_per_thread_vs_fastnoise"] = common.target(
            TARGET_VS_FASTNOISE,
            value,
            ">=",
            measure=f"samples per CPU-second, 1 thread each, default kernel {kernel} (noise "
            f"version {noise.version})",
            baseline={"method": "scalar", "reached": base, "ratio": value / base},
        )
    if "pyfastnoisesimd" in methods:
        # The best SIMD noise library's value fBm on one thread (CPU time, as above), against
        # cumuli's default kernel, with the table kernel (version 1) beside it.
        simd_cpu = methods["pyfastnoisesimd"]["samples_per_cpu_s"]
        ratios["cpp_1_thread_over_fastnoisesimd_cpu_time"] = best["samples_per_cpu_s"] / simd_cpu
        ratios["cpp_1_thread_over_fastnoisesimd"] = med("cpp_1_thread") / med("pyfastnoisesimd")
        ratios["table_kernel_over_fastnoisesimd_cpu_time"] = (
            table_best["samples_per_cpu_s"] / simd_cpu
        )
        targets["cpp_per_thread_vs_fastnoisesimd"] = common.target(
            TARGET_VS_FASTNOISESIMD,
            best["samples_per_cpu_s"] / simd_cpu,
            ">=",
            measure=f"samples per CPU-second, 1 thread each, default kernel {kernel} (noise "
            f"version {noise.version}) over FastNoiseSIMD's value fBm, interleaved",
            baseline={
                "method": f"{table_kernel} (version 1, the table)",
                "reached": table_best["samples_per_cpu_s"] / simd_cpu,
                "ratio": best["samples_per_cpu_s"] / table_best["samples_per_cpu_s"],
            },
            reached_median=best["samples_per_cpu_s_median"]
            / methods["pyfastnoisesimd"]["samples_per_cpu_s_median"],
        )
    hash_key = f"cpp_1_thread_{widest}_hash"
    if hash_key in methods:
        ratios["hash_over_table_kernel_cpu_time"] = (
            methods[hash_key]["samples_per_cpu_s"] / table_best["samples_per_cpu_s"]
        )
    targets["cpp_2_threads_over_1"] = common.target(
        TARGET_2_THREADS,
        ratios["cpp_2_threads_over_1"],
        ">=",
        measure="wall-time throughput, median of repeats (1 and 2 threads interleaved, each "
        "timed call after an untimed one of its own)",
        reached_cold=ratios["cpp_2_threads_over_1_cold"],
        reached_best=ratios["cpp_2_threads_over_1_best"],
        note="needs two idle cores; see machine.load_average and cpp_2_threads_cpu_efficiency",
    )
    for key in ("glsl_texture", "glsl_exact"):
        if key in methods:
            ratios[f"{key}_over_cpp_1_thread"] = med(key) / med("cpp_1_thread")
        one, two = f"{key}_1_thread", f"{key}_2_threads"
        if one in methods and two in methods:
            # The dispatch is what llvmpipe spreads over its threads; the whole call adds the
            # single-threaded upload and read-back, so its ratio is the end-to-end one.
            ratios[f"{key}_2_threads_over_1"] = (
                methods[two]["gpu_samples_per_s"]["median"]
                / methods[one]["gpu_samples_per_s"]["median"]
            )
            ratios[f"{key}_2_threads_over_1_wall"] = med(two) / med(one)

    result = {
        "benchmark": "noise",
        "description": "5-octave fBm throughput on random points",
        "quick": args.quick,
        "points": count,
        "repeats": repeats,
        "octaves": OCTAVES,
        "llvmpipe_threads": glsl_threads,
        "simd_level": widest,
        "simd_fetch": fetch,
        "simd_fetch_preferred": preferred_simd_fetch(),
        "machine": machine,
        "methods": methods,
        "skipped": skipped,
        "ratios": ratios,
        "targets": targets,
    }
    json_path = common.write_json(args.out / "noise.json", result)
    plot_path = args.out / "noise.png"
    plot(result, plot_path)

    for name, m in methods.items():
        extra = ""
        if "gpu_samples_per_s" in m:
            extra = (
                f"   (dispatch {m['dispatch_samples_per_s']['median'] / 1e6:.2f} M/s; timer query"
                f" {m['gpu_query_s']['median'] * 1e3:.3f} ms"
                f"{'' if m['gpu_query_valid'] else ' - did not see the compute work'})"
            )
        common.log(
            f"{name:<22} {m['samples_per_s']['median'] / 1e6:7.2f} M samples/s "
            f"(CPU time: {m['samples_per_cpu_s'] / 1e6:6.2f} M/cpu-s){extra}"
        )
    for name, value in ratios.items():
        common.log(f"{name:<44} {value:6.2f}")
    for name, t in targets.items():
        common.log(common.show_target(name, t))
    for name, why in skipped.items():
        common.log(f"skipped {name}: {why}")
    common.log(f"wrote {json_path} and {plot_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
