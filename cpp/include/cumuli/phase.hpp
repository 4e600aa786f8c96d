// Phase functions shared by the render pass (RENDER_CONTRACT; DESIGN §4); the sky model is
// sky.hpp (included here for the files that take both).
//
// Both are twins of the GLSL marcher's: the parity tests hold them together, so they follow the
// contract's formulas operation by operation (same order, float32 throughout).
#pragma once

#include <glm/vec3.hpp>

#include "cumuli/sky.hpp"

namespace cumuli {

// Henyey-Greenstein phase (eq. 14), normalised by 1/4π:
// HG(g, c) = (1 − g²) / (4π · (1 + g² − 2g·c)^{3/2}), c = cos θ.
float henyey_greenstein(float g, float cos_theta);

// Rayleigh phase (Harris 2002 §2.1: p(θ) = ¾(1 + cos²θ)), normalised by 1/4π like
// henyey_greenstein: 3(1 + c²)/(16π). GLSL twin: rayleigh_phase in shaders/common/phase.glsl.
float rayleigh(float cos_theta);

// The phase functions of the Harris 2002 particle passes, normalised to 4π (∫p dω = 4π, the
// paper's convention, which divides by 4π explicitly): Rayleigh ¾(1 + c²), isotropic 1, and
// Henyey-Greenstein 4π·HG = (1 − g²)/(d·√d), d = 1 + g² − 2g·c. GLSL twin: phase_4pi.
enum class PhaseKind { Rayleigh = 0, Isotropic = 1, HenyeyGreenstein = 2 };
float phase_4pi(PhaseKind kind, float g, float cos_theta);

// The approximate Mie phase of cloud and fog water droplets (Jendersie & d'Eon, "An Approximate
// Mie Scattering Function for Fog and Cloud Rendering", SIGGRAPH 2023 talk): a blend
// (1 − w_D)·HG(g_HG) + w_D·Draine(g_D, α) whose four parameters are the talk's fits over the
// droplet diameter d in µm, valid for 5 ≤ d ≤ 50 (kMieDiameterMin/Max):
//   g_HG = exp(−0.0990567/(d − 1.67154))       g_D = exp(−2.20679/(d + 3.91029) − 0.428934)
//   α    = exp(3.62489 − 8.29288/(d + 5.52825)) w_D = exp(−0.599085/(d − 0.641583) − 0.665888)
// The constants live here only: the GLSL twin (approx_mie_phase in shaders/common/phase.glsl)
// takes the four parameters as uniforms computed by approx_mie_params.
constexpr float kMieDiameterMin = 5.0f;
constexpr float kMieDiameterMax = 50.0f;
struct ApproxMie {
  float g_hg, g_d, alpha, w_d;
};
ApproxMie approx_mie_params(float diameter_um);  // throws std::invalid_argument outside [5, 50]

// Draine's phase (Draine 2003), normalised by 1/4π:
// D(g, α, c) = HG(g, c)·(1 + α·c²)/(1 + α(1 + 2g²)/3).
float draine(float g, float alpha, float cos_theta);

// The blend with both lobes' g scaled by `scale` (the octaves' bⁱ).
float approx_mie(const ApproxMie& m, float cos_theta, float scale = 1.0f);

// Its mean cosine: (1 − w_D)·g_HG + w_D·g_D(1 + α(3 + 2g_D²)/5)/(1 + α(1 + 2g_D²)/3).
float approx_mie_mean_cosine(const ApproxMie& m);

// GLSL's smoothstep: t = clamp((x − e0)/(e1 − e0), 0, 1); t²(3 − 2t).
float smoothstep(float e0, float e1, float x);

}  // namespace cumuli
