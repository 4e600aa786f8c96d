#include "cumuli/rendering/solids.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>

#include "cumuli/parallel.hpp"
#include "cumuli/rendering/compositor.hpp"

namespace cumuli {

namespace {

bool finite3(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// (a.x·b.x + a.y·b.y) + a.z·b.z, the order the shaders use.
float dot3(glm::vec3 a, glm::vec3 b) { return (a.x * b.x + a.y * b.y) + a.z * b.z; }

}  // namespace

void SolidSphere::validate() const {
  if (!finite3(centre)) throw std::invalid_argument("solid centre must be finite");
  if (!std::isfinite(radius) || !(radius > 0.0f))
    throw std::invalid_argument("solid radius must be > 0");
  if (!finite3(colour) || !finite3(ambient) || colour.x < 0.0f || colour.y < 0.0f ||
      colour.z < 0.0f || ambient.x < 0.0f || ambient.y < 0.0f || ambient.z < 0.0f)
    throw std::invalid_argument("solid colour and ambient must be finite and >= 0");
}

float ray_sphere(glm::vec3 origin, glm::vec3 dir, glm::vec3 centre, float radius) {
  const glm::vec3 oc = origin - centre;
  const float b = dot3(oc, dir);
  const float k = dot3(oc, oc) - radius * radius;
  const float disc = b * b - k;
  if (!(disc >= 0.0f)) return kNoSolid;
  const float root = std::sqrt(disc);
  if (-b + root < 0.0f) return kNoSolid;
  return std::max(-b - root, 0.0f);
}

float nearest_solid(const std::vector<SolidSphere>& solids, glm::vec3 origin, glm::vec3 dir,
                    int* which) {
  float best = kNoSolid;
  int idx = -1;
  for (std::size_t s = 0; s < solids.size(); ++s) {
    const float t = ray_sphere(origin, dir, solids[s].centre, solids[s].radius);
    if (t < best) {
      best = t;
      idx = static_cast<int>(s);
    }
  }
  if (which != nullptr) *which = idx;
  return best;
}

glm::vec3 shade_solid(const SolidSphere& solid, glm::vec3 point, const SunParams& sun) {
  const glm::vec3 n = (point - solid.centre) * (1.0f / solid.radius);
  const float lambert = std::max(dot3(n, sun.direction), 0.0f);
  return solid.colour * (solid.ambient + lambert * sun.radiance);
}

void draw_solids(const std::vector<SolidSphere>& solids, const CameraParams& camera, int width,
                 int height, const SunParams& sun, float* out, int threads) {
  if (width < 1 || height < 1) throw std::invalid_argument("width and height must be >= 1");
  if (static_cast<int>(solids.size()) > kMaxSolids)
    throw std::invalid_argument("at most 16 solids");
  for (const auto& s : solids) s.validate();
  camera.validate();
  const CameraRays rays(camera, width, height);
  parallel_chunks(static_cast<std::size_t>(height), threads, [&](std::size_t r0, std::size_t r1) {
    for (std::size_t r = r0; r < r1; ++r) {
      for (int c = 0; c < width; ++c) {
        const glm::vec3 dir = rays.direction(static_cast<int>(r), c);
        int which = -1;
        const float t = nearest_solid(solids, rays.origin, dir, &which);
        float* o = out + (r * static_cast<std::size_t>(width) + static_cast<std::size_t>(c)) * 4;
        if (which < 0) {
          o[0] = o[1] = o[2] = 0.0f;
          o[3] = kNoSolid;
          continue;
        }
        const glm::vec3 rgb =
            shade_solid(solids[static_cast<std::size_t>(which)], rays.origin + t * dir, sun);
        o[0] = rgb.x;
        o[1] = rgb.y;
        o[2] = rgb.z;
        o[3] = t * dot3(dir, rays.forward);
      }
    }
  });
}

void composite_split(const std::vector<const float*>& layers,
                     const std::vector<const float*>& solids, int width, int height, float* out,
                     int threads) {
  if (layers.size() != solids.size() + 1)
    throw std::invalid_argument("a split needs one layer more than solids");
  if (width < 1 || height < 1) throw std::invalid_argument("width and height must be >= 1");
  const std::size_t npix = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  parallel_chunks(npix, threads, [&](std::size_t p0, std::size_t p1) {
    for (std::size_t p = p0; p < p1; ++p) {
      const float* l0 = layers[0] + p * 4;
      float rgba[4] = {l0[0], l0[1], l0[2], l0[3]};
      float depth = kNoSolid;
      for (std::size_t j = 0; j < solids.size(); ++j) {
        const float* s = solids[j] + p * 4;
        if (s[3] < depth) {
          depth = s[3];
          rgba[0] = s[0];
          rgba[1] = s[1];
          rgba[2] = s[2];
          rgba[3] = 1.0f;
        }
        const float* l = layers[j + 1] + p * 4;
        const float keep = 1.0f - l[3];
        for (int c = 0; c < 4; ++c) rgba[c] = l[c] + keep * rgba[c];
      }
      std::copy(rgba, rgba + 4, out + p * 4);
    }
  });
}

}  // namespace cumuli
