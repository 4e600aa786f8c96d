// Endless cloud animation from a database of volumes (Iwasaki, Nishino & Dobashi 2011, §2).
//
// A database holds N successive density volumes [z][y][x] over one world box. Video Textures
// (Schödl et al. 2000) extended to volumes: the similarity D_kl = Σ_n (ρ_k − ρ_l)², the next
// volume after k is l with probability P_kl ∝ exp(−D_{k+1,l} / σ), and a jump cross-dissolves
// over H frames (ρ = w ρ_i + (1 − w) ρ_j). This header also holds a generator that makes such a
// database without a fluid solver: a cumulus whose primitives grow and drift while the noise
// domain is advected, voxelised frame by frame.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "cumuli/model/cloud.hpp"
#include "cumuli/primitives.hpp"
#include "cumuli/rng.hpp"

namespace cumuli {

// How a cumulus evolves over the frames of a generated database (all rates are per frame).
struct EvolutionParams {
  int frames = 16;
  int res_x = 32, res_y = 32, res_z = 32;  // voxels along x, y, z
  float growth = 0.3f;         // radii at the last frame are (1 + growth) × the first ones
  glm::vec3 drift{0.0f};       // translation of the whole cloud per frame (world units)
  float jitter = 0.0f;         // per-primitive random drift speed (world units per frame)
  glm::vec3 wind{0.0f};        // noise-domain advection per frame (world units)
  float density_scale = 1.0f;  // multiplies every density
  float padding = 0.05f;       // box padding as a fraction of the extent (automatic box)
  std::uint64_t seed = 0;      // draws the per-primitive drift directions
};

// The world box that holds the cloud at every frame (growth and drift are linear in the frame,
// so the union of the first and last frames' bounds holds them all), padded.
Box evolving_cloud_box(const CloudShape& cloud, const EvolutionParams& params);

// Voxelise the evolving cloud: frames × res_z × res_y × res_x floats, voxel centres at
// box.lo + (i + ½)·size/res. Each x-row is one ray through the sorted candidates
// (collect_candidates), and a voxel takes the largest cloud_density over the candidates that
// contain it. Independent of the thread count.
std::vector<float> evolving_cloud_volumes(const CloudShape& cloud, const DensitySource& source,
                                          const EvolutionParams& params, const Box& box,
                                          int threads);

// D_kl = Σ_n (ρ_k(x_n) − ρ_l(x_n))² for all pairs of `n` volumes of `voxels` floats each, into an
// n×n row-major matrix. Sums in double, in a fixed order per pair: symmetric with a zero
// diagonal and independent of the thread count.
void similarity_matrix(const float* volumes, int n, std::size_t voxels, double* out, int threads);

// The paper's transition matrix: P_kl = exp(−D_{k+1,l}/σ) / Σ_l exp(−D_{k+1,l}/σ) (rows sum to
// 1). The last frame has no successor to compare with, so its row uses the equivalent
// predecessor form: go to l when l's predecessor resembles the last frame,
// P_{N−1,l} ∝ exp(−D_{N−1,l−1}/σ) for l ≥ 1 (and P_{N−1,0} = 0). One volume: P = [[1]].
std::vector<double> transition_matrix(const double* d, int n, double sigma);

// One displayed frame: density = weight·ρ_source + (1 − weight)·ρ_target.
struct AnimationFrame {
  int source = 0;
  int target = 0;
  float weight = 1.0f;
  bool crossfade = false;  // part of a cross-dissolve
};

// The cross-dissolve weight of step t (0-based) of H: w = 1 − (t + 1)/(H + 1), so the H frames
// lie strictly between the pure source (w = 1) and the pure target (w = 0).
float crossfade_weight(int step, int frames);

// A random walk on the database (Video Textures' Markov chain) that never dead-ends.
//
// From the current frame c, the next volume l is drawn from row c of the walk matrix. l = c + 1
// is the natural successor (shown as is). Any other l is a jump: with H = 0 it is a cut to l;
// with H ≥ 1 the H frames w·ρ_{c+1+t} + (1 − w)·ρ_{l+t} (t = 0..H−1) are shown and the walk
// continues from l + H − 1. This is the paper's cross-dissolve of the windows i = k−H+1..k,
// j = l−H+1..l with the indices named from the start of the windows. A jump needs both windows
// inside the database. Video Textures' dead ends (the last frame, and frames from which every
// path runs into it) are removed by pruning: a frame is live when it has an allowed transition to
// a live frame; the walk matrix keeps only those transitions, weighted as the paper's P (the
// exponent shifted by the row's smallest D so that the best choice never underflows), and rows
// renormalised. Dead frames get an all-zero row and are never visited.
class EndlessWalk {
 public:
  EndlessWalk(const double* d, int n, double sigma, int crossfade, std::uint64_t seed, int start);

  // The next frame to show; the first call returns the start frame.
  AnimationFrame next();

  int size() const { return n_; }
  int current() const { return current_; }
  const std::vector<double>& matrix() const { return p_; }
  const std::vector<unsigned char>& live() const { return live_; }

 private:
  int landing(int l) const { return h_ == 0 ? l : l + h_ - 1; }
  bool allowed(int c, int l) const;

  int n_;
  int h_;
  std::vector<double> p_;
  std::vector<unsigned char> live_;
  Rng rng_;
  int current_;
  bool started_ = false;
  int fade_step_ = -1;  // ≥ 0 while cross-dissolving
  int fade_source_ = 0, fade_target_ = 0;
};

// out = w·a + (1 − w)·b over `count` floats (the cross-dissolve of volumes, optical depths or
// any per-voxel field), on `threads` threads.
void blend_volumes(const float* a, const float* b, float w, float* out, std::size_t count,
                   int threads);

}  // namespace cumuli
