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

// Ellipsoid::to_local and glm::dot written out in glm's order of operations.
void min_q2(const Ellipsoid& e, bool unrotated, const float* x, const float* y, const float* z,
            std::size_t count, float* q2) {
  const glm::mat3& r = e.rotation;
  const glm::vec3 c = e.centre, rad = e.radii;
  if (unrotated) {
    // Ellipsoid::to_local_given's shortcut, written out per point: the same |q|² bit for bit.
    for (std::size_t i = 0; i < count; ++i) {
      const float lx = (x[i] - c.x) / rad.x, ly = (y[i] - c.y) / rad.y, lz = (z[i] - c.z) / rad.z;
      const float d = lx * lx + ly * ly + lz * lz;
      q2[i] = std::min(q2[i], d);
    }
    return;
  }
  for (std::size_t i = 0; i < count; ++i) {
    const float vx = x[i] - c.x, vy = y[i] - c.y, vz = z[i] - c.z;
    // (Rᵀ·v)_a = R[a][0]·v.x + R[a][1]·v.y + R[a][2]·v.z, left to right, then ÷ radii_a.
    const float lx = (r[0][0] * vx + r[0][1] * vy + r[0][2] * vz) / rad.x;
    const float ly = (r[1][0] * vx + r[1][1] * vy + r[1][2] * vz) / rad.y;
    const float lz = (r[2][0] * vx + r[2][1] * vy + r[2][2] * vz) / rad.z;
    const float d = lx * lx + ly * ly + lz * lz;
    q2[i] = std::min(q2[i], d);
  }
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
