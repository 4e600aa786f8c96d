#include "cumuli/anim/endless.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "cumuli/candidates.hpp"
#include "cumuli/parallel.hpp"

namespace cumuli {

namespace {

// The cloud at frame t: radii grown linearly, centres moved by the common drift plus each
// primitive's own drift, then shifted by −wind·t so that evaluating at p − wind·t samples the
// original shape at p and the noise at p − wind·t (the noise domain moves with the wind).
CloudShape frame_cloud(const CloudShape& cloud, const EvolutionParams& p,
                       const std::vector<glm::vec3>& own, int t, bool noise_frame) {
  CloudShape c = cloud;
  const float s = p.frames > 1 ? 1.0f + p.growth * static_cast<float>(t) / (p.frames - 1) : 1.0f;
  const float tf = static_cast<float>(t);
  for (std::size_t j = 0; j < c.primitives.size(); ++j) {
    auto& e = c.primitives[j];
    e.radii *= s;
    e.centre += tf * (p.drift + own[j]);
    if (noise_frame) e.centre -= tf * p.wind;
  }
  // r̄² follows the growth so metaball densities keep their meaning.
  c.density.mean_r2 = c.mean_squared_radius();
  return c;
}

std::vector<glm::vec3> own_drifts(const CloudShape& cloud, const EvolutionParams& p) {
  std::vector<glm::vec3> out(cloud.primitives.size(), glm::vec3(0.0f));
  for (std::size_t j = 0; j < out.size(); ++j) {
    Rng rng = Rng::stream(p.seed, j);
    const glm::vec3 v(static_cast<float>(rng.normal()), static_cast<float>(rng.normal()),
                      static_cast<float>(rng.normal()));
    out[j] = p.jitter * v;
  }
  return out;
}

void check_params(const EvolutionParams& p) {
  if (p.frames < 1) throw std::invalid_argument("n_frames must be >= 1");
  if (p.res_x < 1 || p.res_y < 1 || p.res_z < 1)
    throw std::invalid_argument("resolution must be >= 1 on every axis");
  if (!(p.growth > -1.0f) || !std::isfinite(p.growth))
    throw std::invalid_argument("growth must be finite and > -1");
  if (!std::isfinite(p.jitter) || p.jitter < 0.0f)
    throw std::invalid_argument("jitter must be finite and >= 0");
  if (!(p.density_scale >= 0.0f) || !std::isfinite(p.density_scale))
    throw std::invalid_argument("density_scale must be finite and >= 0");
  if (!(p.padding >= 0.0f) || !std::isfinite(p.padding))
    throw std::invalid_argument("padding must be finite and >= 0");
}

}  // namespace

Box evolving_cloud_box(const CloudShape& cloud, const EvolutionParams& params) {
  check_params(params);
  cloud.validate();
  const auto own = own_drifts(cloud, params);
  Box b = frame_cloud(cloud, params, own, 0, false).bounds();
  const Box last = frame_cloud(cloud, params, own, params.frames - 1, false).bounds();
  b.lo = glm::min(b.lo, last.lo);
  b.hi = glm::max(b.hi, last.hi);
  const glm::vec3 pad = params.padding * (b.hi - b.lo);
  b.lo -= pad;
  b.hi += pad;
  return b;
}

std::vector<float> evolving_cloud_volumes(const CloudShape& cloud, const DensitySource& source,
                                          const EvolutionParams& params, const Box& box,
                                          int threads) {
  check_params(params);
  cloud.validate();
  if (!(box.hi.x > box.lo.x && box.hi.y > box.lo.y && box.hi.z > box.lo.z))
    throw std::invalid_argument("box_max must be greater than box_min on every axis");
  const auto own = own_drifts(cloud, params);
  std::vector<CloudShape> frames;
  frames.reserve(static_cast<std::size_t>(params.frames));
  for (int t = 0; t < params.frames; ++t)
    frames.push_back(frame_cloud(cloud, params, own, t, true));

  const int W = params.res_x, H = params.res_y, D = params.res_z;
  const glm::vec3 step = (box.hi - box.lo) / glm::vec3(W, H, D);
  const std::size_t rows = static_cast<std::size_t>(params.frames) * D * H;
  std::vector<float> out(rows * static_cast<std::size_t>(W), 0.0f);
  const int capacity = static_cast<int>(cloud.primitives.size());
  const bool metaball = cloud.density.model == DensityModel::Metaball;

  parallel_chunks(rows, threads, [&](std::size_t begin, std::size_t end) {
    std::vector<Candidate> cand(static_cast<std::size_t>(capacity));
    for (std::size_t row = begin; row < end; ++row) {
      const int t = static_cast<int>(row / (static_cast<std::size_t>(D) * H));
      const int z = static_cast<int>((row / H) % D);
      const int y = static_cast<int>(row % H);
      const CloudShape& c = frames[static_cast<std::size_t>(t)];
      const glm::vec3 shift = static_cast<float>(t) * params.wind;
      // One ray along +x per row, in the noise frame (see frame_cloud).
      const glm::vec3 origin =
          glm::vec3(box.lo.x, box.lo.y + (y + 0.5f) * step.y, box.lo.z + (z + 0.5f) * step.z) -
          shift;
      const int count = collect_candidates(c, origin, glm::vec3(1, 0, 0), 0.0f, box.hi.x - box.lo.x,
                                           cand.data(), capacity);
      float* dst = out.data() + row * static_cast<std::size_t>(W);
      for (int x = 0; x < W; ++x) {
        const float tx = (x + 0.5f) * step.x;
        const glm::vec3 p = origin + glm::vec3(tx, 0.0f, 0.0f);
        float rho = 0.0f;
        for (int k = 0; k < count; ++k) {
          if (cand[k].t_in > tx) break;  // sorted by t_in: the rest start further on
          if (cand[k].t_out < tx) continue;
          rho = std::max(rho, cloud_density(c, cand[k].primitive, p, source).rho);
          if (metaball) break;  // the metaball field does not depend on the candidate
        }
        dst[x] = rho * params.density_scale;
      }
    }
  });
  return out;
}

void similarity_matrix(const float* volumes, int n, std::size_t voxels, double* out, int threads) {
  if (n < 1) throw std::invalid_argument("the database needs at least one volume");
  const std::size_t nn = static_cast<std::size_t>(n);
  std::vector<std::pair<int, int>> pairs;
  pairs.reserve(nn * (nn - 1) / 2);
  for (int k = 0; k < n; ++k)
    for (int l = k + 1; l < n; ++l) pairs.emplace_back(k, l);
  std::vector<double> sums(pairs.size(), 0.0);
  // Tiles of voxels keep the n volumes' current tiles in cache while every pair uses them; each
  // pair still sums its tiles in order, so the result does not depend on the thread split.
  constexpr std::size_t kTile = 4096;
  parallel_chunks(pairs.size(), threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t t0 = 0; t0 < voxels; t0 += kTile) {
      const std::size_t t1 = std::min(voxels, t0 + kTile);
      for (std::size_t i = begin; i < end; ++i) {
        const float* a = volumes + static_cast<std::size_t>(pairs[i].first) * voxels;
        const float* b = volumes + static_cast<std::size_t>(pairs[i].second) * voxels;
        double s = 0.0;
        for (std::size_t v = t0; v < t1; ++v) {
          const double diff = static_cast<double>(a[v]) - static_cast<double>(b[v]);
          s += diff * diff;
        }
        sums[i] += s;
      }
    }
  });
  for (std::size_t i = 0; i < nn * nn; ++i) out[i] = 0.0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    out[pairs[i].first * nn + pairs[i].second] = sums[i];
    out[pairs[i].second * nn + pairs[i].first] = sums[i];
  }
}

namespace {

// The paper's exponent for "after k show l": D_{k+1,l}; for the last frame D_{k,l−1} (see header).
double transition_cost(const double* d, int n, int k, int l) {
  if (k + 1 < n) return d[static_cast<std::size_t>(k + 1) * n + l];
  if (l >= 1) return d[static_cast<std::size_t>(k) * n + (l - 1)];
  return std::numeric_limits<double>::infinity();
}

// Row k of exp(−(cost − min cost)/σ) over the l with keep(l), normalised; false if none kept.
template <class Keep>
bool fill_row(const double* d, int n, int k, double sigma, Keep keep, double* row) {
  double lo = std::numeric_limits<double>::infinity();
  for (int l = 0; l < n; ++l) {
    row[l] = 0.0;
    if (keep(l)) lo = std::min(lo, transition_cost(d, n, k, l));
  }
  if (!std::isfinite(lo)) return false;
  double sum = 0.0;
  for (int l = 0; l < n; ++l) {
    if (!keep(l)) continue;
    const double c = transition_cost(d, n, k, l);
    if (!std::isfinite(c)) continue;
    row[l] = std::exp(-(c - lo) / sigma);
    sum += row[l];
  }
  for (int l = 0; l < n; ++l) row[l] /= sum;
  return true;
}

void check_similarity(const double* d, int n, double sigma) {
  if (n < 1) throw std::invalid_argument("the database needs at least one volume");
  if (!(sigma > 0.0) || !std::isfinite(sigma))
    throw std::invalid_argument("sigma must be finite and > 0");
  for (std::size_t i = 0; i < static_cast<std::size_t>(n) * n; ++i)
    if (!(d[i] >= 0.0) || !std::isfinite(d[i]))
      throw std::invalid_argument("similarity must be finite and >= 0");
}

}  // namespace

std::vector<double> transition_matrix(const double* d, int n, double sigma) {
  check_similarity(d, n, sigma);
  std::vector<double> p(static_cast<std::size_t>(n) * n, 0.0);
  if (n == 1) {
    p[0] = 1.0;
    return p;
  }
  for (int k = 0; k < n; ++k)
    fill_row(d, n, k, sigma, [](int) { return true; }, p.data() + static_cast<std::size_t>(k) * n);
  return p;
}

float crossfade_weight(int step, int frames) {
  return 1.0f - static_cast<float>(step + 1) / static_cast<float>(frames + 1);
}

bool EndlessWalk::allowed(int c, int l) const {
  if (l == c + 1) return l < n_;                    // the natural successor
  if (h_ == 0) return c + 1 < n_ || l >= 1;         // a cut (the last frame cannot cut to frame 0)
  return c + h_ <= n_ - 1 && l + h_ - 1 <= n_ - 1;  // both cross-dissolve windows exist
}

EndlessWalk::EndlessWalk(const double* d, int n, double sigma, int crossfade, std::uint64_t seed,
                         int start)
    : n_(n), h_(crossfade), rng_(seed), current_(start) {
  check_similarity(d, n, sigma);
  if (crossfade < 0) throw std::invalid_argument("crossfade_frames must be >= 0");
  if (start < 0 || start >= n) throw std::invalid_argument("start must be a frame of the database");
  const std::size_t nn = static_cast<std::size_t>(n);
  // Prune dead ends: repeat until every remaining frame has an allowed move to a remaining frame.
  live_.assign(nn, 1);
  for (bool changed = true; changed;) {
    changed = false;
    for (int c = 0; c < n; ++c) {
      if (!live_[c]) continue;
      bool ok = false;
      for (int l = 0; l < n && !ok; ++l) {
        if (!allowed(c, l)) continue;
        const int s = l == c + 1 ? l : landing(l);
        ok = live_[static_cast<std::size_t>(s)] != 0 && std::isfinite(transition_cost(d, n, c, l));
      }
      if (!ok) {
        live_[c] = 0;
        changed = true;
      }
    }
  }
  if (std::none_of(live_.begin(), live_.end(), [](unsigned char v) { return v != 0; }))
    throw std::invalid_argument(
        "no endless walk exists: the database is too short for crossfade_frames (it needs at "
        "least max(2, 2·crossfade_frames) volumes)");
  if (!live_[static_cast<std::size_t>(start)])
    throw std::invalid_argument("start is a dead-end frame (every path from it reaches the end)");
  p_.assign(nn * nn, 0.0);
  for (int c = 0; c < n; ++c) {
    if (!live_[c]) continue;
    fill_row(
        d, n, c, sigma,
        [&](int l) {
          if (!allowed(c, l)) return false;
          const int s = l == c + 1 ? l : landing(l);
          return live_[static_cast<std::size_t>(s)] != 0;
        },
        p_.data() + static_cast<std::size_t>(c) * n);
  }
}

AnimationFrame EndlessWalk::next() {
  if (!started_) {
    started_ = true;
    return {current_, current_, 1.0f, false};
  }
  if (fade_step_ < 0) {
    // Draw l from row `current_` by inverting the cumulative sum (fixed order: reproducible).
    const double* row = p_.data() + static_cast<std::size_t>(current_) * n_;
    const double u = rng_.uniform_double();
    int l = -1;
    double acc = 0.0;
    for (int i = 0; i < n_; ++i) {
      if (row[i] <= 0.0) continue;
      acc += row[i];
      l = i;
      if (u < acc) break;
    }
    if (l == current_ + 1 || h_ == 0) {
      current_ = l;
      return {l, l, 1.0f, false};
    }
    fade_step_ = 0;
    fade_source_ = current_ + 1;
    fade_target_ = l;
  }
  const int t = fade_step_;
  const AnimationFrame f{fade_source_ + t, fade_target_ + t, crossfade_weight(t, h_), true};
  if (++fade_step_ == h_) {
    fade_step_ = -1;
    current_ = fade_target_ + h_ - 1;
  }
  return f;
}

void blend_volumes(const float* a, const float* b, float w, float* out, std::size_t count,
                   int threads) {
  const float v = 1.0f - w;
  parallel_chunks(count, threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      // Two products then a sum, each rounded (no FMA), as numpy computes it.
      const float x = w * a[i];
      const float y = v * b[i];
      out[i] = x + y;
    }
  });
}

}  // namespace cumuli
