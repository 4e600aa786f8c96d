#include "cumuli/phase.hpp"

#include <algorithm>
#include <cmath>

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

float smoothstep(float e0, float e1, float x) {
  const float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

}  // namespace cumuli
