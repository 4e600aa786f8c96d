"""Render settings: the knobs of the render pass, shared by the GL and CPU marchers."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from cumuli._util import budget
from cumuli._util import validate as check
from cumuli.light.grid import MAX_RESOLUTION
from cumuli.light.ndt import DEFAULT_SOLID_ANGLE, LightParams

#: Upper bounds of the settings that size shader loops and arrays (shaders/marcher/march.frag.glsl).
MAX_CANDIDATES = 128
MAX_STEPS = 1 << 16
MAX_CLOUDS = 64
MARCH_MODES = ("paper", "union")
#: Candidate sorts of the GL marcher (compile-time variants of shaders/marcher/march.frag.glsl).
CANDIDATE_SORTS = ("insertion", "quicksort", "oddeven", "none")
#: Light-grid methods the renderer may use (`cumuli.light_grid`).
LIGHT_METHODS = ("ndt", "naive", "shared")
#: Lighting models: the 2018 paper's render pass, or the physically based mode (RENDER_CONTRACT).
LIGHTING_MODES = ("paper", "physical")
#: Phase functions of the physical mode: the approximate Mie phase of water droplets (the
#: default), one Henyey–Greenstein lobe or a blend of two.
PHASE_FUNCTIONS = ("mie", "hg", "dual_hg")
#: Droplet diameters (µm) the approximate Mie phase's fits cover.
DROPLET_DIAMETER_RANGE = (5.0, 50.0)
#: The physical mode's sun lattice: ACROSS × physical_resolution nodes across the light, ALONG ×
#: as many along.
ACROSS = 2
ALONG = 1
#: Cell-averaging of the world lattice's extinction (supersample³ points per voxel).
SUPERSAMPLE = 2
#: Bytes per physical_resolution³ node while one drawable's light is made: the sun lattice's
#: optical depths (ACROSS² × ALONG float32), the world lattice's extinction, light, centres and
#: transmittance, and the supersampled points of its extinction.
PHYSICAL_BYTES_PER_NODE = 4 * ACROSS * ACROSS * ALONG + 4 + 16 + 12 + 4 + 12 * SUPERSAMPLE**3
#: Bytes per node a finished light keeps (its RGBA grid and its sun depth).
PHYSICAL_KEPT_BYTES_PER_NODE = 16 + 4 * ACROSS * ACROSS * ALONG
#: Samples per node: the sun lattice's march points and the extinction's supersamples.
PHYSICAL_SAMPLES_PER_NODE = ACROSS * ACROSS * ALONG + SUPERSAMPLE**3


@dataclass(frozen=True)
class RenderSettings:
    """Knobs of the render pass (RENDER_CONTRACT), shared by the GL and CPU marchers.

    Attributes
    ----------
    kappa:
        When not None, overrides every spheroid cloud's κ of eq. (2).
    absorption:
        φ of ``Δτ = exp(−φ·ρ·Δ/Δ_ref)`` (Algorithm 3, made step-size independent).
    lod_a, lod_delta:
        A and δ of the LOD step ``Δ = A·exp(−δ·|camera − cloud centre|)`` (Algorithm 1 line 50).
    step_ref:
        Δ_ref, the step at which ``Δτ`` is exactly the paper's ``exp(−φρ)``.
    step_min, step_max:
        Clamp of the LOD step.
    fixed_step:
        When > 0, replaces the LOD step (the paper uses 0.1 for its mesh tests).
    hg_g:
        Henyey-Greenstein asymmetry g of eq. (14), in (−1, 1).
    max_steps:
        Most samples marched per pixel, over all clouds (keeps every loop bounded).
    max_candidates:
        Most candidate primitives kept per ray and cloud (the nearest ones).
    march:
        ``"paper"`` marches each candidate interval on its own (overlaps twice, as the paper);
        ``"union"`` marches the union of the intervals once.
    candidate_sort:
        How the GL marcher orders a ray's candidates: ``"insertion"`` (the paper's insertion
        sort, as candidates arrive), ``"quicksort"`` (iterative, the alternative the paper
        tried) or ``"oddeven"`` (Batcher's odd-even mergesort, the one it suggests) give the
        same order — by ``t_in``, ties by primitive index — at different costs; ``"none"``
        leaves them unsorted (a cost reference: wrong where intervals overlap). The CPU marcher
        orders by the same key for the first three and leaves ``"none"`` unsorted too.
    exact_noise:
        Use exact float trilinear lookups (texelFetch) for the noise and the light grid instead
        of the hardware filter; the parity tests use it.
    octaves, gain, lacunarity, frequency:
        fBm of eq. (1): n, w, s and f (lattice texels per world unit).
    light_resolution:
        Edge of the light grid computed on demand for clouds without one.
    light_method, light_step, light_extinction:
        How that grid is computed (:func:`cumuli.light_grid`): ``"ndt"`` (Algorithm 2) or
        ``"naive"``, its march step and the extinction ``A`` of eq. (3) per world unit.
    lighting:
        ``"physical"`` (the default): the volume rendering equation in physical units with the
        approximations RENDER_CONTRACT states (single scattering, multiple scattering, sky
        light); ``"paper"``: the 2018 render pass above, unchanged bit for bit. The fields
        below are the physical mode's; the paper mode ignores them (except
        ``shadow_resolution`` with a ground).
    extinction_scale:
        σt = extinction_scale · ρ per world unit (ρ the cloud density as in the paper mode; the
        default 12 = absorption / step_ref gives the paper mode's opacity).
    albedo:
        Single-scattering albedo ϖ = σs / σt, in [0, 1].
    phase, hg_g2, hg_blend, droplet_diameter:
        ``"mie"`` (the default): the approximate Mie phase of water droplets of
        ``droplet_diameter`` µm (Jendersie & d'Eon 2023: a Henyey–Greenstein and Draine blend
        fitted over the diameter, 5–50 µm; strong forward peak, the silver lining of back-lit
        clouds); ``"hg"``: Henyey–Greenstein with ``hg_g``; ``"dual_hg"``:
        ``(1 − hg_blend)·HG(hg_g) + hg_blend·HG(hg_g2)``.
    haze:
        Optical depth of the air's haze along a view ray in the physical mode (droplets with the
        clouds' phase function): the aureole, the sun's forward-scattered glow around its disc,
        also around a sun hidden behind a cloud (``cumuli.rendering.air``). ``0`` turns it off;
        the paper mode has none.
    air_extinction:
        Extinction of the air per world unit in the physical mode: the ground seen at distance
        ``t`` fades into the sky's horizon radiance by ``1 − exp(−air_extinction·t)``, so that
        the ground meets the sky without a hard line (``0.003``: half faded at 230 units);
        distant clouds fade the same way with their distance (aerial perspective,
        ``cumuli.rendering.air``). ``0`` turns it off; the paper mode has none.
    air_height:
        Thickness (world units) of the hazy air above the camera in the physical mode: a view
        ray into the sky at elevation ``e`` crosses ``air_height/sin e`` of it, so the sky
        thickens into the horizon's colour towards the horizon as the ground does from below.
    sun_angular_diameter:
        The sun's angular diameter in degrees (``0.53``, as seen from the Earth) in the physical
        mode: the ground's shadows get a penumbra as wide as the distance from the caster to the
        ground times this angle (``0``: hard shadows).
    diffuse_shadows:
        The physical mode's ground under a cloud also receives the sunlight the cloud scatters
        through (a two-stream estimate of the diffuse transmission, ``1/(1 + ¾(1 − ḡ)τ)``
        beyond the direct ``exp(−τ)``), instead of the sky's light alone. ``False``: the direct
        sunlight only.
    resolve:
        The physical mode's resolve pass: a 3×3 tent filter over the finished image
        (``cumuli.rendering.resolve``) that averages out the camera rays' jitter pattern and
        smooths cloud outlines (softening detail by about a pixel; not supersampling).
        ``False`` gives the raw jittered image. The paper mode has none.
    physical_resolution:
        Longest edge of the physical mode's light grids (optical depth towards the sun, sky
        visibility, multiple scattering); the other edges follow the cloud's box. The default,
        40, is the one the physical constants are fitted at: against the Mitsuba references it
        is as close as 48 was (closer with the constants refitted) in ~0.6 of the light's time.
        The lattice gains (``cumuli.light.gains``) keep one cell, the 48-lattice's, at any value:
        a finer light sharpens the light's detail, it does not change the picture's exposure.
    multiple_scattering, sky_light:
        Switch the multiple-scattering approximation and the sky light off (to study each
        approximation alone).
    jitter_seed:
        Seed of the interleaved-gradient pattern that jitters the camera rays' samples (the
        physical mode, and the paper mode with ``jitter``).
    jitter:
        The paper mode's samples at ``ξ·Δ`` into their step, ``ξ`` the per-pixel pattern of
        ``jitter_seed``, instead of at ``Δ/2`` (the paper). Where a near-opaque cloud (a metaball,
        a dense cumulus) is entered within one or two steps, the fixed offset makes the first
        sample's depth jump from pixel to pixel in whole steps, which draws contour rings on the
        surface; the jitter turns them into a fine pattern that averages out. ``False`` (the
        default) is the paper's march; the physical mode always jitters.
    sprite_shadows:
        Particle clouds and billboards shade one another's light, the sun's and each extra
        light's (beyond Harris 2002 and Torchelsen & Musse 2005). Off by default: in a field
        whose clouds move, their light then changes every frame, which costs the light step and
        regenerates impostors (the Fig. 8 gain fell from ×4.1 to ×2.7 with it on). They shade
        the media and the ground either way. The instances of one billboard field shade one
        another with ``BillboardShading(shadow_between_clouds=True)``.
    shadow_resolution:
        Edge of the ground's sun shadow map (texels), when the scene has a ground.
    empty_space_skipping:
        Skip the samples that lie in empty cells of each cloud's coarse occupancy grid
        (``cumuli.occupancy_grid``, 16³ cells over the cloud's box) without evaluating the
        density, in both marchers and both lighting modes. The grid is conservative, so the
        image is the same bit for bit (RENDER_CONTRACT "Empty-space skipping"); ``False`` marches
        every cell.
    min_transmittance:
        The paper mode's early exit: a ray stops once its transmittance falls below it, the
        light still to come estimated by the last sample's source (the medium taken as opaque
        beyond). ``1e-6`` (the default) is the paper mode's exit; larger values
        (``0.2``: ÷ 2 fBm evaluations at a mean |Δ| ≤ 1.3e-3 on the benchmark scenes) trade a
        bounded error (at most ``min_transmittance`` times the radiance behind) for fewer fBm
        evaluations (``benchmarks/bench_render_cpu.py`` measures both). The physical mode keeps
        its own exit (``T < 1e-3``, opaque beyond).
    """

    kappa: float | None = None
    absorption: float = 1.2
    lod_a: float = 0.25
    lod_delta: float = 0.004
    step_ref: float = 0.1
    step_min: float = 0.02
    step_max: float = 1.0
    fixed_step: float = 0.0
    hg_g: float = 0.6
    max_steps: int = 4096
    max_candidates: int = 64
    march: str = "paper"
    candidate_sort: str = "insertion"
    exact_noise: bool = False
    octaves: int = 5
    gain: float = 0.5
    lacunarity: float = 2.0
    frequency: float = 0.3
    light_resolution: int = 20
    light_method: str = "ndt"
    light_step: float = 0.1
    light_extinction: float = 1.0
    lighting: str = "physical"
    extinction_scale: float = 12.0
    albedo: float = 0.99
    phase: str = "mie"
    hg_g2: float = -0.3
    hg_blend: float = 0.2
    droplet_diameter: float = 20.0
    haze: float = 0.05
    air_extinction: float = 0.003
    air_height: float = 10.0
    sun_angular_diameter: float = 0.53
    diffuse_shadows: bool = True
    resolve: bool = True
    physical_resolution: int = 40
    multiple_scattering: bool = True
    sky_light: bool = True
    jitter_seed: int = 0
    shadow_resolution: int = 256
    empty_space_skipping: bool = True
    min_transmittance: float = 1e-6
    jitter: bool = False
    sprite_shadows: bool = False

    def __post_init__(self) -> None:
        s = object.__setattr__
        if self.kappa is not None:
            s(self, "kappa", check.real(self.kappa, "settings.kappa", 0.0, 1.0))
        s(self, "absorption", check.real(self.absorption, "settings.absorption", 0.0))
        s(self, "lod_a", check.real(self.lod_a, "settings.lod_a", 0.0, lo_open=True))
        s(self, "lod_delta", check.real(self.lod_delta, "settings.lod_delta", 0.0))
        s(self, "step_ref", check.real(self.step_ref, "settings.step_ref", 0.0, lo_open=True))
        s(self, "step_min", check.real(self.step_min, "settings.step_min", 1e-5))
        s(self, "step_max", check.real(self.step_max, "settings.step_max", 1e-5))
        if self.step_max < self.step_min:
            raise ValueError(
                f"settings.step_max ({self.step_max}) must be >= "
                f"settings.step_min ({self.step_min})"
            )
        fixed = check.real(self.fixed_step, "settings.fixed_step", 0.0)
        if 0 < fixed < 1e-5:
            raise ValueError(f"settings.fixed_step must be 0 (off) or >= 1e-5, got {fixed}")
        s(self, "fixed_step", fixed)
        g = check.real(self.hg_g, "settings.hg_g", -1.0, 1.0, lo_open=True, hi_open=True)
        s(self, "hg_g", g)
        s(self, "max_steps", check.integer(self.max_steps, "settings.max_steps", 1, MAX_STEPS))
        s(
            self,
            "max_candidates",
            check.integer(self.max_candidates, "settings.max_candidates", 1, MAX_CANDIDATES),
        )
        if self.march not in MARCH_MODES:
            raise ValueError(f"settings.march must be one of {MARCH_MODES}, got {self.march!r}")
        if self.candidate_sort not in CANDIDATE_SORTS:
            raise ValueError(
                f"settings.candidate_sort must be one of {CANDIDATE_SORTS}, "
                f"got {self.candidate_sort!r}"
            )
        if not isinstance(self.exact_noise, (bool, np.bool_)):
            raise TypeError(f"settings.exact_noise must be a bool, got {self.exact_noise!r}")
        s(self, "exact_noise", bool(self.exact_noise))
        s(self, "octaves", check.integer(self.octaves, "settings.octaves", 1, 16))
        s(self, "gain", check.real(self.gain, "settings.gain", 0.0, lo_open=True))
        s(self, "lacunarity", check.real(self.lacunarity, "settings.lacunarity", 0.0, lo_open=True))
        s(self, "frequency", check.real(self.frequency, "settings.frequency", 0.0, lo_open=True))
        from cumuli.noise import _fbm_params

        try:  # the combinations Noise.fbm refuses (float32 overflow of the octaves)
            _fbm_params(self.octaves, self.gain, self.lacunarity, self.frequency)
        except ValueError as exc:
            raise ValueError(f"settings: {exc}") from None
        s(
            self,
            "light_resolution",
            check.integer(self.light_resolution, "settings.light_resolution", 2, MAX_RESOLUTION),
        )
        if self.light_method not in LIGHT_METHODS:
            raise ValueError(
                f"settings.light_method must be one of {LIGHT_METHODS}, got {self.light_method!r}"
            )
        s(self, "light_step", check.real(self.light_step, "settings.light_step", 1e-4))
        s(
            self,
            "light_extinction",
            check.real(self.light_extinction, "settings.light_extinction", 0.0),
        )
        check.choice(self.lighting, "settings.lighting", LIGHTING_MODES)
        scale = check.real(self.extinction_scale, "settings.extinction_scale", 0.0, 1e6)
        s(self, "extinction_scale", scale)
        s(self, "albedo", check.real(self.albedo, "settings.albedo", 0.0, 1.0))
        check.choice(self.phase, "settings.phase", PHASE_FUNCTIONS)
        g2 = check.real(self.hg_g2, "settings.hg_g2", -1.0, 1.0, lo_open=True, hi_open=True)
        s(self, "hg_g2", g2)
        s(self, "hg_blend", check.real(self.hg_blend, "settings.hg_blend", 0.0, 1.0))
        lo, hi = DROPLET_DIAMETER_RANGE
        diameter = check.real(self.droplet_diameter, "settings.droplet_diameter", lo, hi)
        s(self, "droplet_diameter", diameter)
        s(self, "haze", check.real(self.haze, "settings.haze", 0.0, 10.0))
        ext = check.real(self.air_extinction, "settings.air_extinction", 0.0, 10.0)
        s(self, "air_extinction", ext)
        s(self, "air_height", check.real(self.air_height, "settings.air_height", 0.0, 1e6))
        diameter = check.real(self.sun_angular_diameter, "settings.sun_angular_diameter", 0.0, 10.0)
        s(self, "sun_angular_diameter", diameter)
        s(self, "diffuse_shadows", check.flag(self.diffuse_shadows, "settings.diffuse_shadows"))
        s(self, "resolve", check.flag(self.resolve, "settings.resolve"))
        res = check.integer(self.physical_resolution, "settings.physical_resolution", 4, 256)
        s(self, "physical_resolution", res)
        for name in ("multiple_scattering", "sky_light"):
            value = getattr(self, name)
            if not isinstance(value, (bool, np.bool_)):
                raise TypeError(f"settings.{name} must be a bool, got {value!r}")
            s(self, name, bool(value))
        s(self, "jitter_seed", check.integer(self.jitter_seed, "settings.jitter_seed", 0, 1023))
        shadow = check.integer(self.shadow_resolution, "settings.shadow_resolution", 2, 4096)
        s(self, "shadow_resolution", shadow)
        s(
            self,
            "empty_space_skipping",
            check.flag(self.empty_space_skipping, "settings.empty_space_skipping"),
        )
        t_min = check.real(
            self.min_transmittance, "settings.min_transmittance", 0.0, 1.0, hi_open=True
        )
        s(self, "min_transmittance", t_min)
        s(self, "jitter", check.flag(self.jitter, "settings.jitter"))
        s(self, "sprite_shadows", check.flag(self.sprite_shadows, "settings.sprite_shadows"))

    def step_for(self, distance: float) -> float:
        """The march step Δ for a cloud whose centre is ``distance`` from the camera."""
        if self.fixed_step > 0:
            return self.fixed_step
        step = self.lod_a * math.exp(-self.lod_delta * distance)
        return min(max(step, self.step_min), self.step_max)

    def fbm_params(self) -> dict[str, float]:
        """The fBm parameters as keyword arguments of :meth:`cumuli.Noise.fbm`."""
        return {
            "octaves": self.octaves,
            "gain": self.gain,
            "lacunarity": self.lacunarity,
            "frequency": self.frequency,
        }

    def light_grid_kwargs(self) -> dict[str, Any]:
        """Keyword arguments of :func:`cumuli.light_grid` for the grid these settings render with.

        ``light_grid(cloud, sun, noise, **settings.light_grid_kwargs())`` makes the grid the
        renderer would make (κ: the cloud's own; :meth:`light_params` also carries ``kappa``).
        """
        return {
            "resolution": self.light_resolution,
            "method": self.light_method,
            "step": self.light_step,
            "extinction": self.light_extinction,
            **self.fbm_params(),
        }

    def physical_cost(self, media: int) -> tuple[int, int]:
        """``(bytes, samples)`` the physical light of ``media`` drawables with a medium costs
        at ``physical_resolution`` (one made at a time, the finished ones kept)."""
        nodes = self.physical_resolution**3
        if media <= 0:
            return 0, 0
        kept = (media - 1) * PHYSICAL_KEPT_BYTES_PER_NODE
        return nodes * (PHYSICAL_BYTES_PER_NODE + kept), nodes * PHYSICAL_SAMPLES_PER_NODE * media

    def check_physical_budget(self, media: int) -> None:
        """Refuse the physical light of ``media`` drawables when it is over the budget."""
        memory, samples = self.physical_cost(media)
        what = (
            f"the physical light of {media} drawable(s) at "
            f"settings.physical_resolution={self.physical_resolution}"
        )
        budget.check_memory(what, memory)
        budget.check_work(what, samples)

    def light_params(self) -> LightParams:
        """The :class:`cumuli.LightParams` of the light grids these settings render with (the
        settings' light fields and fBm, the default solid angle, ``kappa`` as the override)."""
        return LightParams(
            resolution=self.light_resolution,
            method=self.light_method,
            step=self.light_step,
            extinction=self.light_extinction,
            solid_angle=DEFAULT_SOLID_ANGLE,
            kappa=self.kappa,
            **self.fbm_params(),
        )

    @property
    def physical(self) -> bool:
        """Whether these settings select the physically based lighting."""
        return self.lighting == "physical"

    @property
    def mean_cosine(self) -> float:
        """The phase function's mean cosine ḡ (``hg_g``, the blend of the two lobes, or the
        approximate Mie phase's)."""
        if self.phase == "mie":
            from cumuli import _core

            return float(_core.approx_mie_mean_cosine(self.droplet_diameter))
        if self.phase == "dual_hg":
            return (1.0 - self.hg_blend) * self.hg_g + self.hg_blend * self.hg_g2
        return self.hg_g

    def replace(self, **changes: Any) -> RenderSettings:
        """A copy with some fields changed (validated again)."""
        return RenderSettings(**{**asdict(self), **changes})

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)
