#include "cumuli/rendering/marcher.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>

#include "cumuli/parallel.hpp"
#include "cumuli/rendering/edges.hpp"

namespace cumuli {

// ---------------------------------------------------------------------------------------------
// The marcher

namespace {

// Per-cloud values that are the same for every ray of an image.
struct PreparedCloud {
  const RenderCloud* cloud;
  Box box;
  float step;
  const OccupancyGrid* occupancy;  // null without empty-space skipping
  float margin;                    // a thousandth of the smallest cell edge
  const CandidateFan* fan;         // the candidates of the camera's rays
};

// The physical camera ray's step multiple at view transmittance T_view: twice for each decade
// below `below` (PhysicalParams::coarsen_below), at most kMaxCoarsen; 1 when `below` is 0.
inline float coarsening(float below, float T_view) {
  float m = 1.0f;
  for (float limit = below; m < kMaxCoarsen && T_view < limit; limit *= 0.1f) m *= 2.0f;
  return m;
}

struct BoxHit {
  float t_in, t_out;
  int cloud;
};

// Per-thread scratch: candidates of one cloud, the clouds a ray hits, the density source with
// this thread's fBm counter, and the thread's work counters.
// The physical march's queued samples (march_physical): position, normalised distance to the
// owning primitive, the step it stands for, the step and skip counts after each, and their fBm.
struct Batch {
  static constexpr int kSize = kCoarsenEvery;
  float pts[3 * kSize];
  float q[kSize];
  float dt[kSize];  // the step each sample stands for
  float rho[kSize];
  int steps[kSize];
  std::uint64_t skipped[kSize];
  int size = 0;
};

// The candidates covering the physical march's current sample (RayMarcher::owner_q): each one's
// t_out, and its primitive's |q|² along the ray as |from + s·along|² (CandidateFan::ray_frame).
struct Active {
  std::vector<float> out;
  std::vector<glm::vec3> from, along;
  int size = 0;
  float leave = INFINITY;  // the smallest t_out among them: none leaves before it
};

struct Scratch {
  std::vector<Candidate> candidates;
  Batch batch;
  Active active;
  std::vector<BoxHit> hits;
  DensitySource src;
  std::uint64_t fbm = 0;
  std::uint64_t skipped = 0;
};

class RayMarcher {
 public:
  RayMarcher(const MarchScene& scene, const MarchSettings& settings,
             const std::vector<PreparedCloud>& prepared)
      : scene_(scene), settings_(settings), prepared_(prepared) {
    src_.noise = scene.noise;
    src_.fbm = settings.fbm;
    src_.constant = settings.density_constant;
    if (src_.constant < 0.0f && src_.noise != nullptr) batch_.emplace(*src_.noise, src_.fbm);
  }

  // A thread's scratch, its density source counting into it.
  void init(Scratch& scratch) const {
    scratch.candidates.resize(static_cast<std::size_t>(settings_.max_candidates));
    const std::size_t capacity = static_cast<std::size_t>(settings_.max_candidates);
    scratch.active.out.resize(capacity);
    scratch.active.from.resize(capacity);
    scratch.active.along.resize(capacity);
    scratch.hits.reserve(prepared_.size());
    scratch.src = src_;
    scratch.src.evaluations = &scratch.fbm;
  }

  // The pixel's colour; `steps` receives the samples marched. `tile`: the screen tile of the
  // pixel (ScreenTiles), whose bins the candidate fans hold.
  glm::vec4 march(glm::vec3 origin, glm::vec3 dir, int tile, Scratch& scratch, float xi,
                  int& steps) const {
    const glm::vec3 inv_dir = 1.0f / dir;
    // Clouds whose box the ray meets in front of the camera, sorted by entry (t ≥ 0) with a
    // stable insertion sort so that ties keep the scene order.
    auto& hits = scratch.hits;
    hits.clear();
    // Clouds stop at the nearest opaque solid (kNoSolid = +∞ without solids).
    const float t_solid =
        scene_.solids.empty() ? kNoSolid : nearest_solid(scene_.solids, origin, dir);
    for (std::size_t c = 0; c < prepared_.size(); ++c) {
      Interval iv;
      if (!intersect(prepared_[c].box, origin, inv_dir, iv)) continue;
      if (!(iv.t_out >= 0.0f)) continue;
      if (!(std::max(iv.t_in, 0.0f) < t_solid)) continue;
      const BoxHit h{std::max(iv.t_in, 0.0f), std::min(iv.t_out, t_solid), static_cast<int>(c)};
      hits.push_back(h);
      for (std::size_t k = hits.size() - 1; k > 0 && hits[k - 1].t_in > h.t_in; --k)
        std::swap(hits[k], hits[k - 1]);
    }

    State st;
    st.cos_theta = glm::dot(dir, scene_.sun.direction);
    st.t_limit = t_solid;
    if (settings_.physical) {
      // The octaves' phase terms (a few pow per order) are built at the ray's first sample with
      // density: most rays of a frame never meet one.
      std::optional<OctaveTerms> terms;
      for (const BoxHit& h : hits) {
        if (!march_physical(prepared_[static_cast<std::size_t>(h.cloud)], h, origin, dir, tile,
                            scratch, st, terms, xi))
          break;
      }
    } else {
      st.phase = henyey_greenstein(settings_.hg_g, st.cos_theta);
      for (const BoxHit& h : hits) {
        if (!march_cloud(prepared_[static_cast<std::size_t>(h.cloud)], h, origin, dir, tile,
                         scratch, st, xi))
          break;
      }
    }
    const glm::vec3 rgb = scene_.with_sky ? st.colour + (settings_.physical ? st.T_view : st.T) *
                                                            background(scene_.sky, scene_.sun,
                                                                       scene_.ground, origin, dir)
                                          : st.colour;
    steps = st.steps;
    return glm::vec4(rgb, 1.0f - st.T);
  }

 private:
  struct State {
    glm::vec3 colour{0.0f};
    float T = 1.0f;
    float T_view = 1.0f;  // the radiance's transmittance (the physical mode's δ-M view; else T)
    int steps = 0;
    float cos_theta = 0.0f;
    float phase = 0.0f;
    float t_limit = kNoSolid;  // the nearest solid along the ray
  };

  // One sample at ray parameter s attributed to primitive j (Algorithm 3). Returns false when
  // the ray is done (opaque or out of samples).
  bool sample(const PreparedCloud& pc, int j, float s, glm::vec3 origin, glm::vec3 dir,
              Scratch& scratch, State& st) const {
    const RenderCloud& rc = *pc.cloud;
    const glm::vec3 p = origin + s * dir;
    const DensitySample d = cloud_density(rc.shape, j, p, scratch.src);
    ++st.steps;
    if (d.rho > 0.0f) {
      const float dtau = std::exp(-settings_.absorption * d.rho * pc.step / settings_.ref_step);
      const float pL = rc.light.sample(p);
      const glm::vec3 aL = scene_.sun.radiance * pL;
      const glm::vec3 sL = aL * st.phase * d.gamma;
      st.colour += (1.0f - dtau) * (aL + sL) * st.T;
      st.T *= dtau;
      if (st.T < settings_.min_transmittance) {
        // Early exit: the light still to come is estimated by this sample's source over the
        // rest of the ray (the medium taken as opaque beyond), not dropped.
        st.colour += st.T * (aL + sL);
        st.T = 0.0f;
        return false;
      }
    }
    return st.steps < settings_.max_steps;
  }

  // Empty-space skipping (RENDER_CONTRACT "Empty-space skipping"). When the sample at s = t + off
  // lies in an empty cell of the cloud's occupancy grid, it is passed over, and so is every
  // following sample of the lattice (t += step, as the plain march adds) whose s stays a margin
  // before the cell's exit, before t_end and before the solid. Each counts as a step, so the
  // max_steps budget is spent as without skipping. Returns false when the sample must be taken.
  bool skip_empty(const PreparedCloud& pc, float& t, float step, float off, float t_end,
                  glm::vec3 origin, glm::vec3 dir, Scratch& scratch, State& st,
                  float* occupied_until = nullptr) const {
    const OccupancyGrid* occ = pc.occupancy;
    if (occ == nullptr) return false;
    int ix, iy, iz;
    if (!occ->cell_of(origin + (t + off) * dir, ix, iy, iz)) return false;
    if (occ->occupied(ix, iy, iz)) {
      if (occupied_until != nullptr)
        *occupied_until = occ->cell_exit(ix, iy, iz, origin, dir) - pc.margin;
      return false;
    }
    const float safe = std::min(occ->cell_exit(ix, iy, iz, origin, dir) - pc.margin, st.t_limit);
    do {
      ++st.steps;
      ++scratch.skipped;
      t += step;
    } while (st.steps < settings_.max_steps && t < t_end && t + off < safe);
    return true;
  }

  // Marches one cloud, each sample at ξ·Δ into its step (ξ = ½ unless jittered); false when the
  // whole ray is done.
  bool march_cloud(const PreparedCloud& pc, const BoxHit& h, glm::vec3 origin, glm::vec3 dir,
                   int tile, Scratch& scratch, State& st, float xi) const {
    const CloudShape& shape = pc.cloud->shape;
    Candidate* cand = scratch.candidates.data();
    const int n = pc.fan->collect(dir, tile, h.t_in, h.t_out, cand, settings_.max_candidates,
                                  settings_.sort_candidates);
    const float step = pc.step;
    const float offset = xi * step;  // Δ/2 exactly when not jittered (the paper)
    if (settings_.march == MarchMode::Paper) {
      // Every candidate interval on its own: overlaps are marched twice, as in the paper.
      for (int k = 0; k < n; ++k) {
        for (float t = cand[k].t_in; t < cand[k].t_out;) {
          if (!(t + offset < st.t_limit)) break;
          if (skip_empty(pc, t, step, offset, cand[k].t_out, origin, dir, scratch, st)) {
            if (st.steps >= settings_.max_steps) return false;
            continue;
          }
          if (!sample(pc, cand[k].primitive, t + offset, origin, dir, scratch, st)) return false;
          t += step;
        }
      }
      return true;
    }
    // Union: each point of the union of the intervals once (NDT applied to camera rays).
    const bool attribute = shape.density.model == DensityModel::Spheroid;
    float t = -INFINITY;
    for (int k = 0; k < n; ++k) {
      if (cand[k].t_out <= t) continue;
      t = std::max(t, cand[k].t_in);
      while (t < cand[k].t_out) {
        const float s = t + offset;
        if (!(s < st.t_limit)) break;
        if (skip_empty(pc, t, step, offset, cand[k].t_out, origin, dir, scratch, st)) {
          if (st.steps >= settings_.max_steps) return false;
          continue;
        }
        const int j = attribute
                          ? union_owner(shape, cand, n, s, origin + s * dir, cand[k].primitive)
                          : cand[k].primitive;
        if (!sample(pc, j, s, origin, dir, scratch, st)) return false;
        t += step;
      }
    }
    return true;
  }

  // The |q| of union_owner's owner of the sample at s (world point p = origin + s·dir), for
  // samples taken in increasing s: the covering candidates are kept in `active` as they enter
  // (t_in ≤ s; `entered` of them so far) and leave (s > t_out) instead of scanning them all;
  // the owner's |q| is the smallest, or any value above 1 when the sample is outside them all.
  // Each candidate's |q|² is the ray's quadratic in s in its primitive's frame, |from + s·along|²
  // (set up once as it enters): three multiply-adds and a dot product per sample, where the
  // world point's frame change took a rotation and three divisions. It equals that |q|² up to
  // rounding (a few ulps), as the light pass's attribution does. Unsorted candidates
  // (candidate_sort "none") take union_owner itself.
  float owner_q(const CloudShape& shape, const CandidateFan& fan, const Candidate* cand, int n,
                float s, glm::vec3 p, glm::vec3 dir, int fallback, Active& active,
                int& entered) const {
    if (!settings_.sort_candidates) return fan.q(union_owner(shape, cand, n, s, p, fallback), p);
    while (entered < n && cand[entered].t_in <= s) {
      const Candidate& c = cand[entered++];
      const std::size_t k = static_cast<std::size_t>(active.size++);
      active.out[k] = c.t_out;
      active.leave = std::min(active.leave, c.t_out);
      fan.ray_frame(c.primitive, dir, active.from[k], active.along[k]);
    }
    if (s > active.leave) {  // some candidate has left: drop those, and find the next to leave
      std::size_t kept = 0;
      active.leave = INFINITY;
      for (std::size_t i = 0; i < static_cast<std::size_t>(active.size); ++i) {
        const float out = active.out[i];
        if (!(s > out)) {
          active.out[kept] = out;
          active.from[kept] = active.from[i];
          active.along[kept] = active.along[i];
          ++kept;
          active.leave = std::min(active.leave, out);
        }
      }
      active.size = static_cast<int>(kept);
    }
    const std::size_t kept = static_cast<std::size_t>(active.size);
    if (kept == 0) return fan.q(fallback, p);
    // The smallest |q|², where it is at most 1: beyond, the sample is outside (q > 1) whichever
    // candidate owns it. kInside: a few ulps above 1, so that every |q|² whose root rounds to 1
    // still counts.
    constexpr float kInside = 1.0000004f;
    float best = kInside;
    for (std::size_t i = 0; i < kept; ++i) {
      const glm::vec3 v = active.from[i] + s * active.along[i];
      best = std::min(best, glm::dot(v, v));
    }
    return best < kInside ? std::sqrt(best) : 2.0f;
  }

  // The physical mode (RENDER_CONTRACT "Physical lighting"): the union of the candidate
  // intervals, each sample at ξ·Δ into its step, σ = extinction_scale·ρ. False when done.
  // The samples inside the cloud's primitives are queued (kBatch at most) and their fBm
  // evaluated together by the noise's bulk kernel (bit-identical to one at a time); then they
  // are shaded in order. A ray that turns opaque in a batch takes back the steps (and skips) it
  // queued past that sample, so the image and the work counted are those of the one-by-one march
  // (the evaluations past it, at most kBatch − 1 per ray, are done but not counted).
  bool march_physical(const PreparedCloud& pc, const BoxHit& h, glm::vec3 origin, glm::vec3 dir,
                      int tile, Scratch& scratch, State& st, std::optional<OctaveTerms>& terms,
                      float xi) const {
    const RenderCloud& rc = *pc.cloud;
    const CloudShape& shape = rc.shape;
    const PhysicalParams& ph = settings_.phys;
    Candidate* cand = scratch.candidates.data();
    const int n = pc.fan->collect(dir, tile, h.t_in, h.t_out, cand, settings_.max_candidates,
                                  settings_.sort_candidates);
    const float step = pc.step;
    const float offset = xi * step;
    const bool spheroid = shape.density.model == DensityModel::Spheroid;
    Batch& b = scratch.batch;
    b.size = 0;
    // Shades the queued samples in order; false when the ray turned opaque.
    auto flush = [&]() -> bool {
      if (b.size == 0) return true;
      const std::size_t count = static_cast<std::size_t>(b.size);
      if (src_.constant >= 0.0f) {
        std::fill(b.rho, b.rho + count, src_.constant);
      } else {
        (*batch_)(noise_points(shape, b.pts, count), count, b.rho);
      }
      for (int i = 0; i < b.size; ++i) {
        if (src_.constant < 0.0f) ++scratch.fbm;
        const DensitySample d = spheroid
                                    ? spheroid_density_given(shape.density.kappa, b.q[i], b.rho[i])
                                    : DensitySample{metaball_rho(shape, b.rho[i]), 1.0f};
        if (!(d.rho > 0.0f)) continue;
        const glm::vec3 p(b.pts[3 * i], b.pts[3 * i + 1], b.pts[3 * i + 2]);
        const float sigma = ph.extinction_scale * d.rho;
        const float a = std::exp(-sigma * b.dt[i]);
        // The radiance sees σ·view_scale (the δ-M view); each unit of σ still emits S:
        // ∫₀^Δ e^{−σ'x}·σ·S dx = (1 − e^{−σ'Δ})·S/view_scale.
        const float a_view = std::exp(-sigma * ph.view_scale * b.dt[i]);
        if (!terms) terms.emplace(ph, st.cos_theta);
        const glm::vec3 S =
            rc.physical.source(p, *terms, scene_.sun.radiance, ph.albedo, ph.view_diffuse);
        st.colour += st.T_view * ((1.0f - a_view) / ph.view_scale) * S;
        st.T *= a;
        st.T_view *= a_view;
        if (st.T_view < ph.min_transmittance) {
          // Stopped: opaque. What lies behind would add at most T_view of its radiance, but a
          // sun disc or its aureole behind the cloud is far brighter than the cloud itself.
          st.T = st.T_view = 0.0f;
          st.steps = b.steps[i];
          scratch.skipped = b.skipped[i];
          b.size = 0;
          return false;
        }
      }
      b.size = 0;
      return true;
    };
    // The candidates covering the sample (union_owner's), kept as s grows.
    Active& active = scratch.active;
    active.size = 0;
    active.leave = INFINITY;
    int entered = 0;
    float occupied_until = -INFINITY;  // skip_empty's: the samples before it lie in occupied cells
    float dt = step;                   // the step now: coarser as the ray grows opaque
    float t = -INFINITY;
    for (int k = 0; k < n; ++k) {
      if (cand[k].t_out <= t) continue;
      t = std::max(t, cand[k].t_in);
      while (t < cand[k].t_out) {
        if (st.steps >= settings_.max_steps) {
          flush();
          return false;
        }
        const float s = t + offset;
        if (!(s < st.t_limit)) return flush();  // a solid hides the rest of the ray
        // The rest of an occupied cell (up to its exit, less the margin) needs no new look.
        if (!(s < occupied_until) &&
            skip_empty(pc, t, dt, offset, cand[k].t_out, origin, dir, scratch, st, &occupied_until))
          continue;
        ++st.steps;
        const glm::vec3 p = origin + s * dir;
        t += dt;
        float q = 0.0f;
        if (spheroid) {
          q = owner_q(shape, *pc.fan, cand, n, s, p, dir, cand[k].primitive, active, entered);
          if (q > 1.0f) continue;  // outside the cloud: no density (spheroid_density)
        } else if (!metaball_inside(shape, p)) {
          continue;
        }
        b.pts[3 * b.size] = p.x;
        b.pts[3 * b.size + 1] = p.y;
        b.pts[3 * b.size + 2] = p.z;
        b.q[b.size] = q;
        b.dt[b.size] = dt;
        b.steps[b.size] = st.steps;
        b.skipped[b.size] = scratch.skipped;
        if (++b.size == Batch::kSize) {
          if (!flush()) return false;
          dt = step * coarsening(ph.coarsen_below, st.T_view);
        }
      }
    }
    return flush();
  }

  const MarchScene& scene_;
  const MarchSettings& settings_;
  const std::vector<PreparedCloud>& prepared_;
  DensitySource src_;
  std::optional<Noise::Batch> batch_;  // src_'s fBm for the physical march's queued samples
};

// What every ray of one render shares: each cloud's occupancy grid, candidate fan (every ray
// starts at the camera, binned by screen tile) and march constants. Built once per render, then
// read by all threads.
class PreparedScene {
 public:
  PreparedScene(const MarchScene& scene, const MarchSettings& settings, const CameraParams& camera,
                const ScreenTiles& tiles) {
    settings.validate();
    camera.validate();
    scene.validate(settings);
    if (settings.skip_empty) {
      grids_.reserve(scene.clouds.size());
      for (const auto& c : scene.clouds) grids_.push_back(build_occupancy(c.shape));
    }
    fans_.reserve(scene.clouds.size());
    for (const auto& c : scene.clouds) fans_.emplace_back(c.shape, camera.position);
    bin(tiles);
    clouds_.reserve(scene.clouds.size());
    for (std::size_t k = 0; k < scene.clouds.size(); ++k) {
      const RenderCloud& c = scene.clouds[k];
      PreparedCloud pc{&c,
                       candidate_bounds(c.shape),
                       settings.step_for(camera.position, c.shape.centre()),
                       nullptr,
                       0.0f,
                       &fans_[k]};
      if (settings.skip_empty) {
        const OccupancyGrid& g = grids_[k];
        const glm::vec3 cell = (g.box.hi - g.box.lo) / static_cast<float>(g.res);
        pc.occupancy = &g;
        pc.margin = 1e-3f * std::min(cell.x, std::min(cell.y, cell.z));
      }
      clouds_.push_back(pc);
    }
  }
  const std::vector<PreparedCloud>& clouds() const { return clouds_; }
  // Bins the fans for `tiles` (the same camera, another image size: the edge pass's). Not while
  // a march reads them.
  void bin(const ScreenTiles& tiles) {
    for (CandidateFan& fan : fans_) {
      // A few primitives cost less to test than to bin.
      if (fan.size() > kBinFrom) fan.bin(tiles.cones());
    }
  }

 private:
  static constexpr std::size_t kBinFrom = 8;
  std::vector<OccupancyGrid> grids_;
  std::vector<CandidateFan> fans_;
  std::vector<PreparedCloud> clouds_;
};

// Marches `count` pixels on `threads` threads: pixel k is (row_of(k), col_of(k)) of the
// (height, width) image and writes out[4k..4k+3] (and fbm_map[k]). Work is counted per pixel
// and the totals are integer sums: the same whatever the thread count.
// `prepared`'s fans binned for `tiles`, which are those of `rays`.
template <class PixelOf>
void march_pixels(const MarchScene& scene, const MarchSettings& settings,
                  const PreparedScene& prepared, const CameraRays& rays, const ScreenTiles& tiles,
                  std::size_t count, PixelOf pixel_of, float* out, int threads, MarchStats* stats,
                  std::uint32_t* fbm_map) {
  const RayMarcher marcher(scene, settings, prepared.clouds());
  std::mutex lock;
  MarchStats total;
  parallel_chunks(count, threads, [&](std::size_t k0, std::size_t k1) {
    Scratch scratch;
    marcher.init(scratch);
    std::uint64_t steps_sum = 0;
    for (std::size_t k = k0; k < k1; ++k) {
      const auto [r, c] = pixel_of(k);
      const glm::vec3 dir = rays.direction(r, c);
      const float xi =
          settings.physical || settings.jitter ? jitter(r, c, settings.phys.jitter_seed) : 0.5f;
      const std::uint64_t before = scratch.fbm;
      int steps = 0;
      const glm::vec4 px = marcher.march(rays.origin, dir, tiles.tile_of(r, c), scratch, xi, steps);
      steps_sum += static_cast<std::uint64_t>(steps);
      if (fbm_map != nullptr) fbm_map[k] = static_cast<std::uint32_t>(scratch.fbm - before);
      float* o = out + k * 4;
      o[0] = px.x;
      o[1] = px.y;
      o[2] = px.z;
      o[3] = px.w;
    }
    if (stats != nullptr) {
      const std::lock_guard<std::mutex> guard(lock);
      total.fbm_evaluations += scratch.fbm;
      total.steps += steps_sum;
      total.skipped += scratch.skipped;
    }
  });
  if (stats != nullptr) *stats = total;
}

// The (row, column) of pixel k of a whole (·, width) image, row by row.
struct RowMajor {
  std::size_t width;
  std::pair<int, int> operator()(std::size_t k) const {
    return {static_cast<int>(k / width), static_cast<int>(k % width)};
  }
};

// The (row, column) of pixel k of a list of pairs.
struct Listed {
  const std::int32_t* pixels;
  std::pair<int, int> operator()(std::size_t k) const { return {pixels[2 * k], pixels[2 * k + 1]}; }
};

void check_size(int width, int height) {
  if (width < 1 || height < 1) throw std::invalid_argument("width and height must be >= 1");
}

}  // namespace

void render_image(const MarchScene& scene, const MarchSettings& settings,
                  const CameraParams& camera, int width, int height, float* out, int threads,
                  MarchStats* stats, std::uint32_t* fbm_map) {
  check_size(width, height);
  const CameraRays rays(camera, width, height);
  const ScreenTiles tiles(rays);
  const PreparedScene prepared(scene, settings, camera, tiles);
  const std::size_t w = static_cast<std::size_t>(width);
  march_pixels(scene, settings, prepared, rays, tiles, w * static_cast<std::size_t>(height),
               RowMajor{w}, out, threads, stats, fbm_map);
}

void render_pixels(const MarchScene& scene, const MarchSettings& settings,
                   const CameraParams& camera, int width, int height, const std::int32_t* pixels,
                   std::size_t count, float* out, int threads, MarchStats* stats,
                   std::uint32_t* fbm_map) {
  check_size(width, height);
  for (std::size_t k = 0; k < count; ++k) {
    const std::int32_t r = pixels[2 * k], c = pixels[2 * k + 1];
    if (r < 0 || r >= height || c < 0 || c >= width)
      throw std::invalid_argument("pixels must lie in the image: (row, column) in [0, H) x [0, W)");
  }
  const CameraRays rays(camera, width, height);
  const ScreenTiles tiles(rays);
  const PreparedScene prepared(scene, settings, camera, tiles);
  march_pixels(scene, settings, prepared, rays, tiles, count, Listed{pixels}, out, threads, stats,
               fbm_map);
}

void EdgePass::validate() const {
  if (!std::isfinite(range)) throw std::invalid_argument("edge range must be finite");
  if (sub < 1 || sub > 16) throw std::invalid_argument("edge sub must be in [1, 16]");
  if (rays.empty()) throw std::invalid_argument("the edge pass needs at least one ray");
  for (const auto& [r, c] : rays) {
    if (r < 0 || r >= sub || c < 0 || c >= sub)
      throw std::invalid_argument("edge rays must be sub-pixels (row, column) in [0, sub)");
  }
  if (max_sub_edge < 1) throw std::invalid_argument("max_sub_edge must be >= 1");
}

bool render_image_with_edges(const MarchScene& scene, const MarchSettings& settings,
                             const CameraParams& camera, int width, int height, float* out,
                             int threads, const EdgePass& pass, std::uint8_t* mask,
                             MarchStats* stats, std::uint32_t* fbm_map) {
  check_size(width, height);
  pass.validate();
  const std::size_t w = static_cast<std::size_t>(width), h = static_cast<std::size_t>(height);
  const CameraRays rays(camera, width, height);
  const ScreenTiles tiles(rays);
  PreparedScene prepared(scene, settings, camera, tiles);
  march_pixels(scene, settings, prepared, rays, tiles, w * h, RowMajor{w}, out, threads, stats,
               fbm_map);
  std::fill(mask, mask + w * h, std::uint8_t{0});
  if (static_cast<long long>(pass.sub) * std::max(width, height) > pass.max_sub_edge) return false;

  // The outline, as edges.edge_mask finds it.
  std::vector<float> alpha(w * h);
  for (std::size_t k = 0; k < w * h; ++k) alpha[k] = out[4 * k + 3];
  coverage_edges(alpha.data(), width, height, pass.range, mask, threads);
  std::vector<std::size_t> outline;  // the edge pixels, row by row
  for (std::size_t k = 0; k < w * h; ++k)
    if (mask[k] != 0) outline.push_back(k);
  const std::size_t n_rays = pass.rays.size();
  if (outline.empty() || outline.size() * n_rays > pass.max_rays) {
    std::fill(mask, mask + w * h, std::uint8_t{0});
    return false;
  }

  // Each edge pixel's rays side by side: neighbours in the list, in the cache and on a thread.
  std::vector<std::int32_t> listed(2 * outline.size() * n_rays);
  for (std::size_t i = 0; i < outline.size(); ++i) {
    const int r = static_cast<int>(outline[i] / w), c = static_cast<int>(outline[i] % w);
    for (std::size_t j = 0; j < n_rays; ++j) {
      listed[2 * (i * n_rays + j)] = pass.sub * r + pass.rays[j].first;
      listed[2 * (i * n_rays + j) + 1] = pass.sub * c + pass.rays[j].second;
    }
  }
  const CameraRays sub_rays(camera, pass.sub * width, pass.sub * height);
  const ScreenTiles sub_tiles(sub_rays);
  prepared.bin(sub_tiles);
  const std::size_t count = outline.size() * n_rays;
  std::vector<float> values(4 * count);
  std::vector<std::uint32_t> sub_map(fbm_map != nullptr ? count : 0);
  MarchStats sub_stats;
  march_pixels(scene, settings, prepared, sub_rays, sub_tiles, count, Listed{listed.data()},
               values.data(), threads, stats != nullptr ? &sub_stats : nullptr,
               fbm_map != nullptr ? sub_map.data() : nullptr);

  // The mean in double, rounded once (numpy's mean of the float32 values as float64).
  for (std::size_t i = 0; i < outline.size(); ++i) {
    double sum[4] = {0.0, 0.0, 0.0, 0.0};
    for (std::size_t j = 0; j < n_rays; ++j) {
      const float* v = values.data() + 4 * (i * n_rays + j);
      for (int ch = 0; ch < 4; ++ch) sum[ch] += static_cast<double>(v[ch]);
      if (fbm_map != nullptr) fbm_map[outline[i]] += sub_map[i * n_rays + j];
    }
    float* o = out + 4 * outline[i];
    for (int ch = 0; ch < 4; ++ch)
      o[ch] = static_cast<float>(sum[ch] / static_cast<double>(n_rays));
  }
  if (stats != nullptr) {
    stats->fbm_evaluations += sub_stats.fbm_evaluations;
    stats->steps += sub_stats.steps;
    stats->skipped += sub_stats.skipped;
  }
  return true;
}

}  // namespace cumuli
