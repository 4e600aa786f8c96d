"""GLSL ↔ C++ parity for fBm (shaders/common/noise.glsl via cumuli.gl.fbm) and GL hygiene."""

from __future__ import annotations

import os
from pathlib import Path

import moderngl
import numpy as np
import pytest

import cumuli as cu
import cumuli.gl.context as cgl

pytestmark = pytest.mark.gl

F32 = np.float32
PARAMS = [
    {},
    {"octaves": 8, "gain": 0.6, "lacunarity": 1.7, "frequency": 0.37},
    {"octaves": 1, "gain": 1.0, "lacunarity": 1.0, "frequency": 1.0},
]


def _points(n: int, lo: float, hi: float, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(lo, hi, (n, 3)).astype(F32)


def _hardware_tolerance(renderer: str) -> float:
    """Allowed |GLSL texture() − C++| for fBm with Σwⁱ ≤ 1.

    llvmpipe filters R32F textures in float32: its only difference from the C++ is the rounding
    of u/size·size and of the weights, a few float ulps of the result (measured ≤ 2.4e-7 for
    power-of-two sizes), so 1e-6. Hardware GPUs quantise filter weights to 8 fractional bits
    (error ≤ 2⁻⁹ per axis, three axes, times Σwⁱ ≤ 1), so 6e-3 there.
    """
    return 1e-6 if "llvmpipe" in renderer.lower() else 6e-3


@pytest.mark.parametrize("size", [64, 17, 128])
@pytest.mark.parametrize("params", PARAMS)
def test_exact_glsl_matches_cpp(gl_context: cgl.GLContext, size: int, params: dict) -> None:
    noise = cu.Noise(seed=21, size=size)
    pts = np.concatenate([_points(20000, -50, 50), _points(2000, -1.5, 1.5, 1)])
    cpu = noise.fbm(pts, **params)
    gpu = cgl.fbm(noise, pts, exact=True, context=gl_context, **params)
    assert gpu.dtype == np.float32 and gpu.shape == cpu.shape
    # Same float32 operations in the same order; 1e-6 leaves room for a driver that fuses a
    # multiply-add (llvmpipe matches bit for bit).
    np.testing.assert_allclose(gpu, cpu, rtol=0, atol=1e-6)


@pytest.mark.parametrize("size", [64, 128])
@pytest.mark.parametrize("params", PARAMS)
def test_hardware_filtered_glsl_matches_cpp(
    gl_context: cgl.GLContext, size: int, params: dict
) -> None:
    noise = cu.Noise(seed=22, size=size)
    pts = _points(20000, -50, 50, 2)
    cpu = noise.fbm(pts, **params)
    gpu = cgl.fbm(noise, pts, exact=False, context=gl_context, **params)
    tol = _hardware_tolerance(gl_context.renderer)
    np.testing.assert_allclose(gpu, cpu, rtol=0, atol=tol)
    # And it is a real lookup, not a constant: the values spread like the C++ ones.
    assert abs(float(gpu.std()) - float(cpu.std())) < 1e-3


def test_hardware_filter_on_non_power_of_two_size_is_close(gl_context: cgl.GLContext) -> None:
    # texture() takes u/size, which is inexact when size is not a power of two; the error grows
    # with |u| (≈ |u|·2⁻²⁴ texels of weight). Near the origin it stays small.
    noise = cu.Noise(seed=23, size=17)
    pts = _points(5000, -2, 2, 3)
    gpu = cgl.fbm(noise, pts, exact=False, context=gl_context)
    tol = 2e-6 if "llvmpipe" in gl_context.renderer.lower() else 6e-3
    np.testing.assert_allclose(gpu, noise.fbm(pts), rtol=0, atol=tol)


def test_default_context_is_created_once_and_reused() -> None:
    cgl.close_default_context()
    noise = cu.Noise(seed=1, size=8)
    pts = _points(10, -1, 1)
    first = cgl.fbm(noise, pts)
    ctx = cgl.default_context()
    second = cgl.fbm(noise, pts)
    assert cgl.default_context() is ctx and not ctx.closed
    np.testing.assert_array_equal(first, second)
    cgl.close_default_context()
    assert ctx.closed


def test_fbm_releases_every_gl_object_it_makes(
    gl_context: cgl.GLContext, monkeypatch: pytest.MonkeyPatch
) -> None:
    made: list = []
    ctx = gl_context.ctx

    def recording(method_name: str):
        original = getattr(ctx, method_name)

        def make(*args, **kwargs):
            obj = original(*args, **kwargs)
            made.append(obj)
            return obj

        return make

    for name in ("buffer", "texture3d", "compute_shader"):
        monkeypatch.setattr(ctx, name, recording(name))
    noise = cu.Noise(seed=5, size=16)
    cgl.fbm(noise, _points(1000, -5, 5), context=gl_context)
    queries_before = gl_context.timer_query()
    cgl.fbm(noise, _points(10, -5, 5), context=gl_context)
    assert gl_context.timer_query() is queries_before  # one shared query, not one per call
    kinds = {type(o).__name__ for o in made}
    assert {"Buffer", "Texture3D", "ComputeShader"} <= kinds
    assert all(isinstance(o.mglo, moderngl.InvalidObject) for o in made)
    assert not gl_context.closed  # a caller's context is left open


def test_program_reuse_batches_and_gpu_timer(
    gl_context: cgl.GLContext, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Small batches and a tiny work-group limit exercise the multi-batch loop and the
    # two-dimensional dispatch that large inputs need.
    monkeypatch.setattr(cgl, "_FBM_BATCH", 1000)
    monkeypatch.setattr(cgl, "_MAX_GROUPS", 3)
    noise = cu.Noise(seed=6)
    pts = _points(4321, -30, 30)
    with cgl.FbmProgram(noise, gl_context) as program:
        a = program(pts, exact=True)
        assert program.gpu_time_ns is not None and program.gpu_time_ns > 0
        b = program(pts[:7], exact=True)
    np.testing.assert_allclose(a, noise.fbm(pts), atol=1e-6)
    np.testing.assert_array_equal(b, a[:7])
    with pytest.raises(ValueError, match="released"):
        program(pts)


def test_empty_points_and_bad_input(gl_context: cgl.GLContext) -> None:
    noise = cu.Noise(seed=1, size=8)
    assert cgl.fbm(noise, np.zeros((0, 3), F32), context=gl_context).shape == (0,)
    with pytest.raises(ValueError, match="points"):
        cgl.fbm(noise, np.zeros((4, 2)), context=gl_context)
    with pytest.raises(ValueError, match="points"):
        cgl.fbm(noise, np.full((4, 3), np.nan), context=gl_context)
    with pytest.raises(ValueError, match="octaves"):
        cgl.fbm(noise, np.zeros((4, 3)), octaves=0, context=gl_context)
    with pytest.raises(TypeError, match="noise"):
        cgl.fbm(np.zeros((8, 8, 8)), np.zeros((4, 3)), context=gl_context)
    with pytest.raises(TypeError, match="context"):
        cgl.fbm(noise, np.zeros((4, 3)), context="gl")
    with pytest.raises(TypeError, match="exact"):
        cgl.fbm(noise, np.zeros((4, 3)), exact="yes", context=gl_context)
    # float64, non-contiguous input is converted like the C++ path does.
    pts = np.random.default_rng(0).uniform(-3, 3, (50, 6))[:, ::2]
    np.testing.assert_allclose(
        cgl.fbm(noise, pts, exact=True, context=gl_context), noise.fbm(pts), atol=1e-6
    )


def test_closed_context_is_rejected() -> None:
    ctx = cgl.GLContext()
    ctx.close()
    with pytest.raises(ValueError, match="closed"):
        cgl.fbm(cu.Noise(seed=1, size=8), np.zeros((2, 3)), context=ctx)


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc/self/fd")
def test_context_create_close_does_not_leak_file_descriptors() -> None:
    def open_fds() -> int:
        return len(os.listdir("/proc/self/fd"))

    with cgl.GLContext():
        pass  # first context loads the driver, which may keep a few descriptors for good
    before = open_fds()
    for _ in range(15):
        ctx = cgl.GLContext()
        cgl.fbm(cu.Noise(seed=2, size=4), np.zeros((3, 3)), context=ctx)
        ctx.close()
    assert open_fds() == before


@pytest.mark.parametrize("size", [64, 17])
@pytest.mark.parametrize("params", PARAMS)
def test_hash_version_glsl_matches_cpp(gl_context: cgl.GLContext, size: int, params: dict) -> None:
    """Noise version 2: the exact lookup hashes its corners in GLSL as the C++ kernels do in
    registers; the hardware lookup filters the uploaded lattice, which holds the same values."""
    noise = cu.Noise(seed=23, size=size, version=2)
    pts = np.concatenate([_points(20000, -50, 50, 3), _points(2000, -1.5, 1.5, 4)])
    cpu = noise.fbm(pts, **params)
    exact = cgl.fbm(noise, pts, exact=True, context=gl_context, **params)
    np.testing.assert_allclose(exact, cpu, rtol=0, atol=1e-6)
    if size == 64:  # texture() takes u/size, inexact for other sizes (see above)
        hw = cgl.fbm(noise, pts, exact=False, context=gl_context, **params)
        tol = _hardware_tolerance(gl_context.renderer)
        np.testing.assert_allclose(hw, cpu, rtol=0, atol=tol)
    # Not the table's values: the shader did switch versions.
    table = cgl.fbm(
        cu.Noise(seed=23, size=size, version=1), pts, exact=True, context=gl_context, **params
    )
    assert np.abs(table - exact).max() > 1e-2


def test_hash_version_glsl_computes_its_values(gl_context: cgl.GLContext) -> None:
    """The exact lookup of version 2 hashes its corners in the shader: with the uploaded lattice
    texture zeroed it still returns the C++ values, while texture() then reads zeros."""
    noise = cu.Noise(seed=24, size=64, version=2)
    pts = _points(5000, -30, 30, 5)
    with cgl.FbmProgram(noise, gl_context) as program:
        program.texture.write(np.zeros(64**3, dtype=np.float32).tobytes())
        exact = program(pts, exact=True)
        zeroed = program(pts, exact=False)
    np.testing.assert_allclose(exact, noise.fbm(pts), rtol=0, atol=1e-6)
    assert np.abs(zeroed).max() == 0.0
