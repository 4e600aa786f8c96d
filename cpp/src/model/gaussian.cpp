#include "cumuli/model/gaussian.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "cumuli/rng.hpp"

namespace cumuli {

namespace {

void require_finite(glm::vec3 v, const char* name) {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(v[k])) throw std::invalid_argument(std::string(name) + " must be finite");
}

// Eq. (16)'s fall-off constant.
constexpr double kEq16Falloff = 0.1;
// Redraws per coordinate before ClampMode::Resample gives up and saturates (only reachable with
// clamp windows far out in the tail).
constexpr int kMaxRedraws = 64;

}  // namespace

void GaussianCumulusParams::validate() const {
  if (n < 1 || n > kMaxPrimitives)
    throw std::invalid_argument("n must be in [1, " + std::to_string(kMaxPrimitives) + "], got " +
                                std::to_string(n));
  require_finite(centre, "centre");
  require_finite(mu, "mu");
  require_finite(sigma, "sigma");
  require_finite(clamp_lo, "clamps");
  require_finite(clamp_hi, "clamps");
  require_finite(hollow_box, "hollow_box");
  for (int k = 0; k < 3; ++k) {
    if (!(sigma[k] > 0.0f)) throw std::invalid_argument("sigma must be positive on every axis");
    if (!(clamp_lo[k] <= clamp_hi[k]))
      throw std::invalid_argument("clamps: each (lo, hi) needs lo <= hi");
    if (hollow_box[k] < 0.0f) throw std::invalid_argument("hollow_box must be non-negative");
  }
  if (!(std::isfinite(epsilon) && epsilon > 0.0f))
    throw std::invalid_argument("epsilon must be finite and positive");
  if (!(std::isfinite(radius_scale) && radius_scale > 0.0f))
    throw std::invalid_argument("radius_scale must be finite and positive");
  if (radius_model == RadiusModel::Uniform &&
      !(std::isfinite(radius_lo) && std::isfinite(radius_hi) && radius_lo > 0.0f &&
        radius_lo <= radius_hi))
    throw std::invalid_argument("radius range must satisfy 0 < lo <= hi");
}

bool in_hollow_box(glm::vec3 offset, glm::vec3 half) {
  return std::fabs(offset.x) < half.x && std::fabs(offset.y) < half.y &&
         std::fabs(offset.z) < half.z;
}

std::vector<int> remove_contained_spheres(const std::vector<glm::vec3>& centres,
                                          const std::vector<float>& radii) {
  const int n = static_cast<int>(centres.size());
  std::vector<int> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  // A container is at least as large as what it contains: visiting large spheres first means a
  // sphere only needs testing against spheres already kept (containment is transitive).
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return radii[a] > radii[b]; });
  std::vector<int> kept;
  kept.reserve(static_cast<std::size_t>(n));
  for (int j : order) {
    bool inside = false;
    for (int i : kept) {
      // Eq. (17): sphere j lies inside sphere i when r_i − r_j ≥ |c_i − c_j|. Computed in double
      // so that a sphere touching its container from inside is classified the same on every build.
      const glm::dvec3 d = glm::dvec3(centres[i]) - glm::dvec3(centres[j]);
      if (double(radii[i]) - double(radii[j]) >= std::sqrt(glm::dot(d, d))) {
        inside = true;
        break;
      }
    }
    if (!inside) kept.push_back(j);
  }
  std::sort(kept.begin(), kept.end());  // back to drawing order
  return kept;
}

GaussianCumulusResult gaussian_cumulus(const GaussianCumulusParams& p) {
  p.validate();
  GaussianCumulusResult out;
  std::vector<glm::vec3> centres;
  std::vector<float> radii;
  centres.reserve(static_cast<std::size_t>(p.n));
  radii.reserve(static_cast<std::size_t>(p.n));
  const glm::vec3 half = p.hollow_box * p.sigma;
  for (int i = 0; i < p.n; ++i) {
    // One stream per primitive: the first k primitives do not depend on n.
    Rng rng = Rng::stream(p.seed, static_cast<std::uint64_t>(i));
    glm::dvec3 offset;
    for (int k = 0; k < 3; ++k) {
      const double lo = double(p.mu[k]) + double(p.clamp_lo[k]) * p.sigma[k];
      const double hi = double(p.mu[k]) + double(p.clamp_hi[k]) * p.sigma[k];
      double v = rng.normal(p.mu[k], p.sigma[k]);
      if (v < lo || v > hi) {
        ++out.clamped;
        if (p.clamp_mode == ClampMode::Resample)
          for (int t = 0; t < kMaxRedraws && (v < lo || v > hi); ++t)
            v = rng.normal(p.mu[k], p.sigma[k]);
        v = std::min(std::max(v, lo), hi);
      }
      offset[k] = v;
    }
    // Uniform radii draw after the position so positions match the other radius models.
    double r = 0.0;
    switch (p.radius_model) {
      case RadiusModel::Eq15:
        r = p.epsilon / (std::fabs(offset.x) + std::fabs(offset.z) + 1.0);
        break;
      case RadiusModel::Eq16: {
        const glm::dvec3 u = offset / (2.0 * glm::dvec3(p.sigma));
        const glm::dvec3 u2 = u * u;
        const double s =
            p.eq16_combine == Eq16Combine::Sum ? u2.x + u2.y + u2.z : u2.x * u2.y * u2.z;
        r = p.epsilon * (1.0 - kEq16Falloff * std::sqrt(s));
        // Eq. (16) turns negative beyond 10 × 2σ; such clamp windows are allowed, so keep a small
        // positive radius rather than an invalid sphere.
        r = std::max(r, 0.01 * p.epsilon);
        break;
      }
      case RadiusModel::Uniform:
        r = rng.uniform(p.radius_lo, p.radius_hi);
        break;
    }
    ++out.drawn;
    const glm::vec3 off32(offset);
    if (p.hollow && in_hollow_box(off32, half)) {
      ++out.removed_by_hollow;
      continue;
    }
    centres.push_back(p.centre + off32);
    radii.push_back(static_cast<float>(r * p.radius_scale));
  }
  if (p.remove_contained && centres.size() > 1) {
    const std::vector<int> keep = remove_contained_spheres(centres, radii);
    out.removed_by_containment = static_cast<int>(centres.size() - keep.size());
    for (int i : keep) {
      out.centres.push_back(centres[i]);
      out.radii.push_back(radii[i]);
    }
  } else {
    out.centres = std::move(centres);
    out.radii = std::move(radii);
  }
  return out;
}

}  // namespace cumuli
