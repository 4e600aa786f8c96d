#include "cumuli/primitives.hpp"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

namespace cumuli {

void Ellipsoid::bounds(glm::vec3& lo, glm::vec3& hi) const {
  // Half-extent along world axis k: sqrt(Σ_j (R_kj · r_j)²).
  glm::vec3 half;
  for (int k = 0; k < 3; ++k) {
    float s = 0.0f;
    for (int j = 0; j < 3; ++j) {
      const float v = rotation[j][k] * radii[j];
      s += v * v;
    }
    half[k] = std::sqrt(s);
  }
  lo = centre - half;
  hi = centre + half;
}

bool intersect(const Ellipsoid& e, glm::vec3 origin, glm::vec3 dir, Interval& out) {
  const glm::mat3 rt = glm::transpose(e.rotation);
  const glm::vec3 o = (rt * (origin - e.centre)) / e.radii;
  const glm::vec3 d = (rt * dir) / e.radii;
  const float a = glm::dot(d, d);
  if (!(a > 0.0f)) return false;
  const float b = glm::dot(o, d);
  const float c = glm::dot(o, o) - 1.0f;
  const float disc = b * b - a * c;
  if (disc < 0.0f) return false;
  const float s = std::sqrt(disc);
  out.t_in = (-b - s) / a;
  out.t_out = (-b + s) / a;
  return true;
}

bool intersect(const Box& box, glm::vec3 origin, glm::vec3 inv_dir, Interval& out) {
  float t0 = -INFINITY, t1 = INFINITY;
  for (int k = 0; k < 3; ++k) {
    float ta = (box.lo[k] - origin[k]) * inv_dir[k];
    float tb = (box.hi[k] - origin[k]) * inv_dir[k];
    if (std::isnan(ta) || std::isnan(tb)) {  // zero direction and origin on a slab plane
      if (origin[k] < box.lo[k] || origin[k] > box.hi[k]) return false;
      continue;
    }
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t0 > t1) return false;
  out.t_in = t0;
  out.t_out = t1;
  return true;
}

}  // namespace cumuli
