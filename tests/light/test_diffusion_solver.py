"""The diffusion's linear solve (``_core.diffusion_light``'s ``solver``): conjugate gradients
preconditioned by the modified incomplete Cholesky factor over the medium cells (``"mic"``, the
physical light's default) against the Jacobi-preconditioned solve over the whole lattice
(``"jacobi"``): the same fluence on several clouds, the same result on any thread count, empty
and one-cell media, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

import cumuli as cu
from cumuli import _core
from cumuli.demo import cumulus_scene
from cumuli.light import physical as phys

F = np.float32


def diffusion_inputs(cloud: cu.Cloud, resolution: int = 24) -> dict:
    """The arguments `physical_light` gives the diffusion for ``cloud`` in the demo's light."""
    scene = cumulus_scene(settings=cu.RenderSettings(physical_resolution=resolution))
    scene = scene.replace(clouds=[cloud])
    seen: dict = {}
    solve = phys._core.diffusion_light

    def spy(*args, **kw):
        seen["args"], seen["kw"] = args, kw
        return solve(*args, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(phys._core, "diffusion_light", spy)
        phys.physical_light(scene.clouds[0], scene, threads=1)
    ext, lo, hi, sun_t, to_sun, sky_e, albedo, g = seen["args"][:8]
    return dict(ext=ext, lo=lo, hi=hi, sun_t=sun_t, to_sun=to_sun, sky_e=sky_e, albedo=albedo,
                g=g, forward=seen["kw"]["forward"])  # fmt: skip


def solve(a: dict, solver: str, tolerance: float, threads: int = 1, sky: bool = True):
    return _core.diffusion_light(
        a["ext"], a["lo"], a["hi"], a["sun_t"], a["to_sun"], a["sky_e"] if sky else None,
        a["albedo"], a["g"], tolerance, threads, forward=a["forward"], solver=solver,
    )  # fmt: skip


CLOUDS = {
    "cumulus": lambda: cumulus_scene().clouds[0],
    "seed 2": lambda: cu.gaussian_cumulus(seed=2),
    "metaball": lambda: cu.metaball_cumulus(seed=3),
}


@pytest.mark.parametrize("name", list(CLOUDS))
def test_mic_converges_to_the_jacobi_solve(name: str) -> None:
    """Both solves tightly converged agree to 1e-4 of the fluence's scale in every channel; at
    the light step's tolerance the MIC solve is within 1 % of the converged fluence, no farther
    than the Jacobi solve at the same tolerance (plus a point)."""
    a = diffusion_inputs(CLOUDS[name]())
    exact = solve(a, "jacobi", 1e-7)
    tight = solve(a, "mic", 1e-7)
    scale = exact.reshape(-1, 4).max(axis=0)
    assert np.all(scale > 0.0)
    assert np.max(np.abs(tight - exact) / scale) < 1e-4
    tol = phys.DIFFUSION_TOLERANCE
    err_mic = np.max(np.abs(solve(a, "mic", tol) - exact) / scale)
    err_jac = np.max(np.abs(solve(a, "jacobi", tol) - exact) / scale)
    assert err_mic < 0.01
    assert err_mic <= err_jac + 0.01


def test_mic_is_the_light_steps_solve() -> None:
    """The physical light uses the MIC solve; the Jacobi one is there to compare."""
    assert phys.DIFFUSION_SOLVER == "mic"
    a = diffusion_inputs(CLOUDS["cumulus"](), resolution=16)
    default = _core.diffusion_light(
        a["ext"], a["lo"], a["hi"], a["sun_t"], a["to_sun"], a["sky_e"], a["albedo"], a["g"],
        1e-3, 1, forward=a["forward"],
    )  # fmt: skip
    np.testing.assert_array_equal(default, solve(a, "mic", 1e-3))
    assert not np.array_equal(default, solve(a, "jacobi", 1e-3))


@pytest.mark.parametrize("sky", [True, False])
def test_mic_is_the_same_on_any_thread_count(sky: bool) -> None:
    a = diffusion_inputs(CLOUDS["seed 2"](), resolution=20)
    one = solve(a, "mic", 1e-3, threads=1, sky=sky)
    assert one.shape[-1] == (4 if sky else 1)
    for threads in (2, 3, 0):
        np.testing.assert_array_equal(solve(a, "mic", 1e-3, threads=threads, sky=sky), one)


def test_mic_on_empty_and_one_cell_media() -> None:
    """No medium: no fluence; one isolated cell: the balance of its source against its
    absorption and its six Marshak leaks, as the Jacobi solve gives it."""
    ext = np.zeros((6, 7, 8), F)
    lo, hi = (-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)
    sun_t = np.ones(ext.shape, F)
    sky = np.ones((*ext.shape, 3), F)
    args = (lo, hi, sun_t, (0.0, 1.0, 0.0), sky, 0.99, 0.6, 1e-6)
    assert not np.any(_core.diffusion_light(ext, *args, solver="mic"))
    ext[3, 3, 4] = 20.0
    mic = _core.diffusion_light(ext, *args, solver="mic")
    jac = _core.diffusion_light(ext, *args, solver="jacobi")
    assert mic[3, 3, 4, 0] > 0.0
    np.testing.assert_allclose(mic, jac, rtol=1e-5, atol=1e-9)


def test_bad_solver_and_tolerance_are_refused() -> None:
    a = diffusion_inputs(CLOUDS["cumulus"](), resolution=12)
    for bad in ("ic", "", "MIC"):
        with pytest.raises(ValueError, match="solver"):
            solve(a, bad, 1e-3)
    for tolerance in (0.0, -1e-3, 1.0, float("nan")):
        with pytest.raises(ValueError, match="tolerance"):
            solve(a, "mic", tolerance)
