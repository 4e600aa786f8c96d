"""The render pass's parameters as both marchers take them, from one place.

The C++ core takes them as bound structs of ``cumuli._core`` (``MarchSettings`` with its
``FbmParams`` and ``PhysicalParams``, ``SunParams``, ``SkyParams``, ``CameraParams`` in a
``Viewport``); :func:`march_params` fills the march's struct from a
:class:`cumuli.RenderSettings` once, and :func:`march_uniforms` gives the GLSL marcher's uniforms
from the same struct, so the CPU twin (``cumuli.rendering.marcher_cpu``) and the GL marcher
(``cumuli.rendering.marcher``) cannot drift apart. :func:`sky_uniforms` is the sky's and sun's
uniforms for every GL program that draws the sky (shaders/common/sky.glsl).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cumuli import _core
from cumuli.camera import Camera
from cumuli.light import physical as _physical
from cumuli.settings import MAX_CANDIDATES, RenderSettings
from cumuli.sky import Sky, Sun, sky_args, sun_disc_edges

#: The physical mode stops a ray, opaque from there on, once its transmittance falls below this:
#: the rest would add at most this share of its radiance. 1e-3 against 1e-4 marches 2–8 % fewer
#: samples on the Mitsuba reference views (the cumulus 6.7 %) and changes no 4×4 block of them
#: by more than 0.25 % (no pixel by more than 0.004).
MIN_TRANSMITTANCE = 1e-3
#: The physical camera ray's step doubles for each decade its view transmittance falls below this,
#: looked at after every ``COARSEN_EVERY`` samples inside a cloud (the C++ marcher's batch), up to
#: ``MAX_COARSEN`` times the LOD step; 0 keeps the step. What lies beyond a view transmittance of
#: ½ adds at most half the pixel's light, and coarser samples there move it little: on the
#: Mitsuba reference views it marches 12 % fewer samples on the cumulus (15 % at 1080p) and moves
#: no view's block median by more than 0.1 point (RENDER_CONTRACT "Physical lighting").
COARSEN_BELOW = 0.5
COARSEN_EVERY: int = _core.COARSEN_EVERY
MAX_COARSEN: float = _core.MAX_COARSEN


def fbm_params(settings: RenderSettings) -> _core.FbmParams:
    """The fBm of eq. (1) (octaves, gain, lacunarity, frequency) of ``settings``."""
    return _core.FbmParams(
        int(settings.octaves),
        float(settings.gain),
        float(settings.lacunarity),
        float(settings.frequency),
    )


def sun_params(sun: Sun) -> _core.SunParams:
    """The sun as the core takes it (direction towards it, radiance)."""
    p = _core.SunParams()
    p.direction = sun.direction
    p.radiance = sun.radiance
    return p


def sky_params(sky: Sky) -> _core.SkyParams:
    """The sky as the core takes it (gradient and sun disc)."""
    return sky_args(sky)


def camera_params(camera: Camera) -> _core.CameraParams:
    """A look-at camera as the core takes it."""
    p = _core.CameraParams()
    p.position = camera.position
    p.target = camera.target
    p.up = camera.up
    p.fov = float(camera.fov)
    return p


def viewport(camera: Camera, width: int, height: int) -> _core.Viewport:
    """The camera and the ``width × height`` image it takes, as the core takes them."""
    return _core.Viewport(camera_params(camera), int(width), int(height))


def physical_params(settings: RenderSettings, octaves: int) -> _core.PhysicalParams:
    """The physical mode's shading parameters (RENDER_CONTRACT "Physical lighting") with
    ``octaves`` scattering orders drawn."""
    p = _core.PhysicalParams()
    p.extinction_scale = float(settings.extinction_scale)
    p.albedo = float(settings.albedo)
    p.dual_hg = settings.phase == "dual_hg"
    p.g1 = float(settings.hg_g)
    p.g2 = float(settings.hg_g2)
    p.blend = float(settings.hg_blend)
    p.mie = settings.phase == "mie"
    p.droplet_diameter = float(settings.droplet_diameter)
    p.octaves = int(octaves)
    # read at call time: the fitting script (tests/references/fit_physical.py) varies them
    p.oct_a, p.oct_b, p.oct_c = _physical.OCTAVE_A, _physical.OCTAVE_B, _physical.OCTAVE_C
    p.oct_poisson = _physical.OCTAVE_POISSON
    if _physical.OCTAVE_PHASE == "convolved":  # else the marchers compute phase(bⁿ·g)
        p.order_phase = _physical.order_phase_table(settings, int(octaves)).ravel()
    p.oct_first = _physical.first_order_depth_scale(settings)
    p.view_scale = _physical.view_depth_scale(settings)
    p.view_diffuse = _physical.view_diffuse_share(settings)
    p.jitter_seed = int(settings.jitter_seed)
    p.min_transmittance = MIN_TRANSMITTANCE
    p.coarsen_below = COARSEN_BELOW
    return p


def march_params(settings: RenderSettings, physical_octaves: int = 1) -> _core.MarchSettings:
    """The 2018 marcher's settings (``_core.MarchSettings``) filled from ``settings``: the one
    place the render pass's knobs are packed for the core (:func:`march_uniforms` reads the GL
    uniforms back from the result). ``physical_octaves``: the scattering orders the physical
    mode draws (its lights' ``octaves``)."""
    s = settings
    p = _core.MarchSettings()
    p.absorption = float(s.absorption)
    p.lod_a = float(s.lod_a)
    p.lod_delta = float(s.lod_delta)
    p.ref_step = float(s.step_ref)
    p.step_min = float(s.step_min)
    p.step_max = float(s.step_max)
    p.fixed_step = float(s.fixed_step)
    p.hg_g = float(s.hg_g)
    p.max_steps = int(s.max_steps)
    p.max_candidates = int(s.max_candidates)
    p.march = s.march
    # The GL sorts all give the (t_in, primitive) order the core's insertion sort gives.
    p.sort_candidates = s.candidate_sort != "none"
    p.fbm = fbm_params(s)
    p.min_transmittance = float(s.min_transmittance)
    p.skip_empty = bool(s.empty_space_skipping)
    p.jitter = bool(s.jitter)
    if s.physical:
        p.physical = True
        p.phys = physical_params(s, physical_octaves)
    else:
        p.phys.jitter_seed = int(s.jitter_seed)
    return p


def march_uniforms(params: _core.MarchSettings, exact_noise: bool = False) -> dict[str, Any]:
    """The GLSL marcher's uniforms (shaders/marcher/march.frag.glsl) of a ``_core.MarchSettings``
    (:func:`march_params`): the same values the CPU twin takes. ``exact_noise``: texelFetch
    lookups instead of the hardware filter (GL only)."""
    p = params
    return {
        "u_absorption": p.absorption,
        "u_step_ref": p.ref_step,
        "u_lod_a": p.lod_a,
        "u_lod_delta": p.lod_delta,
        "u_step_min": p.step_min,
        "u_step_max": p.step_max,
        "u_fixed_step": p.fixed_step,
        "u_g": p.hg_g,
        "u_max_steps": p.max_steps,
        "u_max_candidates": min(p.max_candidates, MAX_CANDIDATES),
        "u_union": p.march == "union",
        "u_exact": bool(exact_noise),
        "u_min_t": p.min_transmittance,
        "u_jitter": p.jitter,
        "u_jitter_seed": p.phys.jitter_seed,
        "u_skip_empty": p.skip_empty,
        "u_octaves": p.fbm.octaves,
        "u_gain": p.fbm.gain,
        "u_lacunarity": p.fbm.lacunarity,
        "u_frequency": p.fbm.frequency,
    }


#: vec4 entries of ``u_phys_order_phase`` (shaders/common/physical.glsl): every order past the
#: first of at most ``MAX_OCTAVES``, ``ORDER_PHASE_SIZE`` values each.
ORDER_PHASE_VEC4S = (_core.MAX_OCTAVES - 1) * _core.ORDER_PHASE_SIZE // 4


def order_phase_vec4s(table: Any) -> list[tuple[float, ...]]:
    """``PhysicalParams.order_phase`` as the shaders' ``u_phys_order_phase`` (zeros past it)."""
    flat = np.zeros(4 * ORDER_PHASE_VEC4S, np.float32)
    values = np.asarray(table, np.float32).ravel()
    flat[: values.size] = values
    return [tuple(float(v) for v in row) for row in flat.reshape(-1, 4)]


def physical_uniforms(params: _core.PhysicalParams) -> dict[str, Any]:
    """The physical shading uniforms (shaders/common/physical.glsl) of a ``_core.PhysicalParams``
    (:func:`physical_params`): the same values the CPU twin takes."""
    p = params
    return {
        "u_phys_extinction": p.extinction_scale,
        "u_phys_albedo": p.albedo,
        "u_phys_dual": p.dual_hg,
        "u_phys_g": (p.g1, p.g2, p.blend),
        "u_phys_mie": p.mie,
        "u_phys_mie_p": tuple(p.mie_params),
        "u_phys_octaves": p.octaves,
        "u_phys_abc": (p.oct_a, p.oct_b, p.oct_c),
        "u_phys_poisson": p.oct_poisson,
        "u_phys_order_table": len(p.order_phase) > 0,
        "u_phys_order_phase": order_phase_vec4s(p.order_phase),
        "u_phys_first": p.oct_first,
        "u_phys_view": p.view_scale,
        "u_phys_diffuse": p.view_diffuse,
        "u_phys_seed": p.jitter_seed,
        "u_phys_min_t": p.min_transmittance,
        "u_phys_coarsen": p.coarsen_below,
    }


def sky_uniforms(sky: Sky, sun: Sun) -> dict[str, Any]:
    """The sun's and the sky's uniforms (shaders/common/sky.glsl and sun_disc.glsl)."""
    return {
        "u_sun_dir": sun.direction,
        "u_sun_radiance": sun.radiance,
        "u_sky_zenith": sky.zenith,
        "u_sky_horizon": sky.horizon,
        "u_sky_ground": sky.ground,
        "u_sky_exponent": float(sky.exponent),
        "u_sun_disc": sun_disc_edges(sky.sun_disc_radius),
        "u_sun_disc_intensity": float(sky.sun_disc_intensity),
    }
