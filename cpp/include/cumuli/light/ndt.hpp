// Light pass: the per-cloud voxel grid of precomputed sun light (Jiménez de Parga & Gómez Palomo
// 2018, §3.3 and §3.5, eqs. 3–7, Algorithm 2 "no duplicate tracing").
//
// For each voxel centre v a ray leaves v towards the sun: p(t) = v + t·sun_dir, t ≥ 0. Its
// candidates are the cloud's primitives it meets (collect_candidates semantics: grown by
// candidate_scale, clipped to t ≥ 0, sorted by t_in). The ray is cut into segments
// [t_k, t_{k+1}] of length Δ (= step) starting at the t_in of the interval being marched; the last
// segment of an interval is truncated at its t_out, so the segments tile the marched intervals
// exactly (a constant density gives exactly Beer–Lambert over the chord). Sample i sits at the
// MIDPOINT of its segment, s_i = (t_k + t_{k+1}) / 2, and stands for the segment's length ℓ_i.
//
// Field (eqs. 3, 6, 7), samples numbered i = 1, 2, ... from v outwards (towards the sun):
//   σ_i = A · ρ_i                                 extinction, eq. (3) (ρ_i = 0 where not cloud)
//   T_i = Π_{k ≤ i} exp(−σ_k · ℓ_k)                transmittance from v to the far end of segment i
//   T_0 = 1, T_D = T_n (n = number of samples)
//   L(v) = Σ_{i : ρ_i > 0} C · (ℓ_i / Δ) · T_{i−1}  +  I₀ · T_D,    C = ½ · γ_solid / 4π  (eq. 6)
// T_{i−1} is the transmittance between v and the NEAR end of sample i's segment: light scattered
// forward at sample i is attenuated by everything between it and v, not by its own segment. The
// factor ℓ_i/Δ is 1 for every whole segment (exactly eq. 7's one term per step) and weights the
// truncated last segment of an interval by its length. Only cloud samples (ρ > 0) scatter: the
// candidate intervals of metaballs (grown by √N) are mostly empty space.
//
// Methods:
//  - Ndt (Algorithm 2): every point of the UNION of the candidate intervals is marched once. The
//    sorted candidates are merged into disjoint union intervals (a candidate whose t_out is behind
//    the current end is skipped, a gap is jumped to the next t_in), each marched as above. A
//    sample is attributed to the covering candidate (t_in ≤ s ≤ t_out) whose primitive gives the
//    smallest |q|, as RENDER_CONTRACT's march="union" (for metaballs attribution is irrelevant).
//  - Naive (the paper's baseline): every candidate interval is marched in full, in sorted order,
//    each sample attributed to its own candidate; overlaps are marched (and attenuate) twice.
// For pairwise disjoint primitives both give bit-identical fields.
//  - Shared: the samples of voxels on one sun-parallel line are shared. Each line of a
//    grid sheared along the sun (one line per voxel column of a layer) is marched once, as NDT
//    marches a ray (union intervals, attribution, gating), on a step Δ' ≈ Δ that puts a segment
//    boundary on every voxel layer; L at each layer crossing comes from one backward sweep, and a
//    voxel's L is the bilinear blend of the four lines around it on its layer. Not the per-voxel
//    definition: the difference (max and mean |ΔL| against Ndt) is measured by
//    benchmarks/bench_light.py and bounded in tests/light/test_light_grid_shared.py. `samples`
//    per voxel is then the count of samples its nearest line marched from the voxel's layer
//    towards the sun, and LightStats::samples the number actually marched (each once).
#pragma once

#include <cstdint>

#include <glm/vec3.hpp>

#include "cumuli/model/cloud.hpp"
#include "cumuli/primitives.hpp"

namespace cumuli {

enum class LightMethod { Ndt, Naive, Shared };

struct LightSettings {
  static constexpr int kMaxResolution = 256;  // per axis: 256³ voxels is already minutes of CPU
  // Longest march one ray may need, in steps (box diagonal / step); a smaller step is refused.
  static constexpr double kMaxStepsPerRay = 1 << 20;

  glm::vec3 sun_dir{0.0f, 1.0f, 0.0f};  // towards the sun; normalised by validate()
  int resolution[3] = {20, 20, 20};     // voxels along x, y, z
  float step = 0.1f;                    // Δ, world units
  float extinction = 0.3f;              // A of eq. (3): σ = ρ · A, per world unit (see light.py)
  float solid_angle = 1e-4f;            // γ of eq. (6), steradians
  float intensity = 1.0f;               // I₀
  LightMethod method = LightMethod::Ndt;
  int threads = 0;  // 0 = all cores

  // C = ½ · γ / 4π (eq. 6).
  float scatter_constant() const;
  // Throws std::invalid_argument naming the bad setting; `box` is the grid's world box.
  void validate(const Box& box) const;
};

// The world box the grid covers: the cloud's primitives grown by candidate_scale (as the
// candidates see them), padded by half a voxel on each side so that the centres of the first and
// last voxels lie on the faces of that box. Voxel (i, j, k)'s centre is
// lo + ((i, j, k) + 0.5) · (hi − lo) / (Rx, Ry, Rz). Needs resolution ≥ 2 on every axis.
Box light_grid_box(const CloudShape& cloud, const int resolution[3]);

struct LightStats {
  std::uint64_t samples = 0;  // samples marched, all voxels (empty-space samples included)
  double seconds = 0.0;       // wall time of the march (not of validation)
};

// Fills `light` (Rz·Ry·Rx floats, [z][y][x]) with L(v) and, when `samples` is not null, the
// number of samples marched for each voxel (same layout). The result does not depend on the
// thread count. Throws std::invalid_argument on bad settings or an invalid cloud.
LightStats compute_light_grid(const CloudShape& cloud, const DensitySource& density,
                              const LightSettings& settings, float* light, std::uint32_t* samples);

}  // namespace cumuli
