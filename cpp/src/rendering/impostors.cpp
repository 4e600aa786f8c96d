#include "cumuli/rendering/impostors.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>

#include "cumuli/parallel.hpp"

namespace cumuli {

namespace {

bool finite3(glm::dvec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

constexpr double kPi = 3.14159265358979323846;

}  // namespace

ImpostorView tight_impostor_view(glm::dvec3 eye, glm::dvec3 centre, double radius,
                                 glm::dvec3 world_up) {
  if (!finite3(eye) || !finite3(centre) || !std::isfinite(radius) || !(radius > 0.0))
    throw std::invalid_argument("eye, centre must be finite and radius > 0");
  ImpostorView v;
  v.eye = eye;
  v.centre = centre;
  v.radius = radius;
  const glm::dvec3 to = centre - eye;
  v.distance = glm::length(to);
  if (!(v.distance > radius))
    throw std::invalid_argument("the eye is inside the bounding sphere: use a screen impostor");
  v.forward = to / v.distance;
  glm::dvec3 side = glm::cross(v.forward, world_up);
  if (glm::length(side) < 1e-6) side = glm::cross(v.forward, glm::dvec3(1.0, 0.0, 0.0));
  v.right = glm::normalize(side);
  v.up = glm::cross(v.right, v.forward);
  v.half_angle = std::asin(radius / v.distance);
  v.fov_degrees = 2.0 * v.half_angle * 180.0 / kPi;
  v.half_size = v.distance * radius / std::sqrt(v.distance * v.distance - radius * radius);
  v.near_point = eye + (v.distance - radius) * v.forward;
  v.far_point = eye + (v.distance + radius) * v.forward;
  return v;
}

double translation_error(glm::dvec3 near_point, glm::dvec3 far_point, glm::dvec3 eye) {
  const glm::dvec3 a = near_point - eye, b = far_point - eye;
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

bool impostor_backwards(glm::dvec3 near_point, glm::dvec3 far_point, glm::dvec3 eye) {
  return glm::length(near_point - eye) > glm::length(far_point - eye);
}

double focal_length_px(int height, double fov_degrees) {
  return 0.5 * static_cast<double>(height) / std::tan(0.5 * fov_degrees * kPi / 180.0);
}

double required_resolution(double focal_px, double radius, double distance, double res_scale) {
  return res_scale * focal_px * 2.0 * radius / distance;
}

int impostor_resolution(double res_req, int min_res, int max_res, bool pow2) {
  double r = std::max(1.0, res_req);
  if (pow2) {
    int p = 1;
    while (p < r && p < (1 << 30)) p <<= 1;
    r = p;
  } else {
    r = std::ceil(r);
  }
  return static_cast<int>(std::min<double>(max_res, std::max<double>(min_res, r)));
}

int impostor_resolution_skyworks(int width, int height, double radius, double distance,
                                 double near_radius, int min_res) {
  const int big = std::max(width, height);
  const double want = 2.0 * big * radius / std::max(distance, 1e-30);
  int p = 1;
  while (2.0 * p <= want && p < (1 << 30)) p <<= 1;
  p = std::min(p, std::max(1, big / 2));
  if (distance < 0.5 * radius + near_radius) {
    p /= 8;
  } else if (distance < radius + near_radius) {
    p /= 4;
  }
  return std::max(p, min_res);
}

double near_corner_radius(double near, double tan_half, double aspect) {
  return near * std::sqrt(1.0 + tan_half * tan_half * (1.0 + aspect * aspect));
}

double half_diagonal_fov(double tan_half, double aspect) {
  return std::atan(tan_half * std::sqrt(1.0 + aspect * aspect));
}

bool needs_screen_impostor(glm::dvec3 eye, glm::dvec3 centre, double radius, double tan_half,
                           double aspect, double near) {
  const double d = glm::length(centre - eye);
  if (d <= radius * (1.0 + 1e-6)) return true;
  if (d - radius < near_corner_radius(near, tan_half, aspect)) return true;
  return std::asin(radius / d) >= half_diagonal_fov(tan_half, aspect);
}

int screen_impostor_size(int size, int factor) { return (size + factor - 1) / factor; }

// ---------------------------------------------------------------------------------------------
// Display (§7.2)

namespace {

bool finite3f(glm::vec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// (a.x·b.x + a.y·b.y) + a.z·b.z, the shader's order.
float dot3(glm::vec3 a, glm::vec3 b) { return (a.x * b.x + a.y * b.y) + a.z * b.z; }

float lerp(float a, float b, float t) { return a + t * (b - a); }

}  // namespace

void ImpostorQuad::validate() const {
  if (rgba == nullptr || width < 1 || height < 1)
    throw std::invalid_argument("an impostor needs a non-empty (H, W, 4) image");
  if (!finite3f(centre) || !finite3f(forward) || !finite3f(right) || !finite3f(up))
    throw std::invalid_argument("impostor plane must be finite");
  if (!std::isfinite(half_w) || !std::isfinite(half_h) || !(half_w > 0.0f) || !(half_h > 0.0f))
    throw std::invalid_argument("impostor half sizes must be > 0");
}

PixelRect impostor_rect(const ImpostorQuad& q, const CameraRays& rays) {
  PixelRect full{0, rays.width - 1, 0, rays.height - 1};
  if (q.clamp) return full;
  const float w = static_cast<float>(rays.width), h = static_cast<float>(rays.height);
  float jmin = INFINITY, jmax = -INFINITY, imin = INFINITY, imax = -INFINITY;
  for (int k = 0; k < 4; ++k) {
    const float sx = (k == 1 || k == 2) ? 1.0f : -1.0f;
    const float sy = (k >= 2) ? 1.0f : -1.0f;
    const glm::vec3 corner = q.centre + (sx * q.half_w) * q.right + (sy * q.half_h) * q.up;
    const glm::vec3 v = corner - rays.origin;
    const float z = dot3(v, rays.forward);
    if (!(z > 1e-6f * (glm::length(v) + 1.0f))) return full;
    const float zt = z * rays.tan_half;
    const float j = (w * 0.5f) * (dot3(v, rays.right) / (zt * rays.aspect) + 1.0f);
    const float i = (h * 0.5f) * (1.0f - dot3(v, rays.up) / zt);
    if (!std::isfinite(i) || !std::isfinite(j)) return full;
    jmin = std::min(jmin, j);
    jmax = std::max(jmax, j);
    imin = std::min(imin, i);
    imax = std::max(imax, i);
  }
  PixelRect r;
  r.j0 = static_cast<int>(std::clamp(std::floor(jmin) - 1.0f, 0.0f, w));
  r.j1 = static_cast<int>(std::clamp(std::floor(jmax) + 1.0f, -1.0f, w - 1.0f));
  r.i0 = static_cast<int>(std::clamp(std::floor(imin) - 1.0f, 0.0f, h));
  r.i1 = static_cast<int>(std::clamp(std::floor(imax) + 1.0f, -1.0f, h - 1.0f));
  return r;
}

void display_impostors(const std::vector<ImpostorQuad>& quads, const CameraParams& camera,
                       int width, int height, float* out, int threads) {
  if (width < 1 || height < 1) throw std::invalid_argument("width and height must be >= 1");
  camera.validate();
  for (const auto& q : quads) q.validate();
  const CameraRays rays(camera, width, height);
  std::vector<PixelRect> rects(quads.size());
  for (std::size_t k = 0; k < quads.size(); ++k) rects[k] = impostor_rect(quads[k], rays);
  parallel_chunks(static_cast<std::size_t>(height), threads, [&](std::size_t r0, std::size_t r1) {
    std::fill(out + r0 * width * 4, out + r1 * width * 4, 0.0f);
    for (std::size_t k = 0; k < quads.size(); ++k) {
      const ImpostorQuad& q = quads[k];
      const PixelRect& rc = rects[k];
      const glm::vec3 qo = q.centre - rays.origin;
      const float plane = dot3(qo, q.forward);
      const float tw = static_cast<float>(q.width), th = static_cast<float>(q.height);
      const int i0 = std::max(rc.i0, static_cast<int>(r0));
      const int i1 = std::min(rc.i1, static_cast<int>(r1) - 1);
      for (int i = i0; i <= i1; ++i) {
        for (int j = rc.j0; j <= rc.j1; ++j) {
          const glm::vec3 d = rays.direction(i, j);
          const float denom = dot3(d, q.forward);
          if (!(denom > 0.0f)) continue;
          const float t = plane / denom;
          if (!(t > 0.0f)) continue;
          const glm::vec3 rel = t * d - qo;
          const float s = dot3(rel, q.right) / q.half_w;
          const float v = dot3(rel, q.up) / q.half_h;
          if (!q.clamp && !(std::abs(s) <= 1.0f && std::abs(v) <= 1.0f)) continue;
          const float u = (s + 1.0f) * 0.5f * tw - 0.5f;
          const float y = (1.0f - v) * 0.5f * th - 0.5f;
          const float fu = std::floor(u), fv = std::floor(y);
          const float wx = u - fu, wy = y - fv;
          const int x0 = static_cast<int>(std::clamp(fu, 0.0f, tw - 1.0f));
          const int x1 = static_cast<int>(std::clamp(fu + 1.0f, 0.0f, tw - 1.0f));
          const int y0 = static_cast<int>(std::clamp(fv, 0.0f, th - 1.0f));
          const int y1 = static_cast<int>(std::clamp(fv + 1.0f, 0.0f, th - 1.0f));
          const auto at = [&](int x, int yy, int c) {
            return q.rgba[(static_cast<std::size_t>(yy) * q.width + x) * 4 + c];
          };
          float src[4];
          for (int c = 0; c < 4; ++c)
            src[c] = lerp(lerp(at(x0, y0, c), at(x1, y0, c), wx),
                          lerp(at(x0, y1, c), at(x1, y1, c), wx), wy);
          float* px = out + (static_cast<std::size_t>(i) * width + j) * 4;
          const float keep = 1.0f - src[3];
          for (int c = 0; c < 4; ++c) px[c] = src[c] + keep * px[c];
        }
      }
    }
  });
}

}  // namespace cumuli
