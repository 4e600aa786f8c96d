// Billboard-cloud lighting (Torchelsen & Musse 2005, §3.2, Figs. 6–7, 9): the light-absorption
// factor "CAF" by ray casting through the cloud's boxes, and the per-vertex colour ambient + CAF ·
// directional term.
//
// CAF (§4.1). From a sample point x (a box centre, or a billboard centre) a ray x + t·s, t ≥ 0,
// runs towards the (directional) sun s. With [t_in, t_out] the slab-test span of box b′:
//
//   L = Σ_b′ |[t_in, t_out] ∩ [0, ∞)|        overlap = Sum   ([TM]'s "sum of the red lines")
//   L = |∪_b′ ([t_in, t_out] ∩ [0, ∞))|      overlap = Union (each point of space once)
//   CAF = clamp(1 − L/D_max, 0, 1)            curve = Linear
//   CAF = exp(−3·L/D_max)                     curve = Exp    (Beer–Lambert; CAF(D_max) ≈ 0.05)
//
// The box owning x is skipped when include_self is false. D_max = ∞ gives CAF ≡ 1. Sums are
// formed in double over the hit boxes in index order (union: spans sorted by start), so the
// result does not depend on the candidate search (brute force or the uniform grid) nor on the
// thread count.
//
// Directional term and colour (§4.2), per shading point v (a billboard corner, or a pixel's
// point on the billboard in fragment mode), c_C the centre of the cloud's box AABB:
//
//   cos φ = dot(normalize(v − c_C), s_ℓ)   (0 when |v − c_C| < 1e−6·R_C)
//   D_ℓ   = d_min + (d_max − d_min)·((1 + cos φ)/2)^k_dir                 (Linear)
//   D_ℓ   = d_min + (d_max − d_min)·smoothstep(−0.3, 0.3, cos φ)^k_dir   (Smoothstep, FlightGear)
//   colour = k_amb·ambient + H(f_v)·Σ_ℓ CAF_{b,ℓ}·D_ℓ·radiance_ℓ
//
// H is 1, or piecewise linear through the height_levels (f, h) at the vertex's height fraction
// f_v in the cloud's box AABB (Wang/CSPSim/FlightGear colour levels; beyond [TM]).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "cumuli/primitives.hpp"

namespace cumuli {

enum class Overlap { Sum, Union };
enum class CafCurve { Linear, Exp };
enum class Directional { Linear, Smoothstep };

// One box's span along a ray, tagged with the box index (for the ordered sum).
struct Span {
  std::uint32_t box;
  double t0, t1;
};

// Boxes with a uniform grid for ray queries (built when there are more than kBruteForceBoxes).
class BoxIndex {
 public:
  static constexpr std::size_t kBruteForceBoxes = 64;
  static constexpr std::size_t kMaxCells = std::size_t{1} << 21;

  explicit BoxIndex(std::vector<Box> boxes);

  const std::vector<Box>& boxes() const { return boxes_; }
  std::size_t size() const { return boxes_.size(); }

  // Per-thread scratch for queries.
  struct Scratch {
    std::vector<std::uint32_t> stamp;
    std::uint32_t tick = 0;
    std::vector<std::uint32_t> hits;
  };

  // Appends the spans [max(t_in, 0), t_out] (t_out > 0) of every box the ray o + t·d (t ≥ 0)
  // meets, except the boxes with index in [skip_lo, skip_hi), in increasing box index.
  void spans(glm::vec3 o, glm::vec3 d, std::size_t skip_lo, std::size_t skip_hi,
             std::vector<Span>& out, Scratch& scratch) const;

 private:
  void candidates(glm::vec3 o, glm::vec3 d, Scratch& scratch) const;

  std::vector<Box> boxes_;
  bool grid_ = false;
  Box bounds_;
  int dims_[3] = {1, 1, 1};
  glm::vec3 cell_{1.0f};
  std::vector<std::uint32_t> cell_start_;  // CSR: cell c holds cell_box_[cell_start_[c] ..)
  std::vector<std::uint32_t> cell_box_;
};

// L from spans: the ordered sum, or the length of their union.
double combine_spans(std::vector<Span>& spans, Overlap overlap);

// CAF of a path length (max_distance may be +inf: CAF = 1).
float caf_value(double length, double max_distance, CafCurve curve);

// Path lengths L towards unit `sun` for n points; owner[i] is the box owning point i (skipped
// unless include_self; −1: none).
void caf_path_lengths(const BoxIndex& index, const glm::vec3* points, const int* owner,
                      std::size_t n, glm::vec3 sun, Overlap overlap, bool include_self, double* out,
                      int threads);

// cos and sin of an angle in degrees, exact (0, ±1) at multiples of 90°.
void yaw_cos_sin(double degrees, double& c, double& s);

// Instances of cloud variants: world = R_y(yaw)·local + offset,
// R_y = [[c, 0, s], [0, 1, 0], [−s, 0, c]].
struct Instance {
  int variant = 0;
  glm::vec3 offset{0.0f};
  float yaw = 0.0f;  // degrees about +y
};

// Path lengths of every instance's sample points (variant points/owners, local frames), in
// instance order (instance i's block has the size of its variant's point list). The own cloud is
// traced exactly in its local frame (the sun rotated into it); with between_clouds the other
// instances' boxes (as world AABBs of their rotated boxes) are traced too, spans merged.
void field_path_lengths(const std::vector<BoxIndex>& variants,
                        const std::vector<std::vector<glm::vec3>>& points,
                        const std::vector<std::vector<int>>& owners,
                        const std::vector<Instance>& instances, glm::vec3 sun, Overlap overlap,
                        bool include_self, bool between_clouds, double* out, int threads);

// World AABB of a local box under an instance transform.
Box instance_box(const Box& local, const Instance& inst);

struct ShadeLight {
  glm::vec3 direction{0.0f, 1.0f, 0.0f};  // towards the light, unit
  glm::vec3 radiance{1.0f};
};

struct ShadeParams {
  float d_min = 0.25f, d_max = 1.0f, k_dir = 1.0f;
  Directional directional = Directional::Linear;
  glm::vec3 ambient{0.0f};
  float k_amb = 0.5f;
  std::vector<std::pair<float, float>> height_levels;  // (f, h) sorted by f; empty: H ≡ 1

  void validate() const;
};

// The cloud frame the directional term uses.
struct ShadeFrame {
  glm::vec3 centre{0.0f};  // c_C
  float radius = 1.0f;     // R_C: half-diagonal of the box AABB
  float y_lo = 0.0f, y_hi = 1.0f;
};

ShadeFrame shade_frame(const std::vector<Box>& boxes);

// D of one point for one light.
float directional_term(glm::vec3 v, const ShadeFrame& frame, glm::vec3 light,
                       const ShadeParams& params);

// H: 1 without height levels, else piecewise linear through them at y's fraction of the frame.
float height_factor(float y, const ShadeFrame& frame, const ShadeParams& params);

// The colour k_amb·ambient + H·Σ_ℓ caf[ℓ·stride]·D_ℓ(v)·radiance_ℓ of one point (what
// billboard_shade does per point, and the sprite rasteriser per pixel in fragment mode).
glm::vec3 shade_point(glm::vec3 v, const ShadeFrame& frame, const float* caf, std::size_t stride,
                      const std::vector<ShadeLight>& lights, const ShadeParams& params);

// Colours (n, 3) at points; caf is (lights × q) row-major and point i uses column index[i] (its
// box, or its billboard with per-billboard CAFs).
void billboard_shade(const glm::vec3* points, const int* index, std::size_t n, const float* caf,
                     std::size_t q, const ShadeFrame& frame, const std::vector<ShadeLight>& lights,
                     const ShadeParams& params, float* out, int threads);

// Camera-facing quad corners (n, 4, 3): v0 = p − ½w·r′ − ½h·u′, v1 = p + ½w·r′ − ½h·u′,
// v2 = p + ½w·r′ + ½h·u′, v3 = p − ½w·r′ + ½h·u′, with r′ = cos ρ·r + sin ρ·u and
// u′ = −sin ρ·r + cos ρ·u the camera's right/up turned by the billboard's rotation ρ.
void billboard_corners(const glm::vec3* centres, const glm::vec2* sizes, const float* rotation,
                       std::size_t n, glm::vec3 right, glm::vec3 up, float* out);

// [TM]'s per-vertex shading of n camera-facing billboards: the corners of billboard_corners for
// the camera's right/up, shaded by billboard_shade with column index[i] of caf for billboard i
// (its box, or itself with per-billboard CAFs). out: (n, 4, 3) colours in corner order;
// corners (optional, may be null): (n, 4, 3) positions.
void billboard_vertex_colours(const glm::vec3* centres, const glm::vec2* sizes,
                              const float* rotation, const int* index, std::size_t n,
                              const float* caf, std::size_t q, const ShadeFrame& frame,
                              const std::vector<ShadeLight>& lights, const ShadeParams& params,
                              glm::vec3 right, glm::vec3 up, float* out, float* corners,
                              int threads);

}  // namespace cumuli
