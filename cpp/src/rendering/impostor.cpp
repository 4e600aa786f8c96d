#include "cumuli/rendering/impostor.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>

namespace cumuli {

namespace {

bool finite3(glm::dvec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

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

}  // namespace cumuli
