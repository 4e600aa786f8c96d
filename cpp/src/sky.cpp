#include "cumuli/sky.hpp"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

#include "cumuli/phase.hpp"

namespace cumuli {

glm::vec3 sun_disc(const SkyParams& sky, const SunParams& sun, glm::vec3 d) {
  if (!(sky.sun_disc_radius > 0.0f) || sky.sun_disc_intensity == 0.0f) return glm::vec3(0.0f);
  constexpr float kDegToRad = 0.017453292519943295f;
  const float rad = sky.sun_disc_radius * kDegToRad;
  const float w = smoothstep(std::cos(1.5f * rad), std::cos(rad), glm::dot(d, sun.direction));
  return w * sky.sun_disc_intensity * sun.radiance;
}

glm::vec3 sky_radiance(const SkyParams& sky, const SunParams& sun, glm::vec3 d) {
  glm::vec3 base;
  if (d.y >= 0.0f) {
    base = sky.horizon + (sky.zenith - sky.horizon) * std::pow(d.y, sky.exponent);
  } else {
    base = sky.horizon + (sky.ground - sky.horizon) * std::min(1.0f, -8.0f * d.y);
  }
  if (sky.sun_disc_radius > 0.0f && sky.sun_disc_intensity != 0.0f) base += sun_disc(sky, sun, d);
  return base;
}

}  // namespace cumuli
