// Multiple forward scattering light pass of particle clouds (Harris 2002 §2.2.1, §2.3, Fig. 4;
// equations (1)–(4) with the factors the talk leaves out restored, RENDER_CONTRACT "Sprites").
//
// Per cloud and directional light (s towards the light, light travels along l = −s):
//   1. light frame f = −s, r = normalize(f × up), u = r × f (up = +y, or +x when |f·y| > 1 − 1e−6),
//      bounding sphere (c, R_b) of the particles (centres ± radii);
//   2. an orthographic N_L × N_L buffer tightly fit to the sphere; particle k lands at
//      x = ((p − c)·r + R_b)/(2R_b)·N_L, y = ((p − c)·u + R_b)/(2R_b)·N_L, footprint r_px =
//      r_k·N_L/(2R_b);
//   3. the buffer is cleared to 1 (I₀ = 1: the light's colour multiplies later);
//   4. particles sorted by t_k = (p_k − c)·f ascending (nearest the light first), ties by index;
//   5. for each particle in that order: read back I_k before drawing it (pixel, bilinear or a
//      SkyWorks solid-angle patch), store it, then splat g_k = a_k τ_k p_fwd γ/(4π)·I_k with alpha
//      α_k = 1 − e^{−τ_k} over its footprint: B ← w·g_k + (1 − w·α_k)·B, w = K(d) — GL blending
//      (ONE, ONE_MINUS_SRC_ALPHA), recurrence (4): I_k = g_{k−1} + T_{k−1}·I_{k−1}.
// Optional 2002 emulation: quantize = 8 rounds the buffer to 1/255 (and clamps to [0, 1]) after
// each blend, clamp = true clamps it to [0, 1]. The final buffer is the cloud's transmittance
// shadow map.
//
// Everything is float32 in a fixed operation order (the GLSL twin shaders/particles/light.comp.glsl
// and the GL read-back path agree to ~1e−7). Clouds × lights run on threads, each task sequential
// (the recurrence is), so results do not depend on the thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/model/particles.hpp"
#include "cumuli/phase.hpp"

namespace cumuli {

// Splat kernel K(d) = peak·k(d) for d = distance/r_px < 1, K = 0 for d ≥ 1 (spec §2.2):
// windowed Gaussian σ_w = 1/3: k = (e^{−4.5d²} − e^{−4.5})/(1 − e^{−4.5}) [decision], or SkyWorks'
// cubic Hermite k = 1 − 3d² + 2d³. Both give K(1) = 0.
enum class SplatKernel { Gaussian = 0, Hermite = 1 };
float splat_kernel(SplatKernel kernel, float peak, float d);

enum class Readback { Pixel = 0, Bilinear = 1, SolidAngle = 2 };

struct ParticleLightSettings {
  int resolution = 32;       // N_L (SkyWorks s_iShadeResolution)
  float solid_angle = 1.0f;  // γ of g = a τ p_fwd I γ/4π ([H]: 1, i.e. omitted)
  PhaseKind phase = PhaseKind::Rayleigh;
  float hg_g = 0.6f;
  SplatKernel kernel = SplatKernel::Gaussian;
  float peak = 1.0f;
  Readback readback = Readback::Pixel;
  float readback_solid_angle = 0.09f;  // γ_r of the SkyWorks read-back patch (sr)
  bool forward = true;                 // false: g = 0 (single scattering only, [H] Fig. 10)
  bool clamp = false;                  // clamp the buffer to [0, 1] after each blend
  int quantize = 0;                    // 0 (float32) or 8 (round to 1/255 after each blend)
  bool allow_gain = false;             // allow a τ p_fwd γ/4π > α (a particle adding light)

  static constexpr int kMinResolution = 8;
  static constexpr int kMaxResolution = 4096;
  void validate() const;  // throws std::invalid_argument naming the setting
  // p_fwd = p(cos θ = 1) of the chosen phase (4π-normalised).
  float forward_phase() const { return phase_4pi(phase, hg_g, 1.0f); }
};

// Forward-scattering factor a·τ·p_fwd·γ/(4π) of one particle (0 when forward scattering is off).
float forward_factor(float albedo, float tau, const ParticleLightSettings& settings);
// Throws std::invalid_argument naming solid_angle when some particle's forward factor exceeds its
// α = 1 − e^{−τ} (the particle would add light, m > 1: spec §3.1), unless allow_gain.
void check_energy(const ParticleView& particles, const ParticleLightSettings& settings);

// The orthographic light camera of one cloud and light.
struct LightFrame {
  glm::vec3 centre{0.0f};                          // c, centre of the particles' AABB
  float radius = 0.0f;                             // R_b
  glm::vec3 forward{0.0f}, right{0.0f}, up{0.0f};  // f = −s, r, u
};
LightFrame light_frame(const ParticleView& particles, glm::vec3 sun_direction);

// One particle as the light pass splats it, in processing order.
struct LightSplat {
  float x = 0.0f, y = 0.0f;  // continuous buffer coordinates of the centre
  float r_px = 0.0f;         // footprint radius in buffer pixels
  float forward = 0.0f;      // forward_factor (g_k = forward·I_k)
  float alpha = 0.0f;        // 1 − e^{−τ_k}
  std::uint32_t index = 0;   // the particle's index in the cloud
  std::int32_t patch = 1;    // side n of the solid-angle read-back patch
};
// The splats of one light, sorted nearest the light first (ties by index).
std::vector<LightSplat> light_splats(const ParticleView& particles, const LightFrame& frame,
                                     const ParticleLightSettings& settings);

// Read-back of I_k from `buffer` (N_L² floats, [y][x]) before drawing `s`. The solid-angle patch
// mean sums each row in x order, then the row sums in y order, then divides by side².
float light_read_back(const float* buffer, int n, const LightSplat& s, Readback mode);
// Blend one splat with source (w·g, w·α) into the buffer (then clamp / quantize).
void light_splat(float* buffer, int n, const LightSplat& s, float g,
                 const ParticleLightSettings& settings);

// The light pass of one cloud for one light: I_k written to light[k·stride] (input order); the
// final buffer (N_L², [y][x], y along the light frame's up) to `buffer` when not null.
void particle_light_one(const ParticleView& particles, glm::vec3 sun_direction,
                        const ParticleLightSettings& settings, float* light, std::size_t stride,
                        float* buffer);

// The shadow-map by-product (spec §4 step 6, §10.3.9): the transmittance of the light through the
// cloud at world points, the final light buffer `buffer` (n², [y][x]) of `frame` sampled bilinearly
// (texel centres, clamp to edge) at the point's buffer coordinates x = ((p − c)·r + R)/(2R)·n,
// y = ((p − c)·u + R)/(2R)·n. 1 (unshadowed) outside the buffer's square or in front of the cloud
// ((p − c)·f < −R, nearer the light than every particle).
void particle_shadow(const LightFrame& frame, const float* buffer, int n, const glm::vec3* points,
                     std::size_t count, float* out);

// Clouds × lights on `threads` threads (0 = all). light_out[c] holds n_c × L floats ([k][ℓ]);
// buffers_out[c] (may be null) L × N_L² floats. Sun directions must be unit vectors.
void particle_light(const std::vector<ParticleView>& clouds, const std::vector<glm::vec3>& suns,
                    const ParticleLightSettings& settings, const std::vector<float*>& light_out,
                    const std::vector<float*>& buffers_out, int threads);

}  // namespace cumuli
