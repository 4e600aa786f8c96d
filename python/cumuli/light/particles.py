"""Multiple forward scattering light of particle clouds (Harris 2002 §2.2.1, §2.3; spec §3–4, §6).

:func:`particle_light` runs the illumination pass of [H] Fig. 4 per light: the cloud seen from the
light in an orthographic ``N_L × N_L`` buffer cleared to 1, particles sorted nearest the light
first, each particle's light ``I_k`` read back before it is splatted with colour
``g_k = a_k τ_k p_fwd γ/4π · I_k`` and alpha ``1 − e^{−τ_k}`` under the blend
(ONE, ONE_MINUS_SRC_ALPHA) — recurrence (4). It returns a :class:`ParticleLight` value
(``light (N, L)``: the fraction of light ℓ reaching particle k; never stored on the cloud).

Three methods give the same numbers: ``"cpu"`` (C++ reference, clouds × lights over threads),
``"gl"`` (GLSL compute twin ``shaders/particles/light.comp.glsl``) and ``"readback"`` (the
faithful 2002 path: blended quads into a float framebuffer and one read per particle).

:class:`SpriteSettings` gathers every knob of the light and eye passes (spec §9), with the
``"paper"`` (default) and ``"skyworks"`` presets. :func:`skylight_lights` turns a sky into
directional lights (§6).
"""

from __future__ import annotations

import hashlib
import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from cumuli import _core
from cumuli._util import validate as check
from cumuli.gl.context import check_context
from cumuli.light.billboard_shading import BillboardShading
from cumuli.light.caf import ground_caf
from cumuli.light.sprite_settings import (  # noqa: F401 (public names)
    KERNELS,
    MAX_LIGHTS,
    METHODS,
    PHASES,
    PRESET_PARTICLES,
    PRESETS,
    READBACKS,
    SORTS,
    SpriteSettings,
    as_settings,
)
from cumuli.model.billboard_field import BillboardField
from cumuli.model.billboards import BillboardCloud
from cumuli.model.particles import ParticleCloud
from cumuli.sky import Sky, Sun


def as_lights(lights: Sun | Sequence[Sun]) -> tuple[Sun, ...]:
    """One :class:`cumuli.Sun` or a non-empty sequence of them, as a tuple."""
    if isinstance(lights, Sun):
        return (lights,)
    if isinstance(lights, (str, bytes)) or not isinstance(lights, Sequence):
        raise TypeError(f"lights must be a cumuli.Sun or a sequence of them, got {lights!r}")
    out = tuple(lights)
    if not out:
        raise ValueError("lights must not be empty")
    if len(out) > MAX_LIGHTS:
        raise ValueError(f"at most {MAX_LIGHTS} lights, got {len(out)}")
    for i, light in enumerate(out):
        if not isinstance(light, Sun):
            raise TypeError(f"lights[{i}] must be a cumuli.Sun, got {type(light).__name__}")
    return out


def light_directions(lights: Sequence[Sun]) -> np.ndarray:
    """``(L, 3)`` float32 unit directions towards the lights."""
    return np.array([s.direction for s in lights], dtype=np.float32).reshape(-1, 3)


_digests: weakref.WeakKeyDictionary[ParticleCloud, str] = weakref.WeakKeyDictionary()


def particles_digest(cloud: ParticleCloud) -> str:
    """A digest of what a cloud's light depends on: positions relative to its sphere centre (in
    units of R, to 1e−6, so that a translated cloud keeps its digest), radii/R, τ and albedo.
    Remembered per cloud object (its arrays are read-only), so frames do not rehash."""
    known = _digests.get(cloud)
    if known is None:
        known = _digests[cloud] = _particles_digest(cloud)
    return known


def _particles_digest(cloud: ParticleCloud) -> str:
    centre, radius = cloud.sphere
    rel = (cloud.centres.astype(np.float64) - centre.astype(np.float64)) / radius
    h = hashlib.sha256()
    h.update(np.round(rel, 6).tobytes())
    h.update(np.round(cloud.radii.astype(np.float64) / radius, 6).tobytes())
    h.update(cloud.tau.tobytes())
    h.update(cloud.albedo.tobytes())
    return h.hexdigest()[:32]


@dataclass(frozen=True, eq=False)
class ParticleLight:
    """The result of the light pass: a value, never stored on the cloud.

    ``light`` ``(N, L)`` float32 — fraction of light ℓ reaching particle k (``I_k`` with
    ``I₀ = 1``); ``light_dirs`` ``(L, 3)`` the directions it was made for; ``params`` what it
    depends on (settings, particle digest, method); ``buffers`` ``(L, N_L, N_L)`` the final light
    buffers (``[y, x]``, ``y`` along the light frame's up: the cloud's transmittance shadow map
    seen from each light) when asked for, else None; ``unshadowed`` the cloud's own light this
    one was made from by :meth:`through` (None: this is the cloud's own light).
    """

    light: np.ndarray
    light_dirs: np.ndarray
    params: dict[str, Any] = field(default_factory=dict)
    buffers: np.ndarray | None = None
    unshadowed: ParticleLight | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        light = np.ascontiguousarray(self.light, dtype=np.float32)
        dirs = np.ascontiguousarray(self.light_dirs, dtype=np.float32)
        if light.ndim != 2 or dirs.shape != (light.shape[1], 3):
            raise ValueError(
                f"light (N, L) and light_dirs (L, 3) disagree: {light.shape}, {dirs.shape}"
            )
        for arr in (light, dirs):
            arr.flags.writeable = False
        object.__setattr__(self, "light", light)
        object.__setattr__(self, "light_dirs", dirs)

    @property
    def n_lights(self) -> int:
        return int(self.light.shape[1])

    def through(self, transmittance: np.ndarray) -> ParticleLight:
        """The cloud's own light with particle ``k``'s light ``ℓ`` times ``transmittance[k, ℓ]``:
        what the light crossed before it reached the cloud (other clouds: the scene's media)."""
        own = self.unshadowed or self
        t = np.asarray(transmittance, dtype=np.float32)
        if t.shape != own.light.shape:
            raise ValueError(f"transmittance must be {own.light.shape}, got {t.shape}")
        return ParticleLight(own.light * t, own.light_dirs, own.params, own.buffers, own)


def light_params(cloud: ParticleCloud, settings: SpriteSettings) -> dict[str, Any]:
    """The record of what a particle light depends on (compared by :func:`light_is_stale`)."""
    return {"settings": settings.light_dict(), "particles": particles_digest(cloud), "n": cloud.n}


def light_is_stale(
    light: ParticleLight | None,
    cloud: ParticleCloud,
    lights: Sun | Sequence[Sun],
    settings: SpriteSettings | None = None,
) -> str | None:
    """Why ``light`` must be recomputed for ``cloud`` under ``lights``, or None when it holds.

    Reasons: ``"missing"``, ``"particles"`` (particles changed relative to each other; a pure
    translation keeps the light), ``"lights"`` (count changed, or a direction turned by more than
    ``settings.relight_tolerance`` degrees), ``"settings"`` (a light-pass setting changed).
    """
    settings = as_settings(settings)
    lights = as_lights(lights)
    if light is None:
        return "missing"
    if not isinstance(light, ParticleLight):
        raise TypeError(f"light must be a ParticleLight or None, got {type(light).__name__}")
    want = light_params(cloud, settings)
    if light.params.get("n") != cloud.n or light.params.get("particles") != want["particles"]:
        return "particles"
    if light.n_lights != len(lights):
        return "lights"
    dots = np.clip(
        np.sum(light.light_dirs.astype(np.float64) * light_directions(lights), axis=1), -1.0, 1.0
    )
    if np.degrees(np.arccos(dots)).max() > settings.relight_tolerance:
        return "lights"
    if light.params.get("settings") != want["settings"]:
        return "settings"
    return None


def particle_light(
    cloud: ParticleCloud,
    lights: Sun | Sequence[Sun],
    settings: SpriteSettings | None = None,
    method: str = "cpu",
    threads: int = 0,
    return_buffers: bool = False,
    context: Any = None,
) -> ParticleLight:
    """The multiple forward scattering light of ``cloud`` for each light (spec §4).

    ``lights`` is one :class:`cumuli.Sun` or several (the sun first, then skylight lights: one
    column each). ``method``: ``"cpu"`` (C++, lights over ``threads``), ``"gl"`` (compute twin)
    or ``"readback"`` (the 2002 blended-quads path; slow, for the benchmark). ``context`` is the
    :class:`cumuli.gl.GLContext` of the GL methods (default: the process-wide one).
    Raises ``ValueError`` naming ``solid_angle`` when a particle would add light (spec §3.1)
    unless ``settings.allow_gain``.
    """
    return particle_light_many([cloud], lights, settings, method, threads, return_buffers, context)[
        0
    ]


def particle_light_many(
    clouds: Sequence[ParticleCloud],
    lights: Sun | Sequence[Sun],
    settings: SpriteSettings | None = None,
    method: str = "cpu",
    threads: int = 0,
    return_buffers: bool = False,
    context: Any = None,
) -> list[ParticleLight]:
    """:func:`particle_light` of several clouds; with ``"cpu"`` all clouds × lights share the
    threads (each task is sequential: the recurrence is)."""
    settings = as_settings(settings)
    lights = as_lights(lights)
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if isinstance(clouds, ParticleCloud) or not isinstance(clouds, Sequence):
        raise TypeError("clouds must be a sequence of ParticleCloud")
    for i, c in enumerate(clouds):
        if not isinstance(c, ParticleCloud):
            raise TypeError(f"clouds[{i}] must be a ParticleCloud, got {type(c).__name__}")
    if not isinstance(return_buffers, (bool, np.bool_)):
        raise TypeError("return_buffers must be a bool")
    threads = check.threads(threads)
    check_context(context)  # on every path, as the GL one would
    dirs = light_directions(lights)
    if method == "cpu":
        results = _core.particle_light(
            [c.core_args() for c in clouds],
            dirs,
            settings.light_dict(),
            bool(return_buffers),
            threads,
        )
    else:
        from cumuli.light import particles_gl

        results = [
            particles_gl.light_pass(c, dirs, settings, method, bool(return_buffers), context)
            for c in clouds
        ]
    out = []
    for cloud, (light, buffers) in zip(clouds, results, strict=True):
        params = light_params(cloud, settings)
        params["method"] = method
        out.append(ParticleLight(light, dirs, params, buffers))
    return out


def ground_shadow(
    cloud: ParticleCloud | BillboardCloud | BillboardField,
    sun: Sun,
    points: Any,
    settings: SpriteSettings | BillboardShading | None = None,
    light: ParticleLight | None = None,
) -> np.ndarray:
    """Transmittance ``(M,)`` of ``sun``'s light through ``cloud`` at world ``points`` ``(M, 3)``:
    the light pass's final buffer — the cloud's shadow map seen from the sun (spec §4 step 6) —
    sampled bilinearly where each point projects (1 outside it or in front of the cloud). Pass a
    ``light`` made with ``return_buffers=True`` for this sun (any of its lights) to reuse its
    buffer.

    A billboard cloud or field (with a :class:`BillboardShading` as ``settings``) gives the CAF
    its own billboards would get at each point (:func:`cumuli.light.caf.ground_caf`, beyond
    Torchelsen & Musse 2005)."""
    if not isinstance(sun, Sun):
        raise TypeError(f"sun must be a cumuli.Sun, got {type(sun).__name__}")
    if isinstance(cloud, (BillboardCloud, BillboardField)):
        if light is not None:
            raise TypeError("light is a particle cloud's; a billboard cloud's shadow takes none")
        return ground_caf(cloud, sun, points, settings)  # type: ignore[arg-type]
    if not isinstance(cloud, ParticleCloud):
        raise TypeError(
            f"cloud must be a ParticleCloud, BillboardCloud or BillboardField, got "
            f"{type(cloud).__name__}"
        )
    pts = check.points3(points, "points", bound=check.MAX_COORD)
    settings = as_settings(settings)
    buffer = None
    if light is not None:
        if not isinstance(light, ParticleLight):
            raise TypeError(f"light must be a ParticleLight or None, got {type(light).__name__}")
        if light.buffers is not None:
            # The final buffer of the light's own pass towards this sun, whichever light it was.
            here = light_directions([sun])[0]
            same = np.flatnonzero(np.abs(light.light_dirs - here[None, :]).max(axis=1) <= 1e-6)
            if len(same):
                buffer = light.buffers[int(same[0])]
    if buffer is None:
        buffers = particle_light(cloud, sun, settings, return_buffers=True).buffers
        assert buffers is not None
        buffer = buffers[0]
    return _core.particle_shadow(
        *cloud.core_args(), sun.direction, np.ascontiguousarray(buffer), pts
    )


def skylight_lights(
    sky: Sky,
    sun: Sun,
    n: int = 4,
    strength: float = 1.0,
    elevation_min: float = 10.0,
) -> tuple[Sun, ...]:
    """``n`` directional lights approximating the sky dome (spec §6, [beyond the paper]).

    Directions on a Fibonacci lattice of the cap above ``elevation_min`` degrees (uniform in
    sin(elevation), golden-angle azimuths); colour ``sky.colour(d)`` without the sun disc;
    intensity ``strength·Ω/n`` with ``Ω = 2π(1 − sin(elevation_min))`` the cap's solid angle
    [decision: the spec's "2π/n, the solid angle per light" taken over the cap actually sampled],
    so the lights add up to the cap's irradiance-weighted radiance. Pass them after the sun:
    ``particle_light(pc, [sun, *skylight_lights(sky, sun)])``.
    """
    if not isinstance(sky, Sky):
        raise TypeError(f"sky must be a cumuli.Sky, got {type(sky).__name__}")
    if not isinstance(sun, Sun):
        raise TypeError(f"sun must be a cumuli.Sun, got {type(sun).__name__}")
    n = check.integer(n, "n", 1, MAX_LIGHTS)
    strength = check.real(strength, "strength", 0.0)
    elevation_min = check.real(elevation_min, "elevation_min", 0.0, 90.0, hi_open=True)
    s0 = math.sin(math.radians(elevation_min))
    golden = math.pi * (3.0 - math.sqrt(5.0))
    dirs = []
    for i in range(n):
        y = s0 + (1.0 - s0) * (i + 0.5) / n
        horizontal = math.sqrt(max(0.0, 1.0 - y * y))
        phi = i * golden
        dirs.append((horizontal * math.cos(phi), y, horizontal * math.sin(phi)))
    no_disc = replace(sky, sun_disc_intensity=0.0)
    colours = no_disc.colour(np.array(dirs, dtype=np.float32), sun)
    intensity = strength * 2.0 * math.pi * (1.0 - s0) / n
    return tuple(
        Sun(direction=d, colour=tuple(float(v) for v in c), intensity=intensity)
        for d, c in zip(dirs, colours, strict=True)
    )


def phase_values(
    phase: str,
    cos_theta: Any,
    g: float = 0.6,
    backend: str = "cpu",
    context: Any = None,
) -> np.ndarray:
    """The particle passes' phase function normalised to 4π ([H]: ∫p dω = 4π) at cosines
    ``cos_theta``: ``"rayleigh"`` ¾(1 + c²), ``"isotropic"`` 1,
    ``"hg"`` (1 − g²)/(1 + g² − 2gc)^{3/2}.
    ``backend="gl"`` evaluates ``shaders/common/phase.glsl`` (its parity check)."""
    if phase not in PHASES:
        raise ValueError(f"phase must be one of {PHASES}, got {phase!r}")
    g = check.real(g, "g", -1.0, 1.0, lo_open=True, hi_open=True)
    c = np.asarray(cos_theta)
    if c.dtype.kind not in "fiu":
        raise TypeError(f"cos_theta must be real numbers, got dtype {c.dtype}")
    c = np.ascontiguousarray(c, dtype=np.float32)
    if not np.isfinite(c).all() or (np.abs(c) > 1).any():
        raise ValueError("cos_theta must be finite and within [-1, 1]")
    check_context(context)
    if backend == "cpu":
        return _core.phase_4pi(phase, g, c)
    if backend == "gl":
        from cumuli.light import particles_gl

        return particles_gl.phase_values_gl(phase, g, c, context)
    raise ValueError(f"backend must be 'cpu' or 'gl', got {backend!r}")
