#include "cumuli/rendering/physical.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "cumuli/phase.hpp"

namespace cumuli {

void PhysicalParams::validate() const {
  if (!(extinction_scale >= 0.0f) || !std::isfinite(extinction_scale))
    throw std::invalid_argument("extinction_scale must be finite and >= 0");
  if (!(albedo >= 0.0f && albedo <= 1.0f)) throw std::invalid_argument("albedo must be in [0, 1]");
  for (float g : {g1, g2})
    if (!(g > -1.0f && g < 1.0f)) throw std::invalid_argument("phase g must be in (-1, 1)");
  for (float g : {mie_params.g_hg, mie_params.g_d})
    if (!(g > -1.0f && g < 1.0f)) throw std::invalid_argument("Mie lobe g must be in (-1, 1)");
  if (!(mie_params.alpha >= 0.0f && mie_params.w_d >= 0.0f && mie_params.w_d <= 1.0f))
    throw std::invalid_argument("Mie parameters out of range");
  if (!(blend >= 0.0f && blend <= 1.0f)) throw std::invalid_argument("hg_blend must be in [0, 1]");
  if (octaves < 1 || octaves > kMaxOctaves)
    throw std::invalid_argument("octaves must be in [1, " + std::to_string(kMaxOctaves) + "]");
  for (float c : {oct_a, oct_b, oct_c})
    if (!(c >= 0.0f && c <= 1.0f))
      throw std::invalid_argument("octave constants must be in [0, 1]");
  if (!(oct_first > 0.0f && oct_first <= 1.0f))
    throw std::invalid_argument("oct_first must be in (0, 1]");
  if (!(view_scale > 0.0f && view_scale <= 1.0f))
    throw std::invalid_argument("view_scale must be in (0, 1]");
  if (!(oct_poisson >= 0.0f && oct_poisson <= 16.0f))
    throw std::invalid_argument("oct_poisson must be in [0, 16]");
  if (jitter_seed < 0 || jitter_seed > 1023)
    throw std::invalid_argument("jitter_seed must be in [0, 1023]");
  if (!(min_transmittance >= 0.0f && min_transmittance < 1.0f))
    throw std::invalid_argument("min_transmittance must be in [0, 1)");
  if (!(coarsen_below >= 0.0f && coarsen_below <= 1.0f))
    throw std::invalid_argument("coarsen_below must be in [0, 1]");
  if (!order_phase.empty()) {
    const std::size_t want = static_cast<std::size_t>(octaves - 1) * kOrderPhaseSize;
    if (order_phase.size() != want)
      throw std::invalid_argument("order_phase must hold (octaves - 1) x " +
                                  std::to_string(kOrderPhaseSize) + " values, got " +
                                  std::to_string(order_phase.size()));
    for (float v : order_phase)
      if (!(v >= 0.0f) || !std::isfinite(v))
        throw std::invalid_argument("order_phase values must be finite and >= 0");
  }
}

float PhysicalParams::phase(float cos_theta, float scale) const {
  if (mie) return approx_mie(mie_params, cos_theta, scale);
  const float p1 = henyey_greenstein(g1 * scale, cos_theta);
  if (!dual_hg) return p1;
  return (1.0f - blend) * p1 + blend * henyey_greenstein(g2 * scale, cos_theta);
}

float PhysicalParams::order_phase_at(int order, float cos_theta, float b_power) const {
  if (order == 0 || order_phase.empty()) return phase(cos_theta, b_power);
  // sin(θ/2) = √((1 − cos θ)/2): no inverse trigonometry (whose GLSL accuracy varies), and
  // entries closest together where the phase is steepest, near the forward direction.
  const float u = std::sqrt(std::max(0.5f - 0.5f * cos_theta, 0.0f));
  const float x = std::min(u, 1.0f) * static_cast<float>(kOrderPhaseSize - 1);
  const int k = std::min(static_cast<int>(x), kOrderPhaseSize - 2);
  const float w = x - static_cast<float>(k);
  const float* row = order_phase.data() + static_cast<std::size_t>(order - 1) * kOrderPhaseSize;
  return row[k] + w * (row[k + 1] - row[k]);
}

OctaveTerms::OctaveTerms(const PhysicalParams& p, float cos_theta)
    : n(p.octaves), poisson(p.oct_poisson) {
  float a = 1.0f, b = 1.0f, c = 1.0f;
  for (int i = 0; i < n; ++i) {
    weight[i] = a * p.order_phase_at(i, cos_theta, b);
    scale[i] = i == 0 ? p.oct_first : c;
    a *= p.oct_a;
    b *= p.oct_b;
    c *= p.oct_c;
  }
}

float OctaveTerms::sum(float tau) const {
  float s = 0.0f;
  if (!(poisson > 0.0f)) {
    for (int i = 0; i < n; ++i) s += weight[i] * std::exp(-scale[i] * tau);
    return s;
  }
  const float x = poisson * std::max(tau, 0.0f);
  float pw = 1.0f;  // xⁱ/i!
  for (int i = 0; i < n; ++i) {
    s += weight[i] * pw * std::exp(-scale[i] * tau);
    pw *= x / static_cast<float>(i + 1);
  }
  return s;
}

void PhysicalGrids::validate() const {
  frame.validate();
  grid.validate();
  if (depth_size() != static_cast<std::size_t>(frame.res[0]) * frame.res[1] * frame.res[2])
    throw std::invalid_argument("sun depth lattice does not match its frame");
  if (columns_data() != nullptr &&
      columns_size() != static_cast<std::size_t>(frame.res[0]) * frame.res[1])
    throw std::invalid_argument("upstream depth must be (nv, nu), one value per sun column");
  if (rgba_size() != grid.voxels() * 4)
    throw std::invalid_argument("light lattice must be (D, H, W, 4)");
}

glm::vec3 PhysicalGrids::source(glm::vec3 p, const OctaveTerms& terms, glm::vec3 sun_irradiance,
                                float albedo, float diffuse) const {
  constexpr float kInv4Pi = 0.0795774715459477f;
  const float tau = sample_frame(depth_data(), frame, p, columns_data());
  float L[4];
  sample_trilinear(rgba_data(), grid, 4, p, L);
  const float d = diffuse * kInv4Pi;
  const float sun = terms.sum(tau) + L[0] * d;
  return albedo * (sun_irradiance * sun + glm::vec3(L[1], L[2], L[3]) * d);
}

float jitter(int row, int col, int seed) {
  const float s = 5.588238f * static_cast<float>(seed);
  const float x = static_cast<float>(col) + s, y = static_cast<float>(row) + s;
  const float a = 0.06711056f * x;
  const float b = 0.00583715f * y;
  const float f = a + b;
  const float inner = f - std::floor(f);
  const float g = 52.9829189f * inner;
  return g - std::floor(g);
}

}  // namespace cumuli
