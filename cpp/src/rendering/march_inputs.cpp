// The marcher's inputs (rendering/marcher.hpp): the paper mode's light grid lookup, the camera's
// rays and the validation of settings and scene. The marcher itself is rendering/marcher.cpp.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "cumuli/rendering/marcher.hpp"

namespace cumuli {

// ---------------------------------------------------------------------------------------------
// Light grid

float LightGrid::sample(glm::vec3 p) const {
  const glm::vec3 res(static_cast<float>(nx), static_cast<float>(ny), static_cast<float>(nz));
  // Normalised texture coordinate, then texel space shifted to texel centres (GL convention).
  const glm::vec3 s = (p - box.lo) / (box.hi - box.lo);
  const glm::vec3 u = s * res - 0.5f;
  const glm::vec3 f(std::floor(u.x), std::floor(u.y), std::floor(u.z));
  const glm::vec3 w = u - f;
  // Clamp-to-edge: both neighbours clamped into the grid (floats first, so huge u cannot overflow).
  auto idx = [](float v, int n) {
    return static_cast<int>(std::clamp(v, 0.0f, static_cast<float>(n - 1)));
  };
  const int x0 = idx(f.x, nx), x1 = idx(f.x + 1.0f, nx);
  const int y0 = idx(f.y, ny), y1 = idx(f.y + 1.0f, ny);
  const int z0 = idx(f.z, nz), z1 = idx(f.z + 1.0f, nz);
  auto at = [&](int x, int y, int z) {
    return values[(static_cast<std::size_t>(z) * ny + y) * nx + x];
  };
  // Blend along x, then y, then z (as noise.cpp and shaders/common/noise.glsl do).
  const float c00 = at(x0, y0, z0) + w.x * (at(x1, y0, z0) - at(x0, y0, z0));
  const float c10 = at(x0, y1, z0) + w.x * (at(x1, y1, z0) - at(x0, y1, z0));
  const float c01 = at(x0, y0, z1) + w.x * (at(x1, y0, z1) - at(x0, y0, z1));
  const float c11 = at(x0, y1, z1) + w.x * (at(x1, y1, z1) - at(x0, y1, z1));
  const float c0 = c00 + w.y * (c10 - c00);
  const float c1 = c01 + w.y * (c11 - c01);
  return c0 + w.z * (c1 - c0);
}

void LightGrid::validate() const {
  if (nx < 1 || ny < 1 || nz < 1) throw std::invalid_argument("light grid must not be empty");
  if (values.size() != static_cast<std::size_t>(nx) * ny * nz)
    throw std::invalid_argument("light grid size does not match its resolution");
  for (float v : values)
    if (!std::isfinite(v))
      throw std::invalid_argument("light grid contains NaN or infinite values");
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(box.lo[k]) || !std::isfinite(box.hi[k]))
      throw std::invalid_argument("light_box must be finite");
    if (!(box.hi[k] > box.lo[k]))
      throw std::invalid_argument("light_box hi must be greater than lo on every axis");
  }
}

// ---------------------------------------------------------------------------------------------
// Camera

void CameraParams::validate() const {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(position[k]) || !std::isfinite(target[k]) || !std::isfinite(up[k]))
      throw std::invalid_argument("camera position, target and up must be finite");
  if (!(fov > 0.0f && fov < 180.0f))
    throw std::invalid_argument("camera fov must be in (0, 180) degrees");
  const glm::vec3 f = target - position;
  if (!(glm::dot(f, f) > 0.0f)) throw std::invalid_argument("camera target equals its position");
  const glm::vec3 r = glm::cross(glm::normalize(f), up);
  if (!(glm::dot(r, r) > 1e-12f))
    throw std::invalid_argument("camera up must not be parallel to the view direction");
}

void Viewport::validate() const {
  if (width < 1 || height < 1 || width > kMaxEdge || height > kMaxEdge)
    throw std::invalid_argument("width and height must be in [1, " + std::to_string(kMaxEdge) +
                                "], got " + std::to_string(width) + "x" + std::to_string(height));
  if (static_cast<long long>(width) * height > kMaxPixels)
    throw std::invalid_argument("image has more than " + std::to_string(kMaxPixels) + " pixels");
  camera.validate();
}

CameraRays::CameraRays(const CameraParams& camera, int w, int h) : width(w), height(h) {
  origin = camera.position;
  forward = glm::normalize(camera.target - camera.position);
  right = glm::normalize(glm::cross(forward, camera.up));
  up = glm::cross(right, forward);
  constexpr float kDegToRad = 0.017453292519943295f;
  tan_half = std::tan(camera.fov * kDegToRad / 2.0f);
  aspect = static_cast<float>(w) / static_cast<float>(h);
}

glm::vec3 CameraRays::direction(int row, int col) const {
  const float x = (2.0f * (static_cast<float>(col) + 0.5f) / static_cast<float>(width) - 1.0f) *
                  tan_half * aspect;
  const float y =
      (1.0f - 2.0f * (static_cast<float>(row) + 0.5f) / static_cast<float>(height)) * tan_half;
  return glm::normalize(forward + x * right + y * up);
}

ScreenTiles::ScreenTiles(const CameraRays& rays) {
  while (static_cast<long>(count(rays.width)) * count(rays.height) > kMaxTiles) size_ *= 2;
  cols_ = count(rays.width);
  const int rows = count(rays.height);
  // A direction through a tile is forward + x·right + y·up normalised, (x, y) in the rectangle
  // of its corner pixels' centres: every such direction lies within the largest angle from the
  // corners' mean direction to a corner (the directions within an angle < 90° of an axis meet
  // the image plane in a convex ellipse). The float rounding of the directions is ~10⁻⁷ rad,
  // well inside the bins' pad.
  auto corner = [&](int row, int col) { return glm::dvec3(rays.direction(row, col)); };
  cones_.reserve(static_cast<std::size_t>(cols_) * static_cast<std::size_t>(rows));
  for (int tr = 0; tr < rows; ++tr) {
    const int r0 = tr * size_, r1 = std::min(r0 + size_, rays.height) - 1;
    for (int tc = 0; tc < cols_; ++tc) {
      const int c0 = tc * size_, c1 = std::min(c0 + size_, rays.width) - 1;
      const glm::dvec3 k[4] = {corner(r0, c0), corner(r0, c1), corner(r1, c0), corner(r1, c1)};
      DirectionCone cone;
      cone.axis = glm::normalize(k[0] + k[1] + k[2] + k[3]);
      for (const glm::dvec3& d : k)
        cone.half_angle =
            std::max(cone.half_angle, std::acos(std::min(glm::dot(cone.axis, d), 1.0)));
      cones_.push_back(cone);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Settings

namespace {
void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument(what);
}
}  // namespace

void MarchSettings::validate() const {
  require(std::isfinite(absorption) && absorption >= 0.0f, "absorption must be finite and >= 0");
  require(std::isfinite(lod_a) && lod_a > 0.0f, "lod_a must be finite and > 0");
  require(std::isfinite(lod_delta) && lod_delta >= 0.0f, "lod_delta must be finite and >= 0");
  require(std::isfinite(ref_step) && ref_step > 0.0f, "ref_step must be finite and > 0");
  require(std::isfinite(step_min) && step_min > 0.0f, "step_min must be finite and > 0");
  require(std::isfinite(step_max) && step_max >= step_min,
          "step_max must be finite and >= step_min");
  require(std::isfinite(fixed_step) && fixed_step >= 0.0f, "fixed_step must be finite and >= 0");
  require(std::isfinite(hg_g) && hg_g > -1.0f && hg_g < 1.0f, "hg_g must be in (-1, 1)");
  require(max_steps >= 1 && max_steps <= kMaxStepsLimit,
          "max_steps must be in [1, " + std::to_string(kMaxStepsLimit) + "]");
  require(max_candidates >= 1 && max_candidates <= kMaxCandidatesLimit,
          "max_candidates must be in [1, " + std::to_string(kMaxCandidatesLimit) + "]");
  require(std::isfinite(density_constant), "density_constant must be finite");
  require(min_transmittance >= 0.0f && min_transmittance < 1.0f,
          "min_transmittance must be in [0, 1)");
  fbm.validate();
  if (physical) phys.validate();
}

float MarchSettings::step_for(glm::vec3 eye, glm::vec3 centre) const {
  if (fixed_step > 0.0f) return fixed_step;
  const float d = glm::length(eye - centre);
  return std::clamp(lod_a * std::exp(-lod_delta * d), step_min, step_max);
}

void MarchScene::validate(const MarchSettings& settings) const {
  if (settings.density_constant < 0.0f && noise == nullptr)
    throw std::invalid_argument("noise is required unless density_constant >= 0");
  for (const auto& c : clouds) {
    c.shape.validate();
    if (settings.physical) {
      c.physical.validate();
    } else {
      c.light.validate();
    }
  }
  require(solids.size() <= static_cast<std::size_t>(kMaxSolids), "at most 16 solids");
  for (const auto& s : solids) s.validate();
  ground.validate();
  for (int k = 0; k < 3; ++k) {
    require(std::isfinite(sun.direction[k]) && std::isfinite(sun.radiance[k]),
            "sun direction and radiance must be finite");
    require(std::isfinite(sky.zenith[k]) && std::isfinite(sky.horizon[k]) &&
                std::isfinite(sky.ground[k]),
            "sky colours must be finite");
  }
  require(std::abs(glm::length(sun.direction) - 1.0f) < 1e-3f, "sun direction must be unit length");
  require(std::isfinite(sky.exponent) && sky.exponent > 0.0f, "sky exponent must be > 0");
  require(std::isfinite(sky.sun_disc_radius) && sky.sun_disc_radius >= 0.0f &&
              sky.sun_disc_radius < 60.0f,
          "sun_disc_radius must be in [0, 60) degrees");
  require(std::isfinite(sky.sun_disc_intensity) && sky.sun_disc_intensity >= 0.0f,
          "sun_disc_intensity must be finite and >= 0");
}

}  // namespace cumuli
