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

// GLSL's smoothstep: t = clamp((x − e0)/(e1 − e0), 0, 1); t²(3 − 2t).
float smoothstep(float e0, float e1, float x);

}  // namespace cumuli
