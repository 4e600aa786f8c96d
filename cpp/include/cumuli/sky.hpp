// The render pass's sky and sun (RENDER_CONTRACT "Sky"): a gradient sky and the sun's visible
// disc, shared by every CPU renderer. GLSL twins: shaders/common/sky.glsl and
// shaders/common/sun_disc.glsl; numpy twin: cumuli.Sky.colour. They follow the contract's
// formulas operation by operation (same order, float32 throughout).
#pragma once

#include <glm/vec3.hpp>

namespace cumuli {

struct SkyParams {
  glm::vec3 zenith{0.25f, 0.45f, 0.85f};
  glm::vec3 horizon{0.75f, 0.85f, 0.95f};
  glm::vec3 ground{0.35f, 0.33f, 0.3f};
  float exponent = 0.5f;
  float sun_disc_radius = 0.5f;     // degrees; ≤ 0 draws no disc
  float sun_disc_intensity = 0.0f;  // multiplies the sun radiance inside the disc
};

struct SunParams {
  glm::vec3 direction{0.0f, 1.0f, 0.0f};  // unit, towards the sun
  glm::vec3 radiance{1.0f};               // colour · intensity
};

// The sun disc's radiance seen along unit direction d (the one formula of the disc; GLSL twin:
// sun_disc in shaders/common/sun_disc.glsl), rad = sun_disc_radius in radians:
// smoothstep(cos(1.5·rad), cos(rad), dot(d, sun)) · sun_disc_intensity · sun_radiance;
// zero when the radius is ≤ 0 or the intensity is 0.
glm::vec3 sun_disc(const SkyParams& sky, const SunParams& sun, glm::vec3 d);

// Sky radiance seen along unit direction d: the gradient
// base = d.y ≥ 0 ? horizon + (zenith − horizon)·pow(d.y, exponent)
//                : horizon + (ground − horizon)·min(1, −8·d.y),
// plus sun_disc(sky, sun, d).
glm::vec3 sky_radiance(const SkyParams& sky, const SunParams& sun, glm::vec3 d);

}  // namespace cumuli
