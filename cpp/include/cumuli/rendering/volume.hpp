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
};

constexpr float kVolumeMinTransmittance = 1e-4f;

// (height, width, 4) float32, row 0 at the top.
std::vector<float> render_volume_cpu(const float* density, const float* light, const VolumeGrid& g,
                                     const VolumeCameraRays& cam, const VolumeRenderParams& p,
                                     int threads);

}  // namespace cumuli
