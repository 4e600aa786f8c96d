#include "cumuli/model/cloud.hpp"

#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

namespace cumuli {

Box CloudShape::bounds() const {
  Box b{glm::vec3(INFINITY), glm::vec3(-INFINITY)};
  for (const auto& e : primitives) {
    glm::vec3 lo, hi;
    e.bounds(lo, hi);
    b.lo = glm::min(b.lo, lo);
    b.hi = glm::max(b.hi, hi);
  }
  return b;
}

glm::vec3 CloudShape::centre() const {
  const Box b = bounds();
  return 0.5f * (b.lo + b.hi);
}

float CloudShape::mean_squared_radius() const {
  if (primitives.empty()) return 0.0f;
  double s = 0.0;
  for (const auto& e : primitives) s += glm::dot(e.radii, e.radii) / 3.0;
  return static_cast<float>(s / primitives.size());
}

void CloudShape::validate() const {
  if (primitives.empty()) throw std::invalid_argument("cloud has no primitives");
  for (const auto& e : primitives) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(e.centre[k])) throw std::invalid_argument("cloud centres must be finite");
      if (!std::isfinite(e.radii[k]) || e.radii[k] <= 0.0f)
        throw std::invalid_argument("cloud radii must be finite and positive");
      for (int j = 0; j < 3; ++j)
        if (!std::isfinite(e.rotation[j][k]))
          throw std::invalid_argument("cloud rotations must be finite");
    }
  }
  // Rotation columns are the axes: they must be orthonormal, or to_local (which uses Rᵀ as the
  // inverse) and bounds() (which uses the columns) describe different shapes.
  for (const auto& e : primitives) {
    const glm::mat3 rtr = glm::transpose(e.rotation) * e.rotation;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        if (!(std::fabs(rtr[a][b] - (a == b ? 1.0f : 0.0f)) <= 1e-3f))
          throw std::invalid_argument("cloud rotations must be orthonormal (columns = unit axes)");
  }
  if (!(density.kappa >= 0.0f && density.kappa <= 1.0f))
    throw std::invalid_argument("kappa must be in [0, 1]");
  if (!(density.phi > 0.0f) || !std::isfinite(density.phi))
    throw std::invalid_argument("phi must be finite and positive");
}

DensitySample spheroid_density(const CloudShape& cloud, int j, glm::vec3 p,
                               const DensitySource& src) {
  const float q = cloud.primitives[static_cast<std::size_t>(j)].normalised_distance(p);
  if (q > 1.0f) return {};
  const float rho = src(p);
  const float kappa = cloud.density.kappa;
  const float gamma = std::exp(-q / ((1.0f - kappa) + 2.0f * kappa * rho));
  if (!(rho < gamma)) return {0.0f, gamma};
  return {rho, gamma};
}

DensitySample metaball_density(const CloudShape& cloud, glm::vec3 p, const DensitySource& src) {
  float field = 0.0f;
  for (const auto& e : cloud.primitives) {
    const glm::vec3 q = e.to_local(p);
    const float d2 = glm::dot(q, q);
    if (d2 <= 1e-12f) return {src(p) * cloud.density.mean_r2 * cloud.density.phi, 1.0f};
    field += 1.0f / d2;
    if (field >= 1.0f) break;
  }
  if (field < 1.0f) return {};
  return {src(p) * cloud.density.mean_r2 * cloud.density.phi, 1.0f};
}

DensitySample cloud_density(const CloudShape& cloud, int j, glm::vec3 p, const DensitySource& src) {
  return cloud.density.model == DensityModel::Metaball ? metaball_density(cloud, p, src)
                                                       : spheroid_density(cloud, j, p, src);
}

}  // namespace cumuli
