// CPU reference ray marcher: the render pass of Jiménez de Parga & Gómez Palomo 2018
// (Algorithms 1 and 3), made exact by RENDER_CONTRACT so that it agrees with the GLSL marcher.
//
// Per pixel: a camera ray; clouds whose (candidate-grown) box the ray hits are marched front to
// back by box entry; each cloud's sorted candidate intervals (collect_candidates) are marched with
// the LOD step, either every interval on its own as the paper does (overlaps twice, "paper") or
// their union once ("union"); every sample adds (1 − Δτ)(aL + sL)·T and attenuates T; finally
// the sky shows through what is left of T. Everything is float32, like the shader.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "cumuli/candidates.hpp"
#include "cumuli/model/cloud.hpp"
#include "cumuli/noise.hpp"
#include "cumuli/phase.hpp"
#include "cumuli/primitives.hpp"
#include "cumuli/rendering/ground.hpp"
#include "cumuli/rendering/occupancy.hpp"
#include "cumuli/rendering/physical.hpp"
#include "cumuli/rendering/solids.hpp"

namespace cumuli {

// A cloud's precomputed light grid L(v) and the world box it spans.
struct LightGrid {
  std::vector<float> values;  // [z][y][x], nx·ny·nz floats
  int nx = 0, ny = 0, nz = 0;
  Box box;

  // Trilinear lookup at world point p with the GL texel-centre convention and clamp-to-edge:
  // texel (i, j, k) sits at box.lo + ((i, j, k) + 0.5)·(hi − lo)/R, like a LINEAR /
  // CLAMP_TO_EDGE 3D texture sampled at (p − lo)/(hi − lo).
  float sample(glm::vec3 p) const;
  void validate() const;  // throws std::invalid_argument
};

struct RenderCloud {
  CloudShape shape;
  LightGrid light;         // the paper mode's light
  PhysicalGrids physical;  // the physical mode's light
};

enum class MarchMode { Paper, Union };

struct CameraParams {
  glm::vec3 position{0.0f, 0.0f, -10.0f};
  glm::vec3 target{0.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  float fov = 50.0f;  // vertical field of view, degrees

  void validate() const;  // throws std::invalid_argument
};

// A camera and the image it takes: what the CPU renderers of whole images are given.
struct Viewport {
  CameraParams camera;
  int width = 1, height = 1;

  static constexpr int kMaxEdge = 1 << 15;
  static constexpr long long kMaxPixels = 1LL << 26;

  // Throws std::invalid_argument: edges outside [1, kMaxEdge], more than kMaxPixels pixels, or
  // a bad camera.
  void validate() const;
};

// The camera's frame, computed once per image.
struct CameraRays {
  glm::vec3 origin, forward, right, up;
  float tan_half = 0.0f, aspect = 1.0f;
  int width = 1, height = 1;

  CameraRays(const CameraParams& camera, int width, int height);
  // Unit direction through pixel (row, col), row 0 at the top.
  glm::vec3 direction(int row, int col) const;
};

// The image cut into square tiles of pixels, and the cone of each tile's camera rays: the
// marcher's candidate fans sort their primitives into one bin per tile (CandidateFan::bin), so
// that a ray tests only the primitives whose cull cone meets its tile's (on a 128-primitive
// L-system cloud framed by the camera, every ray tested all 128 and kept a few). Tiles are 8
// pixels square, larger until there are at most kMaxTiles (binning costs tiles × primitives).
class ScreenTiles {
 public:
  static constexpr long kMaxTiles = 512;
  explicit ScreenTiles(const CameraRays& rays);
  const std::vector<DirectionCone>& cones() const { return cones_; }
  int tile_of(int row, int col) const { return (row / size_) * cols_ + col / size_; }

 private:
  int count(int pixels) const { return (pixels + size_ - 1) / size_; }
  int size_ = 8;
  int cols_ = 1;
  std::vector<DirectionCone> cones_;
};

struct MarchSettings {
  float absorption = 1.0f;  // φ_s of Δτ = exp(−φ_s·ρ·Δ/Δ_ref)
  float lod_a = 0.1f;       // A of the LOD step
  float lod_delta = 0.0f;   // δ of the LOD step
  float ref_step = 0.1f;    // Δ_ref
  float step_min = 0.01f;
  float step_max = 1.0f;
  float fixed_step = 0.0f;  // > 0 overrides the LOD step
  float hg_g = 0.5f;
  int max_steps = 4096;     // samples per pixel, all clouds together
  int max_candidates = 64;  // candidates kept per cloud and ray
  MarchMode march = MarchMode::Paper;
  // Order candidates by t_in (ties: primitive index), as every GL candidate_sort but "none" does;
  // false leaves them unsorted like the GL "none" variant.
  bool sort_candidates = true;
  FbmParams fbm;
  float density_constant = -1.0f;  // ≥ 0: constant density instead of fBm (analytic tests)
  // The physical lighting mode (RENDER_CONTRACT "Physical lighting"): union marching with a
  // jittered start, σ = extinction_scale·ρ, physical.hpp's shading; `absorption`, `hg_g` and
  // `march` are then not used.
  bool physical = false;
  PhysicalParams phys;
  // The paper mode's early exit: the ray stops once T < min_transmittance (the physical mode's
  // is phys.min_transmittance). 1e-6 is the paper's exit.
  float min_transmittance = 1e-6f;
  // Empty-space skipping (occupancy.hpp): samples in cells of a cloud's occupancy grid that
  // cannot hold density are passed over without evaluating the density. They still count as
  // steps and keep the sample lattice, so the image is the same bit for bit.
  bool skip_empty = false;
  // The paper mode's samples at ξ·Δ into their step (ξ = jitter(row, col, phys.jitter_seed))
  // instead of Δ/2: turns the step rings of near-opaque clouds into a fine pattern. The physical
  // mode always jitters.
  bool jitter = false;

  static constexpr int kMaxStepsLimit = 1 << 24;
  static constexpr int kMaxCandidatesLimit = 4096;

  void validate() const;  // throws std::invalid_argument naming the setting
  // Δ for a cloud centred at `centre` seen from `eye`.
  float step_for(glm::vec3 eye, glm::vec3 centre) const;
};

// Everything one render needs, read-only while the threads run.
struct MarchScene {
  std::vector<RenderCloud> clouds;
  SunParams sun;
  SkyParams sky;
  const Noise* noise = nullptr;  // may be null only when settings.density_constant ≥ 0
  // false: no sky behind the clouds, output (colour, 1 − T), a premultiplied layer for the
  // compositor (rendering/compositor.hpp).
  bool with_sky = true;
  // Opaque solids (rendering/solids.hpp, Harris 2002 §3.1.1): each ray is marched only up to the
  // nearest solid it meets, t_s — intervals are clipped to t < t_s and a sample whose midpoint lies
  // at or beyond t_s is not taken — so the layer holds exactly the cloud in front of the solid
  // ("march each ray only up to the object's depth"). Empty: no clipping.
  std::vector<SolidSphere> solids;
  GroundParams ground;  // the background below the horizon when enabled

  void validate(const MarchSettings& settings) const;
};

// Work statistics of one render: counted per pixel, so the totals do not
// depend on the thread count. Counting never changes the image.
struct MarchStats {
  std::uint64_t fbm_evaluations = 0;  // fBm evaluations of the density (eq. 1)
  std::uint64_t steps = 0;            // samples marched (empty ones and skipped ones included)
  std::uint64_t skipped = 0;          // samples passed over by empty-space skipping
};

// The (height, width, 4) float32 RGBA image, row 0 at the top, on `threads` threads (0 = all).
// The result does not depend on the thread count. `out` holds height·width·4 floats. When
// `stats` is given it receives the totals, and `fbm_map` (height·width counts, if given) the
// fBm evaluations of each pixel.
void render_image(const MarchScene& scene, const MarchSettings& settings,
                  const CameraParams& camera, int width, int height, float* out, int threads,
                  MarchStats* stats = nullptr, std::uint32_t* fbm_map = nullptr);

// As render_image, for a list of `count` pixels of the (height, width) image: `pixels` holds
// (row, column) pairs, `out` receives count·4 floats (pixel k's RGBA at 4k) and `fbm_map`
// count values. The physical mode's edge pass marches its outline's sub-pixels so, without an
// image twice the size that is mostly zeros. Throws std::invalid_argument for a pixel outside.
void render_pixels(const MarchScene& scene, const MarchSettings& settings,
                   const CameraParams& camera, int width, int height, const std::int32_t* pixels,
                   std::size_t count, float* out, int threads, MarchStats* stats = nullptr,
                   std::uint32_t* fbm_map = nullptr);

// The physical mode's edge pass (cumuli.rendering.edges): the outline's pixels, those whose 3×3
// neighbourhood's coverage spans more than `range`, marched again at `rays` (row, column
// offsets) of their sub × sub sub-pixels in the image `sub` times the size, and set to the mean.
struct EdgePass {
  float range = 0.1f;
  int sub = 2;
  std::vector<std::pair<int, int>> rays;
  std::size_t max_rays = 0;  // an outline needing more rays keeps the image as it is
  int max_sub_edge = 0;      // likewise an image whose sub-sampled edge is longer

  void validate() const;  // throws std::invalid_argument
};

// render_image followed by the edge pass in one call: the occupancy grids and candidate fans
// are built once for both marches, and the result equals render_image, coverage_edges and
// render_pixels of the sub-pixels with their mean taken in double (the two-call route of the
// compositor). Returns whether the pass ran; `mask` (height·width bytes) then holds 1 at the
// outline's pixels (otherwise it is all 0). Stats and fbm_map include the sub-pixels' work,
// each added to the pixel it lies in.
bool render_image_with_edges(const MarchScene& scene, const MarchSettings& settings,
                             const CameraParams& camera, int width, int height, float* out,
                             int threads, const EdgePass& pass, std::uint8_t* mask,
                             MarchStats* stats = nullptr, std::uint32_t* fbm_map = nullptr);

}  // namespace cumuli
