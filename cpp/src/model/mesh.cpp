#include "cumuli/model/mesh.hpp"

#include <atomic>
#include <cmath>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include "cumuli/parallel.hpp"

namespace cumuli {

namespace {

glm::dmat3 skew(glm::dvec3 x) {
  // Eq. (30). glm is column-major: m[col][row].
  glm::dmat3 a(0.0);
  a[1][0] = -x.z;
  a[2][0] = x.y;
  a[0][1] = x.z;
  a[2][1] = -x.x;
  a[0][2] = -x.y;
  a[1][2] = x.x;
  return a;
}

glm::dmat3 rotation_onto_d(glm::dvec3 from, glm::dvec3 to) {
  const double lf = glm::length(from), lt = glm::length(to);
  if (!(lf > 0.0) || !(lt > 1e-30)) return glm::dmat3(1.0);
  const glm::dvec3 f = from / lf, t = to / lt;
  const glm::dvec3 c = glm::cross(f, t);
  const double s = glm::length(c);
  const double d = glm::clamp(glm::dot(f, t), -1.0, 1.0);
  if (s < 1e-12) {
    if (d > 0.0) return glm::dmat3(1.0);
    // Antiparallel: half turn about any axis perpendicular to `from` (R = 2aaᵀ − I).
    glm::dvec3 a = std::fabs(f.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    a = glm::normalize(a - f * glm::dot(a, f));
    return 2.0 * glm::outerProduct(a, a) - glm::dmat3(1.0);
  }
  const glm::dvec3 x = c / s;             // eq. (27)
  const double theta = std::atan2(s, d);  // eq. (28), stabler than acos near 0 and π
  const glm::dmat3 a = skew(x);
  return glm::dmat3(1.0) + std::sin(theta) * a + (1.0 - std::cos(theta)) * (a * a);  // eq. (29)
}

}  // namespace

glm::mat3 rotation_onto(glm::vec3 from, glm::vec3 to) {
  return glm::mat3(rotation_onto_d(glm::dvec3(from), glm::dvec3(to)));
}

MeshEllipsoidsResult ellipsoids_from_mesh(const float* vertices, std::size_t vertex_count,
                                          const std::int64_t* faces, std::size_t face_count,
                                          float scale, bool rotate, float min_radius, int threads) {
  if (vertex_count == 0) throw std::invalid_argument("vertices must not be empty");
  if (face_count == 0) throw std::invalid_argument("faces must not be empty");
  if (!(std::isfinite(scale) && scale > 0.0f && scale <= 2.0f))
    throw std::invalid_argument("scale must be in (0, 2], got " + std::to_string(scale));
  if (!(std::isfinite(min_radius) && min_radius > 0.0f))
    throw std::invalid_argument("min_radius must be finite and positive");
  for (std::size_t i = 0; i < 3 * vertex_count; ++i)
    if (!std::isfinite(vertices[i])) throw std::invalid_argument("vertices must be finite");
  for (std::size_t i = 0; i < 3 * face_count; ++i)
    if (faces[i] < 0 || static_cast<std::uint64_t>(faces[i]) >= vertex_count)
      throw std::invalid_argument("faces: index " + std::to_string(faces[i]) + " at face " +
                                  std::to_string(i / 3) + " is outside [0, " +
                                  std::to_string(vertex_count) + ")");

  MeshEllipsoidsResult out;
  out.ellipsoids.resize(face_count);
  std::vector<unsigned char> floored(face_count, 0);
  // Threads cost more to start than a few thousand faces take (~0.2 µs each): small meshes run
  // on the calling thread. The result is the same either way.
  constexpr std::size_t kFacesPerThread = 8192;
  const int use = face_count < 2 * kFacesPerThread ? 1 : threads;
  parallel_for(face_count, use, [&](std::size_t f) {
    glm::dvec3 p[3];
    for (int k = 0; k < 3; ++k) {
      const std::size_t v = static_cast<std::size_t>(faces[3 * f + k]);
      p[k] = glm::dvec3(vertices[3 * v], vertices[3 * v + 1], vertices[3 * v + 2]);
    }
    const glm::dvec3 b = (p[0] + p[1] + p[2]) / 3.0;  // eq. (22)
    glm::dvec3 radii;
    glm::dvec3 dir[3];
    for (int k = 0; k < 3; ++k) {
      const glm::dvec3 scaled = (p[k] - b) * double(scale) + b;  // eq. (23)
      dir[k] = scaled - b;
      radii[k] = glm::length(dir[k]);  // eq. (24)
    }
    int longest = 0;
    for (int k = 1; k < 3; ++k)
      if (radii[k] > radii[longest]) longest = k;
    Ellipsoid& e = out.ellipsoids[f];
    e.centre = glm::vec3(b);
    for (int k = 0; k < 3; ++k) {
      if (!(radii[k] >= min_radius)) {
        radii[k] = min_radius;
        floored[f] = 1;
      }
    }
    e.radii = glm::vec3(radii);
    if (rotate) {
      glm::dvec3 axis(0.0);
      axis[longest] = 1.0;  // eq. (26): dirEllip is the local axis of the longest radius
      e.rotation = glm::mat3(rotation_onto_d(axis, dir[longest]));  // eqs. (25), (27)–(30)
    } else {
      e.rotation = glm::mat3(1.0f);
    }
  });
  for (unsigned char x : floored) out.floored_faces += x;
  return out;
}

}  // namespace cumuli
