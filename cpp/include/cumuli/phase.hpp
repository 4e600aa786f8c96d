// Phase function and sky model shared by the render pass (RENDER_CONTRACT; DESIGN §4).
//
// Both are twins of the GLSL marcher's: the parity tests hold them together, so they follow the
// contract's formulas operation by operation (same order, float32 throughout).
#pragma once

#include <glm/vec3.hpp>

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

// GLSL's smoothstep: t = clamp((x − e0)/(e1 − e0), 0, 1); t²(3 − 2t).
float smoothstep(float e0, float e1, float x);

struct SkyParams {
  glm::vec3 zenith{0.25f, 0.45f, 0.85f};
  glm::vec3 horizon{0.75f, 0.85f, 0.95f};
  glm::vec3 ground{0.35f, 0.33f, 0.3f};
  float exponent = 0.5f;
  float sun_disc_radius = 0.5f;     // degrees; ≤ 0 draws no disc
  float sun_disc_intensity = 0.0f;  // multiplies the sun radiance inside the disc
};

struct SunParams {
  glm::vec3 direction{0.0f, 1.0f, 0.0f};  // unit, towards the sun
  glm::vec3 radiance{1.0f};               // colour · intensity
};

// Sky radiance seen along unit direction d:
// base = d.y ≥ 0 ? horizon + (zenith − horizon)·pow(d.y, exponent)
//                : horizon + (ground − horizon)·min(1, −8·d.y);
// disc = smoothstep(cos(1.5·rad), cos(rad), dot(d, sun)) · sun_disc_intensity · sun_radiance.
glm::vec3 sky_radiance(const SkyParams& sky, const SunParams& sun, glm::vec3 d);

}  // namespace cumuli
