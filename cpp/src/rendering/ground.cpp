#include "cumuli/rendering/ground.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cumuli {

void GroundParams::validate() const {
  if (!enabled) return;
  if (!std::isfinite(height)) throw std::invalid_argument("ground height must be finite");
  for (int k = 0; k < 3; ++k) {
    if (!(albedo[k] >= 0.0f && albedo[k] <= 1.0f))
      throw std::invalid_argument("ground albedo must be in [0, 1]");
    if (!(sky_irradiance[k] >= 0.0f) || !std::isfinite(sky_irradiance[k]))
      throw std::invalid_argument("ground sky irradiance must be finite and >= 0");
  }
  if (!shadow.empty()) {
    if (nx < 1 || nz < 1 || shadow.size() != static_cast<std::size_t>(nx) * nz)
      throw std::invalid_argument("shadow map size does not match its resolution");
    if (!(x1 > x0) || !(z1 > z0) || !std::isfinite(x0) || !std::isfinite(x1) ||
        !std::isfinite(z0) || !std::isfinite(z1))
      throw std::invalid_argument("shadow map extent must be finite and non-empty");
  }
}

float GroundParams::shadow_at(float x, float z) const {
  if (shadow.empty() || x < x0 || x > x1 || z < z0 || z > z1) return 1.0f;
  const float u = (x - x0) / (x1 - x0) * static_cast<float>(nx) - 0.5f;
  const float v = (z - z0) / (z1 - z0) * static_cast<float>(nz) - 0.5f;
  const float fu = std::floor(u), fv = std::floor(v);
  const float wu = u - fu, wv = v - fv;
  const int i0 = std::clamp(static_cast<int>(fu), 0, nx - 1),
            i1 = std::clamp(static_cast<int>(fu) + 1, 0, nx - 1);
  const int j0 = std::clamp(static_cast<int>(fv), 0, nz - 1),
            j1 = std::clamp(static_cast<int>(fv) + 1, 0, nz - 1);
  auto at = [&](int i, int j) { return shadow[static_cast<std::size_t>(j) * nx + i]; };
  const float a = at(i0, j0) + wu * (at(i1, j0) - at(i0, j0));
  const float b = at(i0, j1) + wu * (at(i1, j1) - at(i0, j1));
  return a + wv * (b - a);
}

glm::vec3 background(const SkyParams& sky, const SunParams& sun, const GroundParams& ground,
                     glm::vec3 origin, glm::vec3 dir) {
  if (ground.enabled && origin.y > ground.height && dir.y < 0.0f) {
    const float t = (ground.height - origin.y) / dir.y;
    const glm::vec3 x = origin + t * dir;
    const float lit = std::max(sun.direction.y, 0.0f) * ground.shadow_at(x.x, x.z);
    constexpr float kInvPi = 0.3183098861837907f;
    return ground.albedo * kInvPi * (sun.radiance * lit + ground.sky_irradiance);
  }
  return sky_radiance(sky, sun, dir);
}

}  // namespace cumuli
