// Emission–absorption ray marching through a density volume lit by a per-voxel light volume
// (Iwasaki et al. 2011's rendering of the database volumes): the CPU reference that
// shaders/volume/march.frag.glsl mirrors.
//
// Per pixel: the ray o + t·d (pinhole camera, vertical fov, row 0 on top, pixel centres) is
// clipped to the volume's box and marched in equal steps no longer than `step`. At a sample,
// ρ and the light (τ_sun, E_sky RGB) are trilinear (clamp to edge); σ = σ_t·ρ;
// S = albedo·(sun·τ_sun·HG(g, d·sun_dir) + E_sky/4π) (single scattering of sun and sky, eqs. 2–3,
// isotropic phase for the sky); colour += T·(1 − e^{−σh})·S; T *= e^{−σh}; stop when T < 1e-4.
// Finally rgb = colour + T·sky(d) with the render pass's sky (phase.hpp sky_radiance: gradient and
// sun disc), alpha = 1 − T. HG is phase.hpp's henyey_greenstein.
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/light/volume.hpp"
#include "cumuli/noise.hpp"
#include "cumuli/phase.hpp"
#include "cumuli/rendering/physical.hpp"
#include "cumuli/rendering/solids.hpp"

namespace cumuli {

struct VolumeCameraRays {
  glm::vec3 position{0.0f};
  glm::vec3 forward{0.0f, 0.0f, -1.0f}, right{1.0f, 0.0f, 0.0f}, up{0.0f, 1.0f, 0.0f};
  float tan_half_fov = 0.5f;  // tan(vertical fov / 2)
};

struct VolumeRenderParams {
  int width = 64, height = 48;
  SunParams sun;  // direction (unit, towards the sun) and radiance
  SkyParams sky;
  bool with_sky = true;  // false: output the premultiplied layer (colour, 1 − T)
  float sigma_t = 1.0f;
  float albedo = 1.0f;
  float g = 0.2f;     // Henyey–Greenstein asymmetry
  float step = 0.1f;  // world units
  // Opaque solids (rendering/solids.hpp): the ray is marched only up to the nearest one it meets
  // (the box span [t0, t_out] becomes [t0, min(t_out, t_s)], still in equal steps). Empty: no
  // clipping.
  std::vector<SolidSphere> solids;
  // The physical lighting mode (RENDER_CONTRACT "Physical lighting"): σ = sigma_t·ρ, samples at
  // (k + ξ)·h, physical.hpp's shading with `grids` (the light argument is then not read).
  bool physical = false;
  PhysicalParams phys;
  const PhysicalGrids* grids = nullptr;
  // Physical mode only, the sharp-volume reconstruction (the paper mode reads neither):
  // `cubic`: the density is the tricubic B-spline of the voxels (C² across cell faces, so no
  // cell edges show), else trilinear. `detail` > 0 erodes it with the fBm `noise` at
  // `detail_fbm` (Schneider's Nubis clouds, 2015/2017): with ρn = min(ρ·detail_inv_max, 1) and
  // e = detail·n(x), n the fBm over its largest value Σwⁱ, ρ' = max(ρn − e, 0)/(1 − e)/inv_max.
  // The remap only removes density and removes more of it where ρn is low: the edges are
  // carved, the core (ρn → 1) is kept.
  bool cubic = false;
  float detail = 0.0f;
  float detail_inv_max = 1.0f;
  FbmParams detail_fbm;
  const Noise* noise = nullptr;  // needed when detail > 0
};

// The tricubic B-spline of a [z][y][x] volume at p (clamp to edge, GL texel centres): its 64
// taps summed separably; the GLSL gets the same sum as eight trilinear lookups at shifted points
// (Sigg & Hadwiger, GPU Gems 2, ch. 20).
float sample_cubic_bspline(const float* vol, const VolumeGrid& g, glm::vec3 p);

// The eroded density of `rho` at p (the `detail` rule above); rho unchanged when detail is 0.
float erode_density(float rho, glm::vec3 p, const VolumeRenderParams& params);

constexpr float kVolumeMinTransmittance = 1e-4f;

// (height, width, 4) float32, row 0 at the top.
std::vector<float> render_volume_cpu(const float* density, const float* light, const VolumeGrid& g,
                                     const VolumeCameraRays& cam, const VolumeRenderParams& p,
                                     int threads);

}  // namespace cumuli
