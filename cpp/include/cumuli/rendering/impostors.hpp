// Impostor mathematics of Harris 2002 §3 (dynamically generated impostors, after Schaufler 1995)
// and §3.1 (viewpoint inside a cloud). Pure functions in double
// precision (one evaluation per cloud and frame); the GL impostor cache builds on them.
//
// For a bounding sphere (c, R) seen from e₀ with d₀ = |c − e₀| > R:
//   n̂₀ = (c − e₀)/d₀, half-angle β = asin(R/d₀), the impostor camera looks from e₀ at c with a
//   vertical fov of 2β (aspect 1), up = world up (+x when the view is vertical);
//   quad centred at c spanned by that camera's right/up, half-size h = d₀·tan β = d₀R/√(d₀² − R²);
//   near point P_n = e₀ + (d₀ − R)n̂₀, far point P_f = e₀ + (d₀ + R)n̂₀.
// Update metrics at the current eye e:
//   translation error α_trans = ∠(P_n − e, P_f − e) (atan2 of |a × b| and a·b: accurate at small
//   angles); "backwards" when |P_n − e| > |P_f − e| (SkyWorks);
//   texture resolution: res_req = res_scale·f_px·2R/d, f_px = (H/2)/tan(fov/2) (the focal length in
//   pixels, [H]'s "resolution_screen"), generated at min(max_res, max(min_res, pow2ceil(res_req))).
// Screen impostors (§3.1) replace the tight one when the eye is inside the sphere
// (d ≤ R(1 + 1e−6)), when the near plane would cut it (d − R < r_near, r_near the distance from the
// eye to a corner of the near plane, SkyWorks' rCamRadius), or when 2β is wider than the view's
// diagonal fov; they are the view camera at ⌈W/f⌉ × ⌈H/f⌉ pixels.
//
// Display (§7.2; the CPU twin of shaders/impostors/impostor.frag.glsl in exact mode): an impostor
// is a premultiplied image on a plane through `centre` with unit normal `forward` and unit axes
// right/up, half sizes (half_w, half_h). Per pixel, the camera ray o + t·d (RENDER_CONTRACT) meets
// the plane at t = ((c − o)·f)/(d·f) (none unless d·f > 0 and t > 0); rel = t·d − (c − o),
// s = rel·right/half_w, v = rel·up/half_h; outside |s|, |v| ≤ 1 a tight impostor is transparent (a
// screen impostor — the view plane at distance 1 — clamps); texel coordinates
// tx = (s + 1)/2·w, ty = (1 − v)/2·h (row 0 on top), bilinear with the texel-centre convention and
// clamp to edge (lerp a + f·(b − a) along x, then y). Impostors are drawn in the given order (back
// to front) with premultiplied over, dst = src + (1 − src.a)·dst, into a layer cleared to 0.
// From the eye an impostor was made at, the tight quad reproduces its image exactly (each pixel
// ray meets the plane at the image's own texel centres).
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/rendering/marcher.hpp"

namespace cumuli {

struct ImpostorView {
  glm::dvec3 eye{0.0}, centre{0.0};
  double radius = 0.0;
  glm::dvec3 forward{0.0}, right{0.0}, up{0.0};  // n̂₀ and the camera's right/up
  double distance = 0.0;                         // d₀
  double half_angle = 0.0;                       // β, radians
  double fov_degrees = 0.0;                      // 2β in degrees
  double half_size = 0.0;                        // h
  glm::dvec3 near_point{0.0}, far_point{0.0};
};

// Throws std::invalid_argument when the eye is inside the sphere (d₀ ≤ R) or inputs are not finite.
ImpostorView tight_impostor_view(glm::dvec3 eye, glm::dvec3 centre, double radius,
                                 glm::dvec3 world_up = glm::dvec3(0.0, 1.0, 0.0));

// α_trans in radians.
double translation_error(glm::dvec3 near_point, glm::dvec3 far_point, glm::dvec3 eye);
bool impostor_backwards(glm::dvec3 near_point, glm::dvec3 far_point, glm::dvec3 eye);

// f_px = (height/2)/tan(fov/2), fov vertical in degrees.
double focal_length_px(int height, double fov_degrees);
// res_req = res_scale·f_px·2R/d.
double required_resolution(double focal_px, double radius, double distance, double res_scale);
// min(max_res, max(min_res, pow2ceil(res_req))) (or ⌈res_req⌉ when !pow2).
int impostor_resolution(double res_req, int min_res, int max_res, bool pow2);
// SkyWorks' rule: 2·max(W,H)·R/d rounded down to a power of two, at most max(W,H)/2, divided by 4
// when d < R + r_near and by 8 when d < R/2 + r_near, at least min_res.
int impostor_resolution_skyworks(int width, int height, double radius, double distance,
                                 double near_radius, int min_res);

// Distance from the eye to a corner of the near plane: near·√(1 + th²(1 + aspect²)).
double near_corner_radius(double near, double tan_half, double aspect);
// Half the view's diagonal field of view, radians: atan(th·√(1 + aspect²)).
double half_diagonal_fov(double tan_half, double aspect);

// The §7.4 test: must this sphere be drawn through a screen impostor from `eye`?
bool needs_screen_impostor(glm::dvec3 eye, glm::dvec3 centre, double radius, double tan_half,
                           double aspect, double near);
// ⌈size/factor⌉.
int screen_impostor_size(int size, int factor);

struct ImpostorQuad {
  const float* rgba = nullptr;  // height × width × 4, premultiplied, row 0 on top
  int width = 0, height = 0;
  glm::vec3 centre{0.0f}, forward{0.0f, 0.0f, 1.0f}, right{1.0f, 0.0f, 0.0f}, up{0.0f, 1.0f, 0.0f};
  float half_w = 1.0f, half_h = 1.0f;
  bool clamp = false;  // screen impostor: clamp outside the image instead of transparent

  void validate() const;  // throws std::invalid_argument
};

// Inclusive pixel rectangle the quad can cover (conservative: the corners' projections ± 1 pixel;
// the whole image when a corner is not in front of the eye or the quad clamps). Empty: j0 > j1.
struct PixelRect {
  int j0 = 0, j1 = -1, i0 = 0, i1 = -1;
};
PixelRect impostor_rect(const ImpostorQuad& quad, const CameraRays& rays);

// The premultiplied layer (height·width·4 floats) of the quads drawn in order (back to front).
void display_impostors(const std::vector<ImpostorQuad>& quads, const CameraParams& camera,
                       int width, int height, float* out, int threads);

}  // namespace cumuli
