// Seed-and-box billboard clouds (Torchelsen & Musse 2005, §3.1–3.2, eq. (1)).
//
// A seed box S with reproduction directions D_i (full cone apertures θ_i) grows child boxes over
// L levels: B = S + l·ρ·λ·R̂ (eq. (1) with ‖R‖ = ρ ∈ (0, 1] and the reach λ converting to world
// units), R̂ uniform on the spherical cap of half-angle θ_i/2 about D̂_i. Every box (seed boxes
// included) is then filled with a random number of camera-facing billboards at uniform positions.
//
// Random numbers: the boxes of seed box j come from Rng::stream(seed, j), the billboards of box k
// from Rng::stream(seed, 2³² + k); so the result is bit-identical for a seed whatever the thread
// count, and a variant v of basis model b uses the seed variant_seed(sky_seed, b, v).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "cumuli/primitives.hpp"

namespace cumuli {

// Limits per cloud (spec §10), checked against the worst case before anything is generated.
constexpr std::size_t kMaxSeedBoxes = 1024;
constexpr std::size_t kMaxCloudBoxes = std::size_t{1} << 16;
constexpr std::size_t kMaxCloudBillboards = std::size_t{1} << 20;
constexpr int kMaxLevels = 16;
constexpr int kMaxDirections = 64;
constexpr int kMaxBoxesPerLevel = 64;
constexpr int kMaxBillboardsPerBox = 256;
constexpr int kMaxTextures = 4096;

// How the number of boxes of a level is drawn ([TM] is ambiguous; spec §2.1 [decision]).
enum class CountPer {
  Direction,  // one count in [n_min, n_max] per (level, direction)   (default)
  Level,      // one count per level; each box picks its direction uniformly
};

// One seed box and its reproduction parameters.
struct SeedBoxParams {
  glm::vec3 centre{0.0f};
  glm::vec3 half_size{4.0f, 1.5f, 3.0f};
  std::vector<glm::vec3> directions;         // D_i, any length > 0 (normalised here)
  std::vector<float> apertures;              // θ_i, full cone apertures in degrees, [0, 360]
  int levels = 3;                            // L
  int boxes_min = 1, boxes_max = 3;          // [n_min, n_max]
  float reach = 0.0f;                        // λ in world units; 0 = ‖half_size‖
  float child_min = 1.0f, child_max = 1.0f;  // child half-size = s·half_size, s ∈ [min, max]
  int billboards_min = 4, billboards_max = 8;
  CountPer count_per = CountPer::Direction;
  bool flat_base = false;  // shift boxes (and billboards) up so none extends below S.y − h.y

  void validate() const;  // throws std::invalid_argument naming the bad parameter
  float effective_reach() const;
  // Most boxes this seed box can produce (the seed box included).
  std::uint64_t max_boxes() const;
};

// Billboard placement shared by every box of a cloud (spec §3).
struct BillboardParams {
  float size_min = 0.8f, size_max = 1.4f;  // width = U[size_min, size_max] · mean box half size
  float aspect_min = 1.0f;                 // height/width uniform in [aspect_min, 1]
  std::vector<int> textures{0};            // atlas indices, one drawn uniformly per billboard
  bool rotate = true;                      // rotation uniform in [0°, 360°), else 0
  float min_spacing = 0.0f;                // > 0: drop billboards closer than this to a kept one
  bool ellipsoid = false;                  // positions uniform in the box's inscribed ellipsoid

  void validate() const;
};

// The generated cloud: boxes (seed boxes first) and billboards.
struct BillboardCloudData {
  std::vector<Box> boxes;
  std::vector<int> box_level, box_seed, box_direction;  // direction −1 for seed boxes
  std::vector<glm::vec3> centres;                       // billboard centres (world)
  std::vector<glm::vec2> sizes;                         // (width, height)
  std::vector<int> texture, box;
  std::vector<float> rotation;       // degrees about the view axis
  std::vector<int> boxes_per_level;  // index = level (0 = seed boxes)
  std::size_t billboards_drawn = 0;  // before the min_spacing filter
  std::size_t dropped_by_spacing = 0;
};

// Worst-case (boxes, billboards) of a parameter set; the generator refuses sets beyond the limits.
void worst_case_counts(const std::vector<SeedBoxParams>& seeds, std::uint64_t& boxes,
                       std::uint64_t& billboards);

// Validates everything and checks the worst case against kMaxCloudBoxes / kMaxCloudBillboards
// (std::invalid_argument naming the parameter otherwise).
void validate_seed_box_cloud(const std::vector<SeedBoxParams>& seeds, const BillboardParams& bb);

// Generates one cloud. Output order: seed boxes in the given order, then the children of each
// seed box in (seed, level, direction, m) order (count_per = Level: (seed, level, m)); billboards
// in box order.
BillboardCloudData seed_box_cloud(const std::vector<SeedBoxParams>& seeds,
                                  const BillboardParams& bb, std::uint64_t seed, int threads);

// The generator seed of variant v of basis model b in a sky seeded with `seed` (spec §2.2):
// Rng::stream(seed, b·2¹⁶ + v).
std::uint64_t variant_seed(std::uint64_t seed, std::uint64_t basis, std::uint64_t variant);

// The fixed frame (e₁, e₂) ⟂ d̂ used for the cone draws (spec §2.1), d̂ normalised.
void cone_frame(const glm::dvec3& d, glm::dvec3& e1, glm::dvec3& e2);

}  // namespace cumuli
