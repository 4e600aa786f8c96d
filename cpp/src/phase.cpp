#include "cumuli/phase.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>

namespace cumuli {

float henyey_greenstein(float g, float cos_theta) {
  const float g2 = g * g;
  const float denom = 1.0f + g2 - 2.0f * g * cos_theta;
  // 4π as a float32 constant, as the GLSL writes it.
  constexpr float kFourPi = 12.566370614359172f;
  return (1.0f - g2) / (kFourPi * std::pow(denom, 1.5f));
}

float rayleigh(float cos_theta) {
  constexpr float kSixteenPi = 50.26548245743669f;
  return 3.0f * (1.0f + cos_theta * cos_theta) / kSixteenPi;
}

float phase_4pi(PhaseKind kind, float g, float cos_theta) {
  switch (kind) {
    case PhaseKind::Rayleigh:
      return 0.75f * (1.0f + cos_theta * cos_theta);
    case PhaseKind::Isotropic:
      return 1.0f;
    case PhaseKind::HenyeyGreenstein:
    default: {
      const float denom = 1.0f + g * g - 2.0f * g * cos_theta;
      return (1.0f - g * g) / (denom * std::sqrt(denom));
    }
  }
}

ApproxMie approx_mie_params(float d) {
  if (!(d >= kMieDiameterMin && d <= kMieDiameterMax))
    throw std::invalid_argument("droplet diameter must be in [5, 50] µm");
  ApproxMie m{};
  m.g_hg = std::exp(-0.0990567f / (d - 1.67154f));
  m.g_d = std::exp(-2.20679f / (d + 3.91029f) - 0.428934f);
  m.alpha = std::exp(3.62489f - 8.29288f / (d + 5.52825f));
  m.w_d = std::exp(-0.599085f / (d - 0.641583f) - 0.665888f);
  return m;
}

float draine(float g, float alpha, float cos_theta) {
  const float shape =
      (1.0f + alpha * cos_theta * cos_theta) / (1.0f + alpha * (1.0f + 2.0f * g * g) / 3.0f);
  return henyey_greenstein(g, cos_theta) * shape;
}

float approx_mie(const ApproxMie& m, float cos_theta, float scale) {
  return (1.0f - m.w_d) * henyey_greenstein(m.g_hg * scale, cos_theta) +
         m.w_d * draine(m.g_d * scale, m.alpha, cos_theta);
}

float approx_mie_mean_cosine(const ApproxMie& m) {
  const float g2 = m.g_d * m.g_d;
  const float gd = m.g_d * (1.0f + m.alpha * (3.0f + 2.0f * g2) / 5.0f) /
                   (1.0f + m.alpha * (1.0f + 2.0f * g2) / 3.0f);
  return (1.0f - m.w_d) * m.g_hg + m.w_d * gd;
}

float smoothstep(float e0, float e1, float x) {
  const float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

}  // namespace cumuli
