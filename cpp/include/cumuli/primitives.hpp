// Cloud primitives: ellipsoids (spheres are the equal-radii, identity-rotation case) and boxes.
//
// Intersection is done in the primitive's unit-sphere frame, q = Rᵀ(p − c) / radii, where the
// ray keeps its parameter t, so t values from different primitives can be compared and sorted.
#pragma once

#include <cstddef>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

namespace cumuli {

struct Ellipsoid {
  glm::vec3 centre{0.0f};
  glm::vec3 radii{1.0f};
  glm::mat3 rotation{1.0f};  // columns are the ellipsoid's axes in world space

  // World point → unit-sphere frame.
  glm::vec3 to_local(glm::vec3 p) const {
    return (glm::transpose(rotation) * (p - centre)) / radii;
  }
  bool unrotated() const { return rotation == glm::mat3(1.0f); }
  // to_local with the rotation skipped when `identity` (= unrotated(), known to the caller):
  // the identity's products and sums give the vector itself, changing at most the sign of a
  // zero, so |q|² (the square takes the sign off) is to_local's bit for bit.
  glm::vec3 to_local_given(glm::vec3 p, bool identity) const {
    const glm::vec3 v = p - centre;
    return (identity ? v : glm::transpose(rotation) * v) / radii;
  }
  // |q|: 0 at the centre, 1 on the surface. Inline: the light step and the marchers call it
  // once per sample and primitive.
  float normalised_distance(glm::vec3 p) const { return glm::length(to_local(p)); }
  // World-space axis-aligned bounds.
  void bounds(glm::vec3& lo, glm::vec3& hi) const;
};

// q2[i] = min(q2[i], |q|²) of `count` points (x[i], y[i], z[i]) against e (`unrotated` =
// e.unrotated(), known to the caller): the same float operations as dot(l, l) with
// l = e.to_local_given(p, unrotated), bit for bit, in a loop that vectorises across the points.
// The light step's bulk density (extinction lattice, sun march) takes each primitive's smallest
// |q|² this way.
void min_q2(const Ellipsoid& e, bool unrotated, const float* x, const float* y, const float* z,
            std::size_t count, float* q2);

// A ray span [t_in, t_out] inside a primitive.
struct Interval {
  float t_in = 0.0f;
  float t_out = 0.0f;
};

// Ray o + t·d against an ellipsoid; false when missed. t_in may be negative (origin inside).
bool intersect(const Ellipsoid& e, glm::vec3 origin, glm::vec3 dir, Interval& out);

struct Box {
  glm::vec3 lo{0.0f};
  glm::vec3 hi{0.0f};

  bool contains(glm::vec3 p) const {
    return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z;
  }
};

// Slab test (Smits; Williams et al.): the ray's span inside the box, false when missed.
// inv_dir = 1 / dir component-wise (±inf for zero components is fine).
bool intersect(const Box& b, glm::vec3 origin, glm::vec3 inv_dir, Interval& out);

}  // namespace cumuli
