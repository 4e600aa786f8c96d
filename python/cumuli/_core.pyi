"""
cumuli C++ core: noise, cloud generators, light precompute and reference renderers
"""
from __future__ import annotations
import collections.abc
import numpy
import numpy.typing
import typing
__all__: list[str] = ['ATLAS_MAX_SIZE', 'ATLAS_MAX_SPRITES', 'ATLAS_MIN_SIZE', 'COARSEN_EVERY', 'CameraParams', 'CloudShape', 'DECK_DETAIL_CONTRAST', 'DECK_MAX_LATTICE_EDGE', 'DECK_MAX_MAP_EDGE', 'DECK_MAX_VOXELS', 'DeckShape', 'EndlessWalk', 'EvolutionParams', 'FbmParams', 'GaussianCumulusParams', 'LIGHT_MAX_RESOLUTION', 'LIGHT_MAX_STEPS_PER_RAY', 'LSYSTEM_MAX_LENGTH', 'MAX_COARSEN', 'MAX_OCTAVES', 'MarchSettings', 'Noise', 'ORDER_PHASE_SIZE', 'PARTICLES_MAX', 'ParticleSpriteSettings', 'PhysicalParams', 'SEEDBOX_MAX_BILLBOARDS', 'SEEDBOX_MAX_BOXES', 'SEEDBOX_MAX_SEEDS', 'ShadeParams', 'SkyParams', 'SpriteRasterSettings', 'SunParams', 'TurtleParams', 'Viewport', 'VolumeCamera', 'VolumeRenderParams', 'WEATHER_MAX_INSTANCES', 'WeatherSim', 'add_multiple_scattering', 'approx_mie_mean_cosine', 'approx_mie_params', 'approx_mie_phase', 'atlas_grid', 'billboard_corners', 'billboard_shade', 'billboard_sprites', 'billboard_vertex_colours', 'blend_volumes', 'buffer_cache_stats', 'caf_path_lengths', 'caf_values', 'camera_candidates', 'cloud_density', 'composite_layers', 'composite_split', 'coverage_edges', 'crossfade_weight', 'deck_density', 'deck_lattice', 'density_grid', 'diffusion_anisotropy', 'diffusion_light', 'display_impostors', 'draw_solids', 'ellipsoids_from_mesh', 'evolving_cloud_box', 'evolving_cloud_volumes', 'field_path_lengths', 'finish_physical', 'fit_shexp', 'gaussian_cumulus', 'impostor_backwards', 'impostor_focal_length_px', 'impostor_half_diagonal_fov', 'impostor_near_corner_radius', 'impostor_rects', 'impostor_required_resolution', 'impostor_resolution', 'impostor_resolution_skyworks', 'impostor_translation_error', 'lattice_transmittance', 'light_frame', 'light_grid', 'light_space_depth', 'light_volume', 'lsystem_expand', 'lsystem_interpret', 'lsystem_length', 'medium_optical_depth', 'needs_screen_impostor', 'occupancy_grid', 'particle_fill', 'particle_light', 'particle_light_splats', 'particle_shadow', 'particle_sphere', 'particle_sprites', 'particles_from_volume', 'particles_to_volume', 'phase_4pi', 'physical_grid', 'point_optical_depth', 'project_sprites', 'rasterise_sprites', 'release_buffer_cache', 'remove_contained_spheres', 'render_cpu', 'render_cpu_edged', 'render_volume_cpu', 'sample_frame', 'sample_volume', 'screen_candidates', 'screen_impostor_size', 'seed_box_cloud', 'seed_box_worst_case', 'set_buffer_cache_limit', 'set_progress', 'set_simd_fetch', 'set_simd_level', 'sh_eval', 'sh_optical_depth', 'shexp_apply', 'simd_fetch', 'simd_fetch_preferred', 'simd_level', 'simd_levels', 'similarity_matrix', 'sky_irradiance', 'sky_irradiance_from', 'sky_sh', 'sky_visibility', 'sphere_outside_frustum', 'sphere_quadrature', 'splat_kernel', 'sprite_atlas', 'sun_optical_depth', 'tight_impostor_view', 'transition_matrix', 'variant_seed', 'volume_sample_points', 'yaw_cos_sin']
class FbmParams:
    """
    fBm of eq. (1): octaves n, gain w, lacunarity s, frequency f (lattice texels per world unit).
    """
    def __init__(self, octaves: typing.SupportsInt | typing.SupportsIndex = 5, gain: typing.SupportsFloat | typing.SupportsIndex = 0.5, lacunarity: typing.SupportsFloat | typing.SupportsIndex = 2.0, frequency: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> None:
        ...
    def validate(self) -> None:
        ...
    @property
    def frequency(self) -> float:
        ...
    @frequency.setter
    def frequency(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def gain(self) -> float:
        ...
    @gain.setter
    def gain(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def lacunarity(self) -> float:
        ...
    @lacunarity.setter
    def lacunarity(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def octaves(self) -> int:
        ...
    @octaves.setter
    def octaves(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
class CloudShape:
    """
    A 2018 cloud as the core takes it: primitives (centres (N, 3), radii (N, 3), rotations (N, 3, 3)) and density model, κ, φ; its fBm is read at p − noise_offset (a cloud that carries its noise with the wind).
    """
    def __init__(self, centres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], radii: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], rotations: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], model: str, kappa: typing.SupportsFloat | typing.SupportsIndex, phi: typing.SupportsFloat | typing.SupportsIndex, noise_offset: typing.Any = None) -> None:
        ...
    @property
    def kappa(self) -> float:
        ...
    @property
    def n(self) -> int:
        ...
    @property
    def noise_offset(self) -> tuple[float, float, float]:
        ...
    @property
    def phi(self) -> float:
        ...
class EvolutionParams:
    """
    How a cumulus evolves over the frames of a volume database.
    """
    def __init__(self) -> None:
        ...
    @property
    def density_scale(self) -> float:
        ...
    @density_scale.setter
    def density_scale(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def drift(self) -> tuple[float, float, float]:
        ...
    @drift.setter
    def drift(self, arg1: typing.Any) -> None:
        ...
    @property
    def frames(self) -> int:
        ...
    @frames.setter
    def frames(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def growth(self) -> float:
        ...
    @growth.setter
    def growth(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def jitter(self) -> float:
        ...
    @jitter.setter
    def jitter(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def padding(self) -> float:
        ...
    @padding.setter
    def padding(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def res(self) -> tuple[int, int, int]:
        ...
    @res.setter
    def res(self, arg1: typing.Annotated[collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], "FixedSize(3)"]) -> None:
        ...
    @property
    def seed(self) -> int:
        ...
    @seed.setter
    def seed(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def wind(self) -> tuple[float, float, float]:
        ...
    @wind.setter
    def wind(self, arg1: typing.Any) -> None:
        ...
class GaussianCumulusParams:
    """
    The Gaussian cumulus generator's parameters (§3.6.1).
    """
    clamp_mode: str
    eq16_combine: str
    hollow: bool
    radius_model: str
    remove_contained: bool
    def __init__(self) -> None:
        ...
    def validate(self) -> None:
        ...
    @property
    def centre(self) -> tuple[float, float, float]:
        ...
    @centre.setter
    def centre(self, arg1: typing.Any) -> None:
        ...
    @property
    def clamp_hi(self) -> tuple[float, float, float]:
        ...
    @clamp_hi.setter
    def clamp_hi(self, arg1: typing.Any) -> None:
        ...
    @property
    def clamp_lo(self) -> tuple[float, float, float]:
        ...
    @clamp_lo.setter
    def clamp_lo(self, arg1: typing.Any) -> None:
        ...
    @property
    def epsilon(self) -> float:
        ...
    @epsilon.setter
    def epsilon(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def hollow_box(self) -> tuple[float, float, float]:
        ...
    @hollow_box.setter
    def hollow_box(self, arg1: typing.Any) -> None:
        ...
    @property
    def mu(self) -> tuple[float, float, float]:
        ...
    @mu.setter
    def mu(self, arg1: typing.Any) -> None:
        ...
    @property
    def n(self) -> int:
        ...
    @n.setter
    def n(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def radius_hi(self) -> float:
        ...
    @radius_hi.setter
    def radius_hi(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def radius_lo(self) -> float:
        ...
    @radius_lo.setter
    def radius_lo(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def radius_scale(self) -> float:
        ...
    @radius_scale.setter
    def radius_scale(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def seed(self) -> int:
        ...
    @seed.setter
    def seed(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def sigma(self) -> tuple[float, float, float]:
        ...
    @sigma.setter
    def sigma(self, arg1: typing.Any) -> None:
        ...
class TurtleParams:
    """
    The L-system turtle: angle, radius and step ranges, symbols, start frame, seed and sphere budget.
    """
    draw_symbols: str
    move_symbols: str
    def __init__(self) -> None:
        ...
    def validate(self) -> None:
        ...
    @property
    def angle_hi(self) -> float:
        ...
    @angle_hi.setter
    def angle_hi(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def angle_lo(self) -> float:
        ...
    @angle_lo.setter
    def angle_lo(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def heading(self) -> tuple[float, float, float]:
        ...
    @heading.setter
    def heading(self, arg1: typing.Any) -> None:
        ...
    @property
    def max_spheres(self) -> int:
        ...
    @max_spheres.setter
    def max_spheres(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def radius_hi(self) -> float:
        ...
    @radius_hi.setter
    def radius_hi(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def radius_lo(self) -> float:
        ...
    @radius_lo.setter
    def radius_lo(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def seed(self) -> int:
        ...
    @seed.setter
    def seed(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def start(self) -> tuple[float, float, float]:
        ...
    @start.setter
    def start(self, arg1: typing.Any) -> None:
        ...
    @property
    def step_hi(self) -> float:
        ...
    @step_hi.setter
    def step_hi(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def step_lo(self) -> float:
        ...
    @step_lo.setter
    def step_lo(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def up(self) -> tuple[float, float, float]:
        ...
    @up.setter
    def up(self, arg1: typing.Any) -> None:
        ...
class ShadeParams:
    """
    Billboard shading ([TM]): directional term (d_min, d_max, k_dir, linear / smoothstep), ambient, k_amb and height levels (f, h).
    """
    directional: str
    def __init__(self) -> None:
        ...
    def validate(self) -> None:
        ...
    @property
    def ambient(self) -> tuple[float, float, float]:
        ...
    @ambient.setter
    def ambient(self, arg1: typing.Any) -> None:
        ...
    @property
    def d_max(self) -> float:
        ...
    @d_max.setter
    def d_max(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def d_min(self) -> float:
        ...
    @d_min.setter
    def d_min(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def height_levels(self) -> list[tuple[float, float]]:
        ...
    @height_levels.setter
    def height_levels(self, arg0: collections.abc.Sequence[tuple[typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex]]) -> None:
        ...
    @property
    def k_amb(self) -> float:
        ...
    @k_amb.setter
    def k_amb(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def k_dir(self) -> float:
        ...
    @k_dir.setter
    def k_dir(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class SunParams:
    """
    The sun: direction (towards it) and radiance.
    """
    def __init__(self) -> None:
        ...
    @property
    def direction(self) -> tuple[float, float, float]:
        ...
    @direction.setter
    def direction(self, arg1: typing.Any) -> None:
        ...
    @property
    def radiance(self) -> tuple[float, float, float]:
        ...
    @radiance.setter
    def radiance(self, arg1: typing.Any) -> None:
        ...
class SkyParams:
    """
    The gradient sky and the sun disc (RENDER_CONTRACT "Sky").
    """
    def __init__(self) -> None:
        ...
    @property
    def exponent(self) -> float:
        ...
    @exponent.setter
    def exponent(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def ground(self) -> tuple[float, float, float]:
        ...
    @ground.setter
    def ground(self, arg1: typing.Any) -> None:
        ...
    @property
    def horizon(self) -> tuple[float, float, float]:
        ...
    @horizon.setter
    def horizon(self, arg1: typing.Any) -> None:
        ...
    @property
    def sun_disc_intensity(self) -> float:
        ...
    @sun_disc_intensity.setter
    def sun_disc_intensity(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def sun_disc_radius(self) -> float:
        ...
    @sun_disc_radius.setter
    def sun_disc_radius(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def zenith(self) -> tuple[float, float, float]:
        ...
    @zenith.setter
    def zenith(self, arg1: typing.Any) -> None:
        ...
class CameraParams:
    """
    A look-at camera: position, target, up, vertical fov (degrees).
    """
    def __init__(self) -> None:
        ...
    def validate(self) -> None:
        ...
    @property
    def fov(self) -> float:
        ...
    @fov.setter
    def fov(self, arg1: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def position(self) -> tuple[float, float, float]:
        ...
    @position.setter
    def position(self, arg1: typing.Any) -> None:
        ...
    @property
    def target(self) -> tuple[float, float, float]:
        ...
    @target.setter
    def target(self, arg1: typing.Any) -> None:
        ...
    @property
    def up(self) -> tuple[float, float, float]:
        ...
    @up.setter
    def up(self, arg1: typing.Any) -> None:
        ...
class Viewport:
    """
    A camera and the image it takes (width × height).
    """
    camera: CameraParams
    def __init__(self, camera: CameraParams, width: typing.SupportsInt | typing.SupportsIndex, height: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    def validate(self) -> None:
        ...
    @property
    def height(self) -> int:
        ...
    @height.setter
    def height(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def width(self) -> int:
        ...
    @width.setter
    def width(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
class PhysicalParams:
    """
    The physical lighting mode's shading (RENDER_CONTRACT "Physical lighting").
    """
    dual_hg: bool
    mie: bool
    def __init__(self) -> None:
        ...
    def octave_sum(self, cos_theta: typing.SupportsFloat | typing.SupportsIndex, tau: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> numpy.typing.NDArray[numpy.float32]:
        """
        The drawn orders' sum Σ aⁱ·phase(bⁱg, cos_theta)·Pᵢ(τ) at optical depths `tau` (the marchers' per-sample octave term).
        """
    def phase(self, cos_theta: typing.SupportsFloat | typing.SupportsIndex, scale: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> float:
        ...
    def validate(self) -> None:
        ...
    @property
    def albedo(self) -> float:
        ...
    @albedo.setter
    def albedo(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def blend(self) -> float:
        ...
    @blend.setter
    def blend(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def coarsen_below(self) -> float:
        ...
    @coarsen_below.setter
    def coarsen_below(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def droplet_diameter(self) -> float:
        ...
    @droplet_diameter.setter
    def droplet_diameter(self, arg1: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def extinction_scale(self) -> float:
        ...
    @extinction_scale.setter
    def extinction_scale(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def g1(self) -> float:
        ...
    @g1.setter
    def g1(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def g2(self) -> float:
        ...
    @g2.setter
    def g2(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def jitter_seed(self) -> int:
        ...
    @jitter_seed.setter
    def jitter_seed(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def mie_params(self) -> tuple[float, float, float, float]:
        ...
    @property
    def min_transmittance(self) -> float:
        ...
    @min_transmittance.setter
    def min_transmittance(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def oct_a(self) -> float:
        ...
    @oct_a.setter
    def oct_a(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def oct_b(self) -> float:
        ...
    @oct_b.setter
    def oct_b(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def oct_c(self) -> float:
        ...
    @oct_c.setter
    def oct_c(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def oct_first(self) -> float:
        ...
    @oct_first.setter
    def oct_first(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def oct_poisson(self) -> float:
        ...
    @oct_poisson.setter
    def oct_poisson(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def octaves(self) -> int:
        ...
    @octaves.setter
    def octaves(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def order_phase(self) -> numpy.typing.NDArray[numpy.float32]:
        """
        Orders 1… of the drawn octaves' phase, (octaves - 1) rows of ORDER_PHASE_SIZE values at sin(θ/2) = k/(ORDER_PHASE_SIZE - 1), flattened; empty: phase(bⁱ·g).
        """
    @order_phase.setter
    def order_phase(self, arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> None:
        ...
    @property
    def view_diffuse(self) -> float:
        ...
    @view_diffuse.setter
    def view_diffuse(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def view_scale(self) -> float:
        ...
    @view_scale.setter
    def view_scale(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class MarchSettings:
    """
    The 2018 marcher's settings (RENDER_CONTRACT), filled from RenderSettings by cumuli.rendering.params.march_params.
    """
    fbm: FbmParams
    jitter: bool
    march: str
    phys: PhysicalParams
    physical: bool
    skip_empty: bool
    sort_candidates: bool
    def __init__(self) -> None:
        ...
    def validate(self) -> None:
        ...
    @property
    def absorption(self) -> float:
        ...
    @absorption.setter
    def absorption(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def density_constant(self) -> float:
        ...
    @density_constant.setter
    def density_constant(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def fixed_step(self) -> float:
        ...
    @fixed_step.setter
    def fixed_step(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def hg_g(self) -> float:
        ...
    @hg_g.setter
    def hg_g(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def lod_a(self) -> float:
        ...
    @lod_a.setter
    def lod_a(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def lod_delta(self) -> float:
        ...
    @lod_delta.setter
    def lod_delta(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def max_candidates(self) -> int:
        ...
    @max_candidates.setter
    def max_candidates(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def max_steps(self) -> int:
        ...
    @max_steps.setter
    def max_steps(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def min_transmittance(self) -> float:
        ...
    @min_transmittance.setter
    def min_transmittance(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def ref_step(self) -> float:
        ...
    @ref_step.setter
    def ref_step(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def step_max(self) -> float:
        ...
    @step_max.setter
    def step_max(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def step_min(self) -> float:
        ...
    @step_min.setter
    def step_min(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class VolumeCamera:
    """
    The volume marcher's camera: position, unit basis and tan(vertical fov / 2).
    """
    def __init__(self) -> None:
        ...
    @property
    def forward(self) -> tuple[float, float, float]:
        ...
    @forward.setter
    def forward(self, arg1: typing.Any) -> None:
        ...
    @property
    def position(self) -> tuple[float, float, float]:
        ...
    @position.setter
    def position(self, arg1: typing.Any) -> None:
        ...
    @property
    def right(self) -> tuple[float, float, float]:
        ...
    @right.setter
    def right(self, arg1: typing.Any) -> None:
        ...
    @property
    def tan_half_fov(self) -> float:
        ...
    @tan_half_fov.setter
    def tan_half_fov(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def up(self) -> tuple[float, float, float]:
        ...
    @up.setter
    def up(self, arg1: typing.Any) -> None:
        ...
class VolumeRenderParams:
    """
    The volume marcher's image, sun, sky and medium.
    """
    cubic: bool
    detail_fbm: FbmParams
    phys: PhysicalParams
    physical: bool
    sky: SkyParams
    sun: SunParams
    with_sky: bool
    def __init__(self) -> None:
        ...
    @property
    def albedo(self) -> float:
        ...
    @albedo.setter
    def albedo(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def detail(self) -> float:
        ...
    @detail.setter
    def detail(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def detail_inv_max(self) -> float:
        ...
    @detail_inv_max.setter
    def detail_inv_max(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def g(self) -> float:
        ...
    @g.setter
    def g(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def height(self) -> int:
        ...
    @height.setter
    def height(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def sigma_t(self) -> float:
        ...
    @sigma_t.setter
    def sigma_t(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def step(self) -> float:
        ...
    @step.setter
    def step(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def width(self) -> int:
        ...
    @width.setter
    def width(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
class ParticleSpriteSettings:
    """
    The Harris particles' eye pass: solid angle γ, phase, ambient, sort and culling.
    """
    cull: bool
    phase: str
    sort: str
    def __init__(self) -> None:
        ...
    @property
    def ambient(self) -> tuple[float, float, float]:
        ...
    @ambient.setter
    def ambient(self, arg1: typing.Any) -> None:
        ...
    @property
    def hg_g(self) -> float:
        ...
    @hg_g.setter
    def hg_g(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def solid_angle(self) -> float:
        ...
    @solid_angle.setter
    def solid_angle(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class SpriteRasterSettings:
    """
    The sprite rasteriser's splat kernel and peak opacity.
    """
    kernel: str
    def __init__(self) -> None:
        ...
    @property
    def peak(self) -> float:
        ...
    @peak.setter
    def peak(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class Noise:
    def __init__(self, seed: typing.SupportsInt | typing.SupportsIndex, size: typing.SupportsInt | typing.SupportsIndex = 64, version: typing.SupportsInt | typing.SupportsIndex = 2) -> None:
        ...
    def fbm(self, points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], octaves: typing.SupportsInt | typing.SupportsIndex = 5, gain: typing.SupportsFloat | typing.SupportsIndex = 0.5, lacunarity: typing.SupportsFloat | typing.SupportsIndex = 2.0, frequency: typing.SupportsFloat | typing.SupportsIndex = 1.0, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
        ...
    def fbm_scan(self, points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], octaves: typing.SupportsInt | typing.SupportsIndex = 5, gain: typing.SupportsFloat | typing.SupportsIndex = 0.5, lacunarity: typing.SupportsFloat | typing.SupportsIndex = 2.0, frequency: typing.SupportsFloat | typing.SupportsIndex = 1.0, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple[numpy.typing.NDArray[numpy.float32], float]:
        """
        fbm and, read in the same pass, the largest |coordinate| (NaN if one is not finite).
        """
    def lattice_at(self, coords: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> numpy.typing.NDArray[numpy.float32]:
        """
        Trilinear lattice value at lattice coordinates (texels).
        """
    @property
    def has_cells(self) -> bool:
        ...
    @property
    def key(self) -> int:
        """
        Version 2's 32-bit hash key of the seed.
        """
    @property
    def lattice(self) -> numpy.typing.NDArray[numpy.float32]:
        """
        The size³ uniform lattice, [z, y, x], read-only view.
        """
    @property
    def seed(self) -> int:
        ...
    @property
    def size(self) -> int:
        ...
    @property
    def version(self) -> int:
        ...
class DeckShape:
    """
    A cloud deck's heights, type, density, erosion, fBm, wind offset and extent (everything but its weather map).
    """
    cloud_type: str
    def __init__(self) -> None:
        ...
    def validate(self) -> None:
        ...
    @property
    def base(self) -> float:
        ...
    @base.setter
    def base(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def density(self) -> float:
        ...
    @density.setter
    def density(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def detail(self) -> float:
        ...
    @detail.setter
    def detail(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    @property
    def extent(self) -> tuple[float, float, float, float]:
        """
        (x0, z0, x1, z1): the weather map's extent and the slab's in x and z.
        """
    @extent.setter
    def extent(self, arg1: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(4)"]) -> None:
        ...
    @property
    def fbm(self) -> tuple[int, float, float, float]:
        """
        (octaves, gain, lacunarity, frequency) of the detail fBm.
        """
    @fbm.setter
    def fbm(self, arg1: tuple[typing.SupportsInt | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex]) -> None:
        ...
    @property
    def offset(self) -> tuple[float, float]:
        """
        (ox, oz): the map's and the fBm's shift, wind · time.
        """
    @offset.setter
    def offset(self, arg1: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(2)"]) -> None:
        ...
    @property
    def top(self) -> float:
        ...
    @top.setter
    def top(self, arg0: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
class EndlessWalk:
    def __init__(self, similarity: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], sigma: typing.SupportsFloat | typing.SupportsIndex, crossfade: typing.SupportsInt | typing.SupportsIndex, seed: typing.SupportsInt | typing.SupportsIndex, start: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    def next(self) -> tuple[int, int, float, bool]:
        ...
    @property
    def current(self) -> int:
        ...
    @property
    def live(self) -> numpy.typing.NDArray[numpy.bool]:
        ...
    @property
    def matrix(self) -> numpy.typing.NDArray[numpy.float64]:
        ...
class WeatherSim:
    def __init__(self, area: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(4)"], layers: list, schedule: collections.abc.Sequence[typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(2)"]], seed: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    def counts(self, layer: typing.SupportsInt | typing.SupportsIndex) -> list[int]:
        ...
    def cv_at(self, t: typing.SupportsFloat | typing.SupportsIndex) -> float:
        ...
    def instances(self, layer: typing.SupportsInt | typing.SupportsIndex) -> dict:
        ...
    def layer_stats(self, layer: typing.SupportsInt | typing.SupportsIndex) -> dict:
        ...
    def mix(self, arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.SupportsFloat | typing.SupportsIndex) -> tuple[int, int, float]:
        ...
    def set_state(self, t: typing.SupportsFloat | typing.SupportsIndex, layers: list) -> None:
        """
        Replace the state (after validating sizes, indices and counters); the weather is unchanged when it raises.
        """
    def step(self, dt: typing.SupportsFloat | typing.SupportsIndex) -> None:
        ...
    def target(self, layer: typing.SupportsInt | typing.SupportsIndex, cv: typing.SupportsFloat | typing.SupportsIndex) -> int:
        ...
    @property
    def cv(self) -> float:
        ...
    @property
    def time(self) -> float:
        ...
def add_multiple_scattering(arg0: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg2: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg3: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg4: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg5: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg6: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg7: typing.SupportsFloat | typing.SupportsIndex, arg8: typing.SupportsFloat | typing.SupportsIndex, arg9: typing.SupportsInt | typing.SupportsIndex, arg10: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float32]:
    """
    Light plus `orders` orders of isotropic multiple scattering through the sample points.
    """
def approx_mie_mean_cosine(diameter: typing.SupportsFloat | typing.SupportsIndex) -> float:
    """
    The approximate Mie phase's mean cosine.
    """
def approx_mie_params(diameter: typing.SupportsFloat | typing.SupportsIndex) -> tuple[float, float, float, float]:
    """
    (g_HG, g_D, alpha, w_D) of the approximate Mie phase for droplets of `diameter` µm.
    """
def approx_mie_phase(diameter: typing.SupportsFloat | typing.SupportsIndex, cos_theta: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], scale: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> numpy.typing.NDArray[numpy.float32]:
    """
    The approximate Mie phase (normalised by 1/4π) at cosines, lobes' g scaled by `scale`.
    """
def atlas_grid(n: typing.SupportsInt | typing.SupportsIndex) -> tuple[int, int]:
    ...
def billboard_corners(centres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], sizes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], rotation: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], right: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], up: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"]) -> numpy.typing.NDArray[numpy.float32]:
    """
    Camera-facing quad corners (K, 4, 3): v0 bottom-left, v1 bottom-right, v2 top-right, v3 top-left of the quad turned by each billboard's rotation about the view axis.
    """
def billboard_shade(points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], index: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], caf: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], boxes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], light_dirs: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], light_radiance: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], shade: ShadeParams, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    Colours (N, 3) = k_amb·ambient + H·Σ_ℓ caf[ℓ, index]·D_ℓ·radiance_ℓ at points; the cloud frame (centre, radius, heights) comes from the boxes.
    """
def billboard_sprites(variants: list, variant: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], offsets: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], yaw: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], alpha: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], caf_first: typing.Annotated[numpy.typing.ArrayLike, numpy.int64], caf: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], shade: dict, camera: dict, draw: dict, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> dict:
    """
    The sprites of billboard clouds for a camera: culled, faded, sorted back to front and shaded (vertex colours, or per-sprite fragment-shading data): a dict of arrays.
    """
def billboard_vertex_colours(centres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], sizes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], rotation: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], index: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], caf: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], boxes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], light_dirs: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], light_radiance: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], shade: ShadeParams, right: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], up: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32]]:
    """
    [TM]'s vertex shading: ((K, 4, 3) colours, (K, 4, 3) corners) of the camera-facing quads.
    """
def blend_volumes(a: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], b: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], w: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    w·a + (1 − w)·b.
    """
def buffer_cache_stats() -> dict:
    """
    The light step's idle-block cache: idle_blocks and idle_bytes it holds, its limit_bytes, and the hits (blocks reused) and misses (blocks made afresh) since the process started.
    """
def caf_path_lengths(boxes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], owner: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], sun: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], overlap: str, include_self: bool, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float64]:
    """
    Light path length L through the boxes from each point towards the sun: (N,) float64.
    """
def caf_values(lengths: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], max_distance: typing.SupportsFloat | typing.SupportsIndex, curve: str) -> numpy.typing.NDArray[numpy.float32]:
    """
    CAF of path lengths: clamp(1 − L/D, 0, 1) (linear) or exp(−3L/D); D = inf gives 1.
    """
def camera_candidates(centres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], radii: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], rotations: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], model: str, origin: tuple[typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex], dirs: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], capacity: typing.SupportsInt | typing.SupportsIndex = 64) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32]]:
    """
    The candidates (primitive, t_in, t_out; −1 past the last) of rays from one origin, by the camera's fan (culled by cones, the marchers' path) and by testing every primitive: (fan, each), each (n, capacity, 3) float32. For tests: the two must agree bit for bit.
    """
def cloud_density(cloud: CloudShape, points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], noise: Noise, constant: typing.SupportsFloat | typing.SupportsIndex, fbm: FbmParams = ..., threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32]]:
    """
    Density (rho, gamma) of a cloud at points (eq. 2 or eqs. 19-21).
    """
def composite_layers(layers: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], boxes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], camera: CameraParams, sky: typing.Any, sun_direction: typing.Any, sun_radiance: typing.Any, threads: typing.SupportsInt | typing.SupportsIndex = 0, solid: typing.Any = None, ground: typing.Any = None, view_scales: typing.Any = None) -> numpy.typing.NDArray[numpy.float32]:
    """
    Composite premultiplied layers (L, H, W, 4) over the sky, front to back per pixel by the ray's entry into each layer's box (L, 2, 3): an (H, W, 4) float32 image, row 0 on top. solid (H, W, 4): rgb and view depth of opaque solids (+inf where none), which hide the layers entered behind them. view_scales (L,) in (0, 1]: what lies behind layer k shows through (1 − A_k)^v_k of it (the physical mode's δ-M view of a medium; None: all 1).
    """
def composite_split(layers: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], solids: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    Harris 2002's split composite: layers farthest first, a solid image between each pair (depth test among solids, none for layers): one premultiplied (H, W, 4) layer.
    """
def coverage_edges(alpha: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], range: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.bool]:
    """
    The (H, W) bool mask of the pixels whose 3x3 neighbourhood (edges clamped) of the (H, W) coverage alpha spans more than range: the physical mode's outline (the edge pass).
    """
def crossfade_weight(step: typing.SupportsInt | typing.SupportsIndex, frames: typing.SupportsInt | typing.SupportsIndex) -> float:
    ...
def deck_density(shape: DeckShape, map: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], noise: Noise, points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], threads: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float32]:
    """
    A cloud deck's density at (N, 3) points: (N,) float32.
    """
def deck_lattice(shape: DeckShape, map: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], noise: Noise, resolution: typing.Annotated[collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], "FixedSize(3)"], threads: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float32]:
    """
    A cloud deck's density at the texel centres of its slab: (nz, ny, nx) float32 [z, y, x].
    """
def density_grid(cloud: CloudShape, noise: Noise, constant: typing.SupportsFloat | typing.SupportsIndex, fbm: FbmParams, lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], hi: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], res: typing.Annotated[collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], "FixedSize(3)"], supersample: typing.SupportsInt | typing.SupportsIndex = 1, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    The density field (union attribution) on a lattice over a box: (D, H, W) float32, the mean of supersample³ points per voxel (1: texel centres).
    """
def diffusion_anisotropy(extinction: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], hi: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], phi: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], albedo: typing.SupportsFloat | typing.SupportsIndex, mean_cosine: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0, sun_t: typing.Any = None, to_sun: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] = [0.0, 1.0, 0.0], forward: typing.SupportsFloat | typing.SupportsIndex = 0.0) -> numpy.typing.NDArray[numpy.float32]:
    """
    The anisotropy r = 3E/phi of channel 0 of a diffusion solution phi (D, H, W, C): (D, H, W, 3), E = -D grad phi the diffuse flux (Marshak's leak at the medium's faces), plus forward*3D*Q1, the forward-scattered flux of diffusion_light's sun source (with sun_t, the same sun_t, to_sun and forward as that call); |r| <= 3; the empty cells next to the medium hold their medium neighbours' mean.
    """
def diffusion_light(extinction: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], hi: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], sun_t: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], to_sun: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], sky_e: typing.Any, albedo: typing.SupportsFloat | typing.SupportsIndex, mean_cosine: typing.SupportsFloat | typing.SupportsIndex, tolerance: typing.SupportsFloat | typing.SupportsIndex = 9.999999747378752e-06, threads: typing.SupportsInt | typing.SupportsIndex = 0, forward: typing.SupportsFloat | typing.SupportsIndex = 0.0, solver: str = 'mic') -> numpy.typing.NDArray[numpy.float32]:
    """
    Collided fluence of the diffusion approximation: (D, H, W, 1 | 4) (sun per unit irradiance, then the sky's RGB); forward: the weight of the forward-scattered sun's flux source (0: an isotropic source); solver: the conjugate gradients' preconditioner, 'mic' (modified incomplete Cholesky over the medium cells) or 'jacobi' (the diagonal, over the whole lattice).
    """
def display_impostors(images: list, planes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], clamp: typing.Any, camera_position: typing.Any, camera_target: typing.Any, camera_up: typing.Any, fov: typing.SupportsFloat | typing.SupportsIndex, width: typing.SupportsInt | typing.SupportsIndex, height: typing.SupportsInt | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    Impostors drawn back to front (exact bilinear): images (h, w, 4) premultiplied, planes (n, 14) = centre, forward, right, up, half_w, half_h; clamp (n,) bool. An (H, W, 4) premultiplied layer, row 0 on top.
    """
def draw_solids(spheres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], colours: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], ambient: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], camera_position: typing.Any, camera_target: typing.Any, camera_up: typing.Any, fov: typing.SupportsFloat | typing.SupportsIndex, width: typing.SupportsInt | typing.SupportsIndex, height: typing.SupportsInt | typing.SupportsIndex, sun_direction: typing.Any, sun_radiance: typing.Any, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    The solid image of opaque spheres (n, 4): (H, W, 4) rgb (Lambert + ambient) and the view depth of the nearest solid (+inf where none), row 0 on top.
    """
def ellipsoids_from_mesh(vertices: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], faces: numpy.ndarray, scale: typing.SupportsFloat | typing.SupportsIndex, rotate: bool, min_radius: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], dict]:
    """
    Mesh → ellipsoids (§3.6.4, eqs. 22–30): returns (centres (F,3), radii (F,3), rotations (F,3,3), stats).
    """
def evolving_cloud_box(cloud: CloudShape, evolution: EvolutionParams) -> tuple[typing.Annotated[list[float], "FixedSize(3)"], typing.Annotated[list[float], "FixedSize(3)"]]:
    """
    World box holding the evolving cloud at every frame (padded): ((x,y,z) lo, (x,y,z) hi).
    """
def evolving_cloud_volumes(cloud: CloudShape, noise: Noise, constant: typing.SupportsFloat | typing.SupportsIndex, fbm: FbmParams, evolution: EvolutionParams, box_lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], box_hi: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], threads: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float32]:
    """
    Voxelise an evolving cloud: (frames, D, H, W) float32 densities.
    """
def field_path_lengths(variant_boxes: list, variant_points: list, variant_owners: list, variant: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], offsets: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], yaw: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], sun: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], overlap: str, include_self: bool, between_clouds: bool, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float64]:
    """
    Path lengths of every instance's points (instance order, flat), optionally through the other instances' boxes too.
    """
def finish_physical(image: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], camera: CameraParams, sky: SkyParams, sun: SunParams, ground: typing.Any, boxes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], air: tuple[typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex], phase: PhysicalParams, resolve: bool, threads: typing.SupportsInt | typing.SupportsIndex = 0, unfiltered: typing.Any = None, out: typing.Any = None) -> numpy.ndarray:
    """
    The physical mode's finishing passes on a finished (H, W, 4) image (a new array): the air (air = (air_extinction, air_height, haze): aerial perspective, and the aureole with phase's phase function; boxes (n, 2, 3): the drawables' layer boxes for the clouds' depth), then the 3x3 tent resolve when resolve is true, except at the pixels where unfiltered (H, W) is nonzero (the edge pass's supersampled pixels). out: a writable C-contiguous float32 (H, W, 4) array to write into and return instead of a new one; it may be image itself (finished in place), but must not overlap it otherwise.
    """
def fit_shexp(f: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], order: typing.SupportsInt | typing.SupportsIndex, sigma_t: typing.SupportsFloat | typing.SupportsIndex, bins: typing.SupportsInt | typing.SupportsIndex, n_theta: typing.SupportsInt | typing.SupportsIndex) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], float]:
    ...
def gaussian_cumulus(params: GaussianCumulusParams) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], dict]:
    """
    Gaussian cumulus (params: a GaussianCumulusParams) (§3.6.1): returns (centres (N,3), radii (N,), stats dict).
    """
def impostor_backwards(arg0: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg1: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg2: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"]) -> bool:
    """
    Whether the eye is nearer the far point than the near point.
    """
def impostor_focal_length_px(arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.SupportsFloat | typing.SupportsIndex) -> float:
    """
    f_px = (H/2)/tan(fov/2).
    """
def impostor_half_diagonal_fov(arg0: typing.SupportsFloat | typing.SupportsIndex, arg1: typing.SupportsFloat | typing.SupportsIndex) -> float:
    """
    atan(th·√(1 + aspect²)), radians.
    """
def impostor_near_corner_radius(arg0: typing.SupportsFloat | typing.SupportsIndex, arg1: typing.SupportsFloat | typing.SupportsIndex, arg2: typing.SupportsFloat | typing.SupportsIndex) -> float:
    """
    near·√(1 + th²(1 + aspect²)).
    """
def impostor_rects(arg0: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg1: typing.Any, arg2: typing.Any, arg3: typing.Any, arg4: typing.Any, arg5: typing.SupportsFloat | typing.SupportsIndex, arg6: typing.SupportsInt | typing.SupportsIndex, arg7: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.int32]:
    """
    Conservative pixel rectangles (n, 4) = j0, j1, i0, i1 (inclusive) of impostor quads.
    """
def impostor_required_resolution(arg0: typing.SupportsFloat | typing.SupportsIndex, arg1: typing.SupportsFloat | typing.SupportsIndex, arg2: typing.SupportsFloat | typing.SupportsIndex, arg3: typing.SupportsFloat | typing.SupportsIndex) -> float:
    """
    res_req = res_scale·f_px·2R/d.
    """
def impostor_resolution(arg0: typing.SupportsFloat | typing.SupportsIndex, arg1: typing.SupportsInt | typing.SupportsIndex, arg2: typing.SupportsInt | typing.SupportsIndex, arg3: bool) -> int:
    """
    min(max_res, max(min_res, pow2ceil(res_req))).
    """
def impostor_resolution_skyworks(arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.SupportsInt | typing.SupportsIndex, arg2: typing.SupportsFloat | typing.SupportsIndex, arg3: typing.SupportsFloat | typing.SupportsIndex, arg4: typing.SupportsFloat | typing.SupportsIndex, arg5: typing.SupportsInt | typing.SupportsIndex) -> int:
    """
    SkyWorks' impostor resolution rule.
    """
def impostor_translation_error(arg0: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg1: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg2: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"]) -> float:
    """
    α_trans (radians): the angle at the eye between the near and far points.
    """
def lattice_transmittance(depth: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], frame: tuple, lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], cell: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], dims: typing.Annotated[collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], "FixedSize(3)"], threads: typing.SupportsInt | typing.SupportsIndex = 0, upstream: typing.Any = None, depth_scale: typing.SupportsFloat | typing.SupportsIndex = 1.0, carried: typing.SupportsFloat | typing.SupportsIndex = 0.0, carried_rate: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> numpy.typing.NDArray[numpy.float32]:
    """
    e^-(depth_scale*tau) of a light-frame lattice of optical depths tau (plus `upstream`, a (nv, nu) map of one depth per column, where given) at the centres of a (W, H, D) lattice (lo + (index + 1/2)*cell per axis, float32), shape (D, H, W): the sun's transmittance on a drawable's world lattice. `carried` m > 0: the diffusion's sun source with a share m of the collided light carried on along the light, turning diffuse at the rate `carried_rate` a: (1 - m)*e^(-k*tau) + m*a/(a - k)*(e^(-k*tau) - e^(-a*tau)), k = depth_scale.
    """
def light_frame(arg0: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg1: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg2: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg3: typing.Annotated[collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], "FixedSize(3)"]) -> tuple:
    """
    The sun's lattice enclosing a box: (u, v, w, lo, hi, res) with w the way light travels.
    """
def light_grid(cloud: CloudShape, noise: Noise, sun_dir: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], resolution: typing.Annotated[collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], "FixedSize(3)"], method: str, step: typing.SupportsFloat | typing.SupportsIndex, extinction: typing.SupportsFloat | typing.SupportsIndex, solid_angle: typing.SupportsFloat | typing.SupportsIndex, fbm: FbmParams, density_constant: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.uint32], tuple[float, float, float], tuple[float, float, float], int, float]:
    """
    Light grid L(v) [z, y, x] (see cumuli.light_grid). Returns (grid, samples, lo, hi, total_samples, seconds).
    """
def light_space_depth(clouds: list, volumes: list, noise: Noise, octaves: typing.SupportsInt | typing.SupportsIndex, gain: typing.SupportsFloat | typing.SupportsIndex, lacunarity: typing.SupportsFloat | typing.SupportsIndex, frequency: typing.SupportsFloat | typing.SupportsIndex, frame: tuple, step: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0, depth_cut: typing.SupportsFloat | typing.SupportsIndex = ...) -> numpy.typing.NDArray[numpy.float32]:
    """
    Optical depth from the sun-side face of a light frame to each node: (nw, nv, nu). Each
    drawable's march along a column ends after the segment where its depth exceeds depth_cut:
    nodes before keep their exact depth, nodes after hold a depth above the cut.
    """
def light_volume(arg0: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg2: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg3: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg4: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg5: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg6: typing.SupportsFloat | typing.SupportsIndex, arg7: typing.SupportsInt | typing.SupportsIndex, arg8: bool, arg9: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg10: typing.SupportsFloat | typing.SupportsIndex, arg11: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float32]:
    """
    Per-voxel (τ_sun, E_sky RGB): (D, H, W, 4).
    """
def lsystem_expand(axiom: str, rules: collections.abc.Mapping[str, str], iterations: typing.SupportsInt | typing.SupportsIndex, max_length: typing.SupportsInt | typing.SupportsIndex) -> str:
    """
    Rewrite the axiom `iterations` times; refuses (ValueError) before allocating when any string would exceed max_length symbols.
    """
def lsystem_interpret(symbols: str, params: TurtleParams) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], dict]:
    """
    Walk an L-system string with the 3D turtle (params: a TurtleParams): returns (centres (N,3), radii (N,), stats).
    """
def lsystem_length(axiom: str, rules: collections.abc.Mapping[str, str], iterations: typing.SupportsInt | typing.SupportsIndex) -> tuple[int, int]:
    """
    (final, peak) symbol counts of the expansion, saturating at 2**64 - 1; allocates nothing.
    """
def medium_optical_depth(clouds: list, volumes: list, noise: Noise, octaves: typing.SupportsInt | typing.SupportsIndex, gain: typing.SupportsFloat | typing.SupportsIndex, lacunarity: typing.SupportsFloat | typing.SupportsIndex, frequency: typing.SupportsFloat | typing.SupportsIndex, points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], direction: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], step: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    Optical depth of every cloud and volume along points + t·direction, t >= 0: (N,).
    """
def needs_screen_impostor(arg0: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg1: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg2: typing.SupportsFloat | typing.SupportsIndex, arg3: typing.SupportsFloat | typing.SupportsIndex, arg4: typing.SupportsFloat | typing.SupportsIndex, arg5: typing.SupportsFloat | typing.SupportsIndex) -> bool:
    """
    Whether the sphere must be drawn through a screen impostor from the eye.
    """
def occupancy_grid(centres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], radii: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], rotations: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], model: str, resolution: typing.SupportsInt | typing.SupportsIndex = 16) -> tuple[numpy.typing.NDArray[numpy.uint8], tuple[float, float, float], tuple[float, float, float]]:
    """
    A cloud's occupancy grid for empty-space skipping (RENDER_CONTRACT): (cells [z, y, x] uint8, 1 where density may be > 0, 0 where it is certainly 0; lo; hi), over the cloud's candidate box.
    """
def particle_fill(cloud: CloudShape, n: typing.SupportsInt | typing.SupportsIndex, radius_min: typing.SupportsFloat | typing.SupportsIndex, radius_max: typing.SupportsFloat | typing.SupportsIndex, tau: typing.SupportsFloat | typing.SupportsIndex, albedo: typing.SupportsFloat | typing.SupportsIndex, noise: Noise, fbm: FbmParams, tau_floor: typing.SupportsFloat | typing.SupportsIndex, seed: typing.SupportsInt | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32]]:
    """
    Fill a cloud's ellipsoid union with particles: (centres, radii, tau, albedo).
    """
def particle_light(clouds: list, directions: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], settings: dict, return_buffers: bool = False, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> list:
    """
    Harris 2002 light pass for clouds × lights: [(light (N, L), buffers (L, N_L, N_L) | None)].
    """
def particle_light_splats(arg0: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg2: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg3: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg4: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg5: dict) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.int32], numpy.typing.NDArray[numpy.int32], numpy.typing.NDArray[numpy.float32], float]:
    """
    The light pass's splats per light in processing order: (geometry (L, N, 5) = x, y, r_px, forward factor, alpha; index (L, N); patch (L, N); frames (L, 4, 3) = centre, f, r, u; R_b).
    """
def particle_shadow(arg0: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg2: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg3: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg4: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg5: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg6: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> numpy.typing.NDArray[numpy.float32]:
    """
    Transmittance of the light through a particle cloud at world points (M, 3), from its final light buffer (the shadow map): (M,) float32, 1 outside the buffer or in front.
    """
def particle_sphere(arg0: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg2: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg3: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float], float]:
    """
    ((lo), (hi), (sphere centre), sphere radius) of a particle cloud, float32 as the core.
    """
def particle_sprites(centres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], radii: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], tau: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], albedo: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], light: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], directions: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], radiances: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], camera: dict, settings: ParticleSpriteSettings) -> tuple[numpy.typing.NDArray[numpy.int64], numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32]]:
    """
    Eye pass sprites of a particle cloud (settings: a ParticleSpriteSettings): (index back to front, colours (M, 3), alpha (M,), sort keys (M,)).
    """
def particles_from_volume(density: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], hi: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], n: typing.SupportsInt | typing.SupportsIndex, radius: typing.SupportsFloat | typing.SupportsIndex, tau: typing.SupportsFloat | typing.SupportsIndex, albedo: typing.SupportsFloat | typing.SupportsIndex, tau_floor: typing.SupportsFloat | typing.SupportsIndex, seed: typing.SupportsInt | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32]]:
    """
    Importance-sample a density volume into particles: (centres, radii, tau, albedo).
    """
def particles_to_volume(arg0: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg2: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg3: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg4: typing.Annotated[collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], "FixedSize(3)"], arg5: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg6: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg7: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float32]:
    """
    Sample the particles' Gaussian-blob extinction on a (nz, ny, nx) grid [z, y, x].
    """
def phase_4pi(arg0: str, arg1: typing.SupportsFloat | typing.SupportsIndex, arg2: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> numpy.typing.NDArray[numpy.float32]:
    """
    Harris 2002 phase functions normalised to 4π at cosines c: rayleigh, isotropic or hg.
    """
def physical_grid(extinction: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], phi: typing.Any, sky_e: typing.Any, cell: typing.SupportsFloat | typing.SupportsIndex, gain_depth: typing.SupportsFloat | typing.SupportsIndex, sun_gain: typing.SupportsFloat | typing.SupportsIndex, sky_gain: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    A drawable's physical light lattice (D, H, W, 4), float32: A = G_sun*phi_sun, RGB = G_sky*(sky_e + phi_sky) (sky_e alone without phi), G = 1 + (G_inf - 1)*(1 - exp(-max(extinction, 0)*cell/gain_depth)) (G_inf where gain_depth is 0).
    """
def point_optical_depth(volumes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], box_min: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], box_max: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], step: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex, method: str = 'march') -> numpy.typing.NDArray[numpy.float32]:
    """
    Optical depth from every voxel centre to every sample point: (N, D, H, W, K).
    """
def project_sprites(arg0: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg1: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg2: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], arg3: dict) -> numpy.typing.NDArray[numpy.float32]:
    """
    Screen projection of sprites: (N, 6) = j_c, i_c, hx, hy (pixels), depth Z, visible.
    """
def rasterise_sprites(centres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], half_sizes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], rotation: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], colours: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], alpha: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], texture: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], camera: dict, settings: SpriteRasterSettings, atlas: typing.Any, threads: typing.SupportsInt | typing.SupportsIndex = 0, shading: typing.Any = None, depth: typing.Any = None) -> numpy.typing.NDArray[numpy.float32]:
    """
    Rasterise view-plane-parallel sprites back to front into a premultiplied (H, W, 4) layer; settings: a SpriteRasterSettings (kernel, peak); atlas: None or (rgba (H, W, 4), (nx, ny)); shading: per-pixel billboard shading; depth (H, W): a sprite covers only pixels where its view depth is smaller.
    """
def release_buffer_cache() -> int:
    """
    Give every idle block of the cache back to the system; returns the bytes given back.
    """
def remove_contained_spheres(centres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], radii: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> numpy.typing.NDArray[numpy.int64]:
    """
    Eq. (17): indices of the spheres kept so that none lies inside another.
    """
def render_cpu(view: Viewport, clouds: list, sun: SunParams, sky: SkyParams, settings: MarchSettings, noise: Noise, threads: typing.SupportsInt | typing.SupportsIndex = 0, with_sky: bool = True, solids: typing.Any = None, ground: typing.Any = None, return_stats: bool = False, pixels: typing.Any = None) -> typing.Any:
    """
    CPU reference ray marcher (RENDER_CONTRACT): an (H, W, 4) float32 RGBA image of the Viewport, row 0 at the top. Each cloud is a dict with centres, radii, rotations, model, kappa, phi, light ([z, y, x]) and light_lo / light_hi (or physical). settings: a MarchSettings (density_constant >= 0 replaces fBm, for tests; physical selects the physical mode with its PhysicalParams). with_sky=False gives the premultiplied layer (colour, 1 − T); solids (n, 4) (centre, radius) stop every ray at the nearest solid; return_stats=True returns (image, {fbm_evaluations, steps, skipped, fbm_map}); pixels, an (N, 2) integer array of (row, column), marches only those pixels of the image and returns their (N, 4) values in that order (fbm_map then (N,)).
    """
def render_cpu_edged(view: Viewport, clouds: list, sun: SunParams, sky: SkyParams, settings: MarchSettings, noise: Noise, threads: typing.SupportsInt | typing.SupportsIndex = 0, ground: typing.Any = None, return_stats: bool = False, edges: typing.Any = None) -> typing.Any:
    """
    render_cpu over the sky (no solids) with the physical mode's edge pass in the same call (cumuli.rendering.edges): edges, a tuple (range, sub, rays, max_rays, max_sub_edge). Returns (image, mask or None) and, with return_stats, (image, mask or None, stats), the outline's work counted in its pixels.
    """
def render_volume_cpu(density: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], light: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], hi: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], camera: VolumeCamera, params: VolumeRenderParams, threads: typing.SupportsInt | typing.SupportsIndex, solids: typing.Any = None, physical_light: typing.Any = None, noise: typing.Any = None) -> numpy.typing.NDArray[numpy.float32]:
    """
    CPU emission–absorption march of a lit density volume: (H, W, 4) float32, row 0 on top. camera: a VolumeCamera; params: VolumeRenderParams (image, sun, sky, medium; physical with its PhysicalParams and physical_light); solids (n, 4) stop every ray at the nearest solid; noise: the fBm lattice of the physical mode's detail (params.detail > 0).
    """
def sample_frame(values: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], frame: tuple, points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], threads: typing.SupportsInt | typing.SupportsIndex = 0, upstream: typing.Any = None) -> numpy.typing.NDArray[numpy.float32]:
    """
    Trilinear values of a light-frame lattice at (N, 3) world points, plus the bilinear value of `upstream`, a (nv, nu) map of one value per column, where given.
    """
def sample_volume(volume: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], hi: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], points: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    Trilinear values (texel centres, clamp to edge) of a (D, H, W) volume at (N, 3) points.
    """
def screen_candidates(centres: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], radii: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], rotations: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], model: str, viewport: Viewport, capacity: typing.SupportsInt | typing.SupportsIndex = 64) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.int32]]:
    """
    The candidates (primitive, t_in, t_out; −1 past the last) of every pixel's camera ray, by the marchers' fan binned by screen tile and by testing every primitive, and the number of primitives each pixel's bin holds: (binned, each, tested), binned and each (H, W, capacity, 3) float32, tested (H, W) int32. For tests: binned and each must agree bit for bit.
    """
def screen_impostor_size(arg0: typing.SupportsInt | typing.SupportsIndex, arg1: typing.SupportsInt | typing.SupportsIndex) -> int:
    """
    ⌈size/factor⌉.
    """
def seed_box_cloud(seeds: list, billboard_size: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(2)"], aspect_min: typing.SupportsFloat | typing.SupportsIndex, textures: collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], rotate: bool, min_spacing: typing.SupportsFloat | typing.SupportsIndex, ellipsoid: bool, seed: typing.SupportsInt | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> dict:
    """
    Seed-and-box cloud (Torchelsen & Musse 2005 §3, eq. 1): dict of boxes and billboards.
    """
def seed_box_worst_case(seeds: list) -> tuple[int, int]:
    """
    (boxes, billboards) in the worst case of a seed-box parameter set.
    """
def set_buffer_cache_limit(bytes: typing.SupportsInt | typing.SupportsIndex) -> int:
    """
    Set the most bytes the idle-block cache keeps (0: none), giving back what is over it; returns the previous limit.
    """
def set_progress(callback: typing.Any) -> typing.Any:
    """
    Set this thread's progress callback (done, total) of long C++ loops (None: none); returns the previous one.
    """
def set_simd_fetch(fetch: str) -> None:
    """
    Use this lattice fetch ('auto': back to CUMULI_SIMD_FETCH or the CPU's).
    """
def set_simd_level(level: str) -> None:
    """
    Use this SIMD level ('auto': back to CUMULI_SIMD or the widest).
    """
def sh_eval(order: typing.SupportsInt | typing.SupportsIndex, directions: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> numpy.typing.NDArray[numpy.float32]:
    ...
def sh_optical_depth(volumes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], box_min: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], box_max: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], order: typing.SupportsInt | typing.SupportsIndex, n_theta: typing.SupportsInt | typing.SupportsIndex, step: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex, method: str = 'march') -> numpy.typing.NDArray[numpy.float32]:
    """
    SH coefficients of per-voxel optical depth over directions: (N, D, H, W, order²).
    """
def shexp_apply(g: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], a: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], b: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], max_norm: typing.SupportsFloat | typing.SupportsIndex, order: typing.SupportsInt | typing.SupportsIndex, squaring: bool = False) -> numpy.typing.NDArray[numpy.float32]:
    ...
def simd_fetch() -> str:
    """
    How the wide fBm kernels read the lattice now: 'gather', 'loads' or 'cells'.
    """
def simd_fetch_preferred() -> str:
    """
    The fetch this CPU runs fastest where measured: 'cells' on AMD, 'gather' elsewhere.
    """
def simd_level() -> str:
    """
    The SIMD level the core's fBm uses now: 'scalar', 'avx2' or 'avx512'.
    """
def simd_levels() -> list:
    """
    The SIMD levels this CPU and build support, narrowest first.
    """
def similarity_matrix(volumes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float64]:
    """
    D_kl = Σ (ρ_k − ρ_l)² for all pairs: (N, N) float64.
    """
def sky_irradiance(extinction: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], hi: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], sky_coeffs: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], order: typing.SupportsInt | typing.SupportsIndex, n_theta: typing.SupportsInt | typing.SupportsIndex, step: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0, method: str = 'march') -> numpy.typing.NDArray[numpy.float32]:
    """
    Sky irradiance reaching each voxel unscattered (SH visibility × sky SH): (D, H, W, 3); method 'march' (a ray per voxel and product-quadrature direction, n_theta polar nodes, steps of `step` voxels) or 'lattice' (the 26 neighbour directions, τ exact by a recurrence over the lattice; voxels within 10 % of cubes, else 'march').
    """
def sky_irradiance_from(visibility: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], sky_coeffs: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], threads: typing.SupportsInt | typing.SupportsIndex = 0) -> numpy.typing.NDArray[numpy.float32]:
    """
    Sky irradiance (D, H, W, 3) from sky_visibility's moments and a sky's SH coefficients: the same values sky_irradiance gives.
    """
def sky_sh(sky: typing.Any, order: typing.SupportsInt | typing.SupportsIndex, n_theta: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float32]:
    ...
def sky_visibility(extinction: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], lo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], hi: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], order: typing.SupportsInt | typing.SupportsIndex, n_theta: typing.SupportsInt | typing.SupportsIndex, step: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0, method: str = 'march') -> numpy.typing.NDArray[numpy.float32]:
    """
    The sky visibility's SH moments per voxel, (D, H, W, order²) float32 (each summed in double): sky_irradiance without the sky (sky_irradiance_from projects a sky onto them).
    """
def sphere_outside_frustum(arg0: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg1: typing.SupportsFloat | typing.SupportsIndex, arg2: dict) -> bool:
    """
    Whether a sphere lies wholly outside the camera frustum (conservative).
    """
def sphere_quadrature(n_theta: typing.SupportsInt | typing.SupportsIndex) -> tuple[numpy.typing.NDArray[numpy.float32], numpy.typing.NDArray[numpy.float32]]:
    ...
def splat_kernel(arg0: str, arg1: typing.SupportsFloat | typing.SupportsIndex, arg2: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> numpy.typing.NDArray[numpy.float32]:
    """
    The splat kernel K(d) (0 for d >= 1) at distances d in units of the splat radius.
    """
def sprite_atlas(style: str, n: typing.SupportsInt | typing.SupportsIndex, size: typing.SupportsInt | typing.SupportsIndex, seed: typing.SupportsInt | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex = 0) -> tuple[numpy.typing.NDArray[numpy.float32], tuple[int, int]]:
    """
    Procedural sprite atlas: ((H, W, 4) float32 straight-alpha RGBA, (nx, ny) grid).
    """
def sun_optical_depth(volumes: typing.Annotated[numpy.typing.ArrayLike, numpy.float32], box_min: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], box_max: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], to_sun: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], step: typing.SupportsFloat | typing.SupportsIndex, threads: typing.SupportsInt | typing.SupportsIndex, method: str = 'march') -> numpy.typing.NDArray[numpy.float32]:
    """
    Optical depth towards the sun per voxel: (N, D, H, W); method 'march' or 'sweep'.
    """
def tight_impostor_view(arg0: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg1: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], arg2: typing.SupportsFloat | typing.SupportsIndex) -> dict:
    """
    The tight impostor camera of a bounding sphere seen from an eye (dict).
    """
def transition_matrix(similarity: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], sigma: typing.SupportsFloat | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float64]:
    """
    The paper's P_kl ∝ exp(−D_{k+1,l}/σ) (last row: exp(−D_{N−1,l−1}/σ)), rows summing to 1.
    """
def variant_seed(seed: typing.SupportsInt | typing.SupportsIndex, basis: typing.SupportsInt | typing.SupportsIndex, variant: typing.SupportsInt | typing.SupportsIndex) -> int:
    """
    Generator seed of variant v of basis model b: Rng::stream(seed, b·2¹⁶ + v).
    """
def volume_sample_points(box_min: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], box_max: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], count: typing.SupportsInt | typing.SupportsIndex, seed: typing.SupportsInt | typing.SupportsIndex) -> numpy.typing.NDArray[numpy.float32]:
    ...
def yaw_cos_sin(degrees: typing.SupportsFloat | typing.SupportsIndex) -> tuple[float, float]:
    """
    (cos, sin) of an angle in degrees, exact at multiples of 90°.
    """
ATLAS_MAX_SIZE: int = 512
ATLAS_MAX_SPRITES: int = 256
ATLAS_MIN_SIZE: int = 8
COARSEN_EVERY: int = 16
DECK_DETAIL_CONTRAST: float = 3.0
DECK_MAX_LATTICE_EDGE: int = 1024
DECK_MAX_MAP_EDGE: int = 4096
DECK_MAX_VOXELS: int = 134217728
LIGHT_MAX_RESOLUTION: int = 256
LIGHT_MAX_STEPS_PER_RAY: float = 1048576.0
LSYSTEM_MAX_LENGTH: int = 1073741824
MAX_COARSEN: float = 8.0
MAX_OCTAVES: int = 8
ORDER_PHASE_SIZE: int = 64
PARTICLES_MAX: int = 4194304
SEEDBOX_MAX_BILLBOARDS: int = 1048576
SEEDBOX_MAX_BOXES: int = 65536
SEEDBOX_MAX_SEEDS: int = 1024
WEATHER_MAX_INSTANCES: int = 1048576
