// CPU rasteriser of view-plane-parallel sprites: the CPU twin of
// shaders/sprites/sprites.{vert,frag}.glsl, shared by Harris 2002 particle splats (§2.3, eq. (5)
// and (6)) and Torchelsen & Musse 2005 billboards.
//
// A sprite is a w×h rectangle centred at a world point, parallel to the image plane, rotated by
// `rotation` about the view axis. Its projection (RENDER_CONTRACT camera: f, r, u, th = tan(fov/2),
// aspect = W/H) is, with v = centre − eye, Z = v·f, X = v·r, Y = v·u (skipped when Z ≤ near):
//   j_c = W/2·(X/(Z·th·aspect) + 1),  i_c = H/2·(1 − Y/(Z·th)),  scale = (H/2)/(Z·th)  pixels per
//   unit,
// a rectangle of half sizes (half.x·scale, half.y·scale) in pixels. At pixel (row i, col j) the
// sprite coordinates (s, t) ∈ [−1, 1]² (s along the rotated right, t along the rotated up) are
//   dx = (j + ½) − j_c, dy = (i + ½) − i_c,  s = (dx·cos ψ − dy·sin ψ)/hx,  t = (−dx·sin ψ − dy·cos
//   ψ)/hy.
// Corners v0..v3 = (−1,−1), (1,−1), (1,1), (−1,1) (bottom-left, bottom-right, top-right, top-left);
// per-vertex colours interpolate barycentrically over the triangles (v0,v1,v2) (s ≥ t) and
// (v0,v2,v3).
//
// Two fragment modes, chosen per sprite by `texture`:
//   * texture < 0, analytic splat (Harris): w = K(d), d = √(s² + t²); source (w·colour, w·alpha)
//     — colour is the particle's scattered light, not scaled by alpha (eq. (5): E = S + T·E);
//   * texture ≥ 0, atlas cell (Torchelsen): straight-alpha RGBA sampled bilinearly (texel-centre
//     convention, clamp to the cell's edge, lerp a + f·(b − a) along x then y) at
//     tx = cell_x0 + (s + 1)/2·cell_w, ty = cell_y0 + (1 − t)/2·cell_h (atlas row 0 on top);
//     a = tex.a·alpha, source (colour·tex.rgb·a, a).
// Billboard fragment shading (Torchelsen spec §4.2, shading = "fragment"; optional SpriteShading):
// the colour is evaluated per pixel at the pixel's point on the billboard,
//   p = centre + (s·half.x)·r′ + (t·half.y)·u′,  r′ = cos ψ·r + sin ψ·u,  u′ = −sin ψ·r + cos ψ·u,
// with shade_point (light/caf.hpp) for the sprite's cloud frame and CAF row, in place of the
// interpolated vertex colours (GLSL twin: shaders/common/billboard_shade.glsl).
// Blending is premultiplied "over" in the given order (back to front): C ← src.rgb + (1 − src.a)·C,
// A ← src.a + (1 − src.a)·A, into a layer cleared to 0 — GL's (ONE, ONE_MINUS_SRC_ALPHA). The layer
// has no sky: the compositor adds it (rgb = C + (1 − A)·sky, alpha = A).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "cumuli/light/caf.hpp"
#include "cumuli/light/particles.hpp"

namespace cumuli {

struct SpriteCamera {
  glm::vec3 position{0.0f};
  glm::vec3 forward{0.0f, 0.0f, -1.0f}, right{1.0f, 0.0f, 0.0f}, up{0.0f, 1.0f, 0.0f};  // unit
  float tan_half = 0.4663077f;  // tan(vertical fov / 2)
  int width = 1, height = 1;
  float near = 1e-3f;

  static constexpr int kMaxEdge = 1 << 15;
  void validate() const;  // throws std::invalid_argument
};

struct Sprite {
  glm::vec3 centre{0.0f};
  glm::vec2 half_size{1.0f};          // world half width and height (Harris: r_k, r_k)
  float rotation = 0.0f;              // radians about the view axis, counter-clockwise on screen
  std::array<glm::vec3, 4> colour{};  // at v0..v3
  float alpha = 1.0f;                 // Harris: 1 − e^{−τ}; billboards: opacity·fade
  std::int32_t texture =
      -1;  // −1: analytic splat kernel; ≥ 0: atlas cell (row-major, row 0 on top)
};

// Straight-alpha RGBA atlas, (height, width, 4) float32, row 0 on top, split into nx × ny cells.
struct SpriteAtlas {
  const float* rgba = nullptr;
  int width = 0, height = 0, nx = 1, ny = 1;
  void validate() const;
};

struct SpriteRasterSettings {
  SplatKernel kernel = SplatKernel::Gaussian;
  float peak = 1.0f;
};

// A sprite on screen (pixels, continuous coordinates: j + ½ is a pixel centre).
struct ScreenSprite {
  bool visible = false;  // Z > near and finite
  float jc = 0.0f, ic = 0.0f, hx = 0.0f, hy = 0.0f, cos_r = 1.0f, sin_r = 0.0f;
  float depth = 0.0f;  // Z
  // Inclusive pixel range the sprite can touch, clipped to the image (empty when j0 > j1).
  int j0 = 0, j1 = -1, i0 = 0, i1 = -1;
};
ScreenSprite project_sprite(const Sprite& sprite, const SpriteCamera& camera);

// Per-pixel billboard shading of every sprite (fragment mode): lights in world space, and per
// sprite k its cloud frame (frame[k] = (c_C, R_C), yrange[k] = (y_lo, y_hi), world) and its CAF
// per light, caf[k·lights.size() + ℓ].
struct SpriteShading {
  std::vector<ShadeLight> lights;
  ShadeParams params;
  const glm::vec4* frame = nullptr;
  const glm::vec2* yrange = nullptr;
  const float* caf = nullptr;
};

// Rasterise sprites in the given order (back to front) into `out`, height × width × 4 floats,
// which this function clears first. Rows are split over threads (result independent of threads).
// `atlas` may be null when no sprite has texture ≥ 0; `shading` (optional) switches every
// sprite to per-pixel billboard shading. `depth` (height × width view depths, e.g. of opaque
// solids, +∞ where none) may be null; when given, a sprite covers only the pixels where its view
// depth Z < depth (Harris 2002 §3.1.1, direct rendering with the depth test).
void rasterise_sprites(const std::vector<Sprite>& sprites, const SpriteCamera& camera,
                       const SpriteRasterSettings& settings, const SpriteAtlas* atlas, float* out,
                       int threads, const SpriteShading* shading = nullptr,
                       const float* depth = nullptr);

// --- Harris particles as sprites (eye pass, spec §5 steps 1–4) --------------------------------

enum class SpriteSort { Distance = 0, Depth = 1 };

struct ParticleSpriteSettings {
  float solid_angle = 1.0f;  // γ
  PhaseKind phase = PhaseKind::Rayleigh;
  float hg_g = 0.6f;
  glm::vec3 ambient{0.0f};
  SpriteSort sort = SpriteSort::Distance;
  bool cull =
      true;  // drop clouds outside the frustum and particles off screen (never changes pixels)
};

// One light as the eye pass sees it: direction towards it, radiance = colour·intensity.
struct SpriteLight {
  glm::vec3 direction{0.0f, 1.0f, 0.0f};
  glm::vec3 radiance{1.0f};
};

struct ParticleSpriteList {
  std::vector<std::uint32_t> index;  // particle indices, back to front
  std::vector<glm::vec3> colour;     // C_k = ambient + Σ_ℓ c_{k,ℓ}·p(cos θ_ℓ)
  std::vector<float> alpha;          // 1 − e^{−τ_k}
  std::vector<float> key;            // the sort key (distance or depth), decreasing
};

// Colour, cull and sort the particles for the camera: c_{k,ℓ} = a_k τ_k γ/(4π)·i_{k,ℓ}·radiance_ℓ,
// cos θ_ℓ = normalize(p_k − eye)·s_ℓ; order back to front by |p_k − eye| (distance) or
// (p_k − eye)·f (depth), ties by index. `light` is n × L ([k][ℓ]).
ParticleSpriteList particle_sprites(const ParticleView& particles, const float* light,
                                    const std::vector<SpriteLight>& lights,
                                    const SpriteCamera& camera,
                                    const ParticleSpriteSettings& settings);

// Whether a sphere lies wholly outside the camera's frustum (behind the near plane or beyond a
// side plane); conservative: false whenever any part may show.
bool sphere_outside_frustum(glm::vec3 centre, float radius, const SpriteCamera& camera);

}  // namespace cumuli
