// The ground (RENDER_CONTRACT "Ground"): an optional Lambertian plane y = height under the
// clouds, the background of every ray that meets it (the sky's elsewhere). Shared by the 2018
// marcher, the compositor and their GLSL twin shaders/common/ground.glsl.
//
// A ray o + t·d meets the ground when o.y > height and d.y < 0, at t = (height − o.y)/d.y. There
//   L = albedo/π · (E_sun·max(sun.y, 0)·T_shadow(x, z) + E_sky)
// with E_sun the sun's irradiance (colour·intensity), E_sky the sky's irradiance on the plane
// (∫ L_sky cosθ over the upper hemisphere, computed by the caller) and T_shadow the sunlight
// transmittance through every cloud: the shadow map, bilinear over its extent with texel
// centres and clamped at the edges, 1 outside the extent.
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/phase.hpp"

namespace cumuli {

struct GroundParams {
  bool enabled = false;
  float height = 0.0f;
  glm::vec3 albedo{0.3f};
  glm::vec3 sky_irradiance{0.0f};
  // Shadow map [z][x] (nz rows of nx texels) over x in [x0, x1], z in [z0, z1]; empty: no shadow.
  std::vector<float> shadow;
  int nx = 0, nz = 0;
  float x0 = 0.0f, z0 = 0.0f, x1 = 1.0f, z1 = 1.0f;

  void validate() const;  // throws std::invalid_argument
  float shadow_at(float x, float z) const;
};

// The ground's radiance where the ray meets it, else the sky's (phase.hpp sky_radiance).
glm::vec3 background(const SkyParams& sky, const SunParams& sun, const GroundParams& ground,
                     glm::vec3 origin, glm::vec3 dir);

}  // namespace cumuli
