#include "cumuli/light/caf.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "cumuli/parallel.hpp"

namespace cumuli {

namespace {

constexpr double kPi = 3.141592653589793;
constexpr int kMaxDim = 128;

float smoothstep(float e0, float e1, float x) {
  const float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

glm::vec3 inverse(glm::vec3 d) { return glm::vec3(1.0f / d.x, 1.0f / d.y, 1.0f / d.z); }

}  // namespace

BoxIndex::BoxIndex(std::vector<Box> boxes) : boxes_(std::move(boxes)) {
  if (boxes_.size() <= kBruteForceBoxes) return;
  grid_ = true;
  bounds_ = boxes_[0];
  double mean_extent = 0.0;
  for (const Box& b : boxes_) {
    bounds_.lo = glm::min(bounds_.lo, b.lo);
    bounds_.hi = glm::max(bounds_.hi, b.hi);
    const glm::vec3 e = b.hi - b.lo;
    mean_extent += std::max({e.x, e.y, e.z});
  }
  mean_extent /= static_cast<double>(boxes_.size());
  const glm::dvec3 ext = glm::dvec3(bounds_.hi) - glm::dvec3(bounds_.lo);
  const double longest = std::max({ext.x, ext.y, ext.z});
  // About two boxes per cell, but cells no smaller than half a typical box (a box then covers a
  // few cells) and at most kMaxDim per axis.
  const double floor_ext = std::max(longest * 1e-6, 1e-30);
  const double volume =
      std::max(ext.x, floor_ext) * std::max(ext.y, floor_ext) * std::max(ext.z, floor_ext);
  double cell = std::cbrt(volume / (2.0 * static_cast<double>(boxes_.size())));
  cell = std::max({cell, 0.5 * mean_extent, longest / kMaxDim});
  for (int k = 0; k < 3; ++k) {
    dims_[k] =
        ext[k] > 0.0 ? std::clamp(static_cast<int>(std::ceil(ext[k] / cell)), 1, kMaxDim) : 1;
    cell_[k] = ext[k] > 0.0 ? static_cast<float>(ext[k] / dims_[k]) : 1.0f;
  }
  const std::size_t cells = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
  // Register each box (padded by a thousandth of a cell, so that rays grazing a cell face still
  // find boxes touching it) in every cell it overlaps: two passes into CSR arrays.
  auto range = [&](const Box& b, int lo[3], int hi[3]) {
    for (int k = 0; k < 3; ++k) {
      const float pad = 1e-3f * cell_[k];
      lo[k] = std::clamp(static_cast<int>(std::floor((b.lo[k] - pad - bounds_.lo[k]) / cell_[k])),
                         0, dims_[k] - 1);
      hi[k] = std::clamp(static_cast<int>(std::floor((b.hi[k] + pad - bounds_.lo[k]) / cell_[k])),
                         0, dims_[k] - 1);
    }
  };
  std::vector<std::uint32_t> count(cells + 1, 0);
  for (const Box& b : boxes_) {
    int lo[3], hi[3];
    range(b, lo, hi);
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x)
          count[(static_cast<std::size_t>(z) * dims_[1] + y) * dims_[0] + x + 1] += 1;
  }
  for (std::size_t c = 0; c < cells; ++c) count[c + 1] += count[c];
  cell_start_ = count;
  cell_box_.assign(count[cells], 0);
  std::vector<std::uint32_t> fill(count.begin(), count.end() - 1);
  for (std::size_t i = 0; i < boxes_.size(); ++i) {
    int lo[3], hi[3];
    range(boxes_[i], lo, hi);
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y)
        for (int x = lo[0]; x <= hi[0]; ++x)
          cell_box_[fill[(static_cast<std::size_t>(z) * dims_[1] + y) * dims_[0] + x]++] =
              static_cast<std::uint32_t>(i);
  }
}

void BoxIndex::candidates(glm::vec3 o, glm::vec3 d, Scratch& s) const {
  s.hits.clear();
  if (s.stamp.size() != boxes_.size()) {
    s.stamp.assign(boxes_.size(), 0);
    s.tick = 0;
  }
  if (++s.tick == 0) {  // wrapped: clear the stamps
    std::fill(s.stamp.begin(), s.stamp.end(), 0);
    s.tick = 1;
  }
  Box padded = bounds_;
  padded.lo -= 1e-3f * cell_;
  padded.hi += 1e-3f * cell_;
  Interval span;
  if (!intersect(padded, o, inverse(d), span) || span.t_out < 0.0f) return;
  const double t_start = std::max(0.0, double(span.t_in));
  const double t_end = span.t_out;
  int cell[3], step[3];
  double t_max[3], t_delta[3];
  for (int k = 0; k < 3; ++k) {
    const double p = double(o[k]) + t_start * double(d[k]);
    cell[k] =
        std::clamp(static_cast<int>(std::floor((p - bounds_.lo[k]) / cell_[k])), 0, dims_[k] - 1);
    if (d[k] > 0.0f) {
      step[k] = 1;
      t_max[k] = (bounds_.lo[k] + double(cell[k] + 1) * cell_[k] - double(o[k])) / d[k];
      t_delta[k] = cell_[k] / double(d[k]);
    } else if (d[k] < 0.0f) {
      step[k] = -1;
      t_max[k] = (bounds_.lo[k] + double(cell[k]) * cell_[k] - double(o[k])) / d[k];
      t_delta[k] = -cell_[k] / double(d[k]);
    } else {
      step[k] = 0;
      t_max[k] = INFINITY;
      t_delta[k] = INFINITY;
    }
  }
  for (;;) {
    const std::size_t c =
        (static_cast<std::size_t>(cell[2]) * dims_[1] + cell[1]) * dims_[0] + cell[0];
    for (std::uint32_t j = cell_start_[c]; j < cell_start_[c + 1]; ++j) {
      const std::uint32_t b = cell_box_[j];
      if (s.stamp[b] != s.tick) {
        s.stamp[b] = s.tick;
        s.hits.push_back(b);
      }
    }
    int k = 0;
    if (t_max[1] < t_max[k]) k = 1;
    if (t_max[2] < t_max[k]) k = 2;
    if (!(t_max[k] <= t_end)) break;
    cell[k] += step[k];
    if (cell[k] < 0 || cell[k] >= dims_[k]) break;
    t_max[k] += t_delta[k];
  }
  std::sort(s.hits.begin(), s.hits.end());
}

void BoxIndex::spans(glm::vec3 o, glm::vec3 d, std::size_t skip_lo, std::size_t skip_hi,
                     std::vector<Span>& out, Scratch& scratch) const {
  const glm::vec3 inv = inverse(d);
  auto test = [&](std::size_t i) {
    if (i >= skip_lo && i < skip_hi) return;
    Interval iv;
    if (!intersect(boxes_[i], o, inv, iv) || !(iv.t_out > 0.0f)) return;
    out.push_back(
        Span{static_cast<std::uint32_t>(i), std::max(0.0, double(iv.t_in)), double(iv.t_out)});
  };
  if (!grid_) {
    for (std::size_t i = 0; i < boxes_.size(); ++i) test(i);
    return;
  }
  candidates(o, d, scratch);
  for (std::uint32_t i : scratch.hits) test(i);
}

double combine_spans(std::vector<Span>& spans, Overlap overlap) {
  double total = 0.0;
  if (overlap == Overlap::Sum) {
    for (const Span& s : spans) total += s.t1 - s.t0;
    return total;
  }
  std::sort(spans.begin(), spans.end(), [](const Span& a, const Span& b) {
    if (a.t0 != b.t0) return a.t0 < b.t0;
    if (a.t1 != b.t1) return a.t1 < b.t1;
    return a.box < b.box;
  });
  bool open = false;
  double lo = 0.0, hi = 0.0;
  for (const Span& s : spans) {
    if (open && s.t0 <= hi) {
      hi = std::max(hi, s.t1);
      continue;
    }
    if (open) total += hi - lo;
    lo = s.t0;
    hi = s.t1;
    open = true;
  }
  if (open) total += hi - lo;
  return total;
}

float caf_value(double length, double max_distance, CafCurve curve) {
  if (std::isinf(max_distance)) return 1.0f;
  const double x = length / max_distance;
  if (curve == CafCurve::Linear) return static_cast<float>(std::clamp(1.0 - x, 0.0, 1.0));
  return static_cast<float>(std::exp(-3.0 * x));
}

void caf_path_lengths(const BoxIndex& index, const glm::vec3* points, const int* owner,
                      std::size_t n, glm::vec3 sun, Overlap overlap, bool include_self, double* out,
                      int threads) {
  parallel_chunks(n, threads, [&](std::size_t b, std::size_t e) {
    BoxIndex::Scratch scratch;
    std::vector<Span> spans;
    for (std::size_t i = b; i < e; ++i) {
      spans.clear();
      std::size_t lo = 0, hi = 0;
      if (!include_self && owner != nullptr && owner[i] >= 0) {
        lo = static_cast<std::size_t>(owner[i]);
        hi = lo + 1;
      }
      index.spans(points[i], sun, lo, hi, spans, scratch);
      out[i] = combine_spans(spans, overlap);
    }
  });
}

void yaw_cos_sin(double degrees, double& c, double& s) {
  const double r = std::fmod(degrees, 360.0);
  const double q = r / 90.0;
  if (q == std::floor(q)) {
    const int k = ((static_cast<int>(q) % 4) + 4) % 4;
    const double cs[4] = {1.0, 0.0, -1.0, 0.0};
    const double sn[4] = {0.0, 1.0, 0.0, -1.0};
    c = cs[k];
    s = sn[k];
    return;
  }
  c = std::cos(r * kPi / 180.0);
  s = std::sin(r * kPi / 180.0);
}

Box instance_box(const Box& local, const Instance& inst) {
  double c, s;
  yaw_cos_sin(inst.yaw, c, s);
  const glm::dvec3 centre = 0.5 * (glm::dvec3(local.lo) + glm::dvec3(local.hi));
  const glm::dvec3 half = 0.5 * (glm::dvec3(local.hi) - glm::dvec3(local.lo));
  const glm::dvec3 wc(c * centre.x + s * centre.z + inst.offset.x, centre.y + inst.offset.y,
                      -s * centre.x + c * centre.z + inst.offset.z);
  const glm::dvec3 wh(std::abs(c) * half.x + std::abs(s) * half.z, half.y,
                      std::abs(s) * half.x + std::abs(c) * half.z);
  return Box{glm::vec3(wc - wh), glm::vec3(wc + wh)};
}

void field_path_lengths(const std::vector<BoxIndex>& variants,
                        const std::vector<std::vector<glm::vec3>>& points,
                        const std::vector<std::vector<int>>& owners,
                        const std::vector<Instance>& instances, glm::vec3 sun, Overlap overlap,
                        bool include_self, bool between_clouds, double* out, int threads) {
  const std::size_t ni = instances.size();
  std::vector<std::size_t> first(ni + 1, 0), box_first(ni + 1, 0);
  for (std::size_t i = 0; i < ni; ++i) {
    const auto v = static_cast<std::size_t>(instances[i].variant);
    first[i + 1] = first[i] + points[v].size();
    box_first[i + 1] = box_first[i] + variants[v].size();
  }
  std::vector<Box> world;
  if (between_clouds) {
    world.reserve(box_first[ni]);
    for (const Instance& inst : instances)
      for (const Box& b : variants[static_cast<std::size_t>(inst.variant)].boxes())
        world.push_back(instance_box(b, inst));
  }
  const BoxIndex world_index(std::move(world));
  const std::size_t total = first[ni];
  parallel_chunks(total, threads, [&](std::size_t b, std::size_t e) {
    BoxIndex::Scratch own_scratch, world_scratch;
    std::vector<Span> spans, others;
    std::size_t i = static_cast<std::size_t>(std::upper_bound(first.begin(), first.end(), b) -
                                             first.begin() - 1);
    for (std::size_t q = b; q < e; ++q) {
      while (q >= first[i + 1]) ++i;
      const Instance& inst = instances[i];
      const auto v = static_cast<std::size_t>(inst.variant);
      const std::size_t k = q - first[i];
      double c, s;
      yaw_cos_sin(inst.yaw, c, s);
      const glm::vec3 local_sun(static_cast<float>(c * sun.x - s * sun.z), sun.y,
                                static_cast<float>(s * sun.x + c * sun.z));
      spans.clear();
      std::size_t lo = 0, hi = 0;
      const int own = owners[v][k];
      if (!include_self && own >= 0) {
        lo = static_cast<std::size_t>(own);
        hi = lo + 1;
      }
      variants[v].spans(points[v][k], local_sun, lo, hi, spans, own_scratch);
      if (between_clouds) {
        const glm::vec3 p = points[v][k];
        const glm::vec3 wp(static_cast<float>(c * p.x + s * p.z + inst.offset.x),
                           p.y + inst.offset.y,
                           static_cast<float>(-s * p.x + c * p.z + inst.offset.z));
        others.clear();
        world_index.spans(wp, sun, box_first[i], box_first[i + 1], others, world_scratch);
        const auto shift = static_cast<std::uint32_t>(variants[v].size());
        for (Span sp : others) {
          sp.box += shift;
          spans.push_back(sp);
        }
      }
      out[q] = combine_spans(spans, overlap);
    }
  });
}

void ShadeParams::validate() const {
  if (!(std::isfinite(d_min) && std::isfinite(d_max) && d_min >= 0.0f && d_min <= d_max))
    throw std::invalid_argument("d_min, d_max must satisfy 0 <= d_min <= d_max");
  if (!(std::isfinite(k_dir) && k_dir > 0.0f)) throw std::invalid_argument("k_dir must be > 0");
  if (!(std::isfinite(k_amb) && k_amb >= 0.0f)) throw std::invalid_argument("k_amb must be >= 0");
  for (int k = 0; k < 3; ++k)
    if (!(std::isfinite(ambient[k]) && ambient[k] >= 0.0f))
      throw std::invalid_argument("ambient must be finite and >= 0");
  for (std::size_t i = 0; i < height_levels.size(); ++i) {
    if (!std::isfinite(height_levels[i].first) || !std::isfinite(height_levels[i].second) ||
        height_levels[i].second < 0.0f)
      throw std::invalid_argument("height_levels must be finite (f, h) pairs with h >= 0");
    if (i > 0 && !(height_levels[i].first > height_levels[i - 1].first))
      throw std::invalid_argument("height_levels must be sorted by strictly increasing f");
  }
}

ShadeFrame shade_frame(const std::vector<Box>& boxes) {
  ShadeFrame f;
  if (boxes.empty()) return f;
  glm::vec3 lo = boxes[0].lo, hi = boxes[0].hi;
  for (const Box& b : boxes) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  f.centre = 0.5f * (lo + hi);
  f.radius = 0.5f * glm::length(hi - lo);
  f.y_lo = lo.y;
  f.y_hi = hi.y;
  return f;
}

float directional_term(glm::vec3 v, const ShadeFrame& frame, glm::vec3 light,
                       const ShadeParams& params) {
  const glm::vec3 off = v - frame.centre;
  const float len = glm::length(off);
  const float cos_phi = len < 1e-6f * frame.radius ? 0.0f : glm::dot(off / len, light);
  float x = params.directional == Directional::Linear ? 0.5f * (1.0f + cos_phi)
                                                      : smoothstep(-0.3f, 0.3f, cos_phi);
  x = std::clamp(x, 0.0f, 1.0f);
  if (params.k_dir != 1.0f) x = std::pow(x, params.k_dir);
  return params.d_min + (params.d_max - params.d_min) * x;
}

float height_factor(float y, const ShadeFrame& frame, const ShadeParams& params) {
  const auto& lv = params.height_levels;
  if (lv.empty()) return 1.0f;
  const float span = frame.y_hi - frame.y_lo;
  const float f = span > 0.0f ? (y - frame.y_lo) / span : 0.5f;
  if (f <= lv.front().first) return lv.front().second;
  if (f >= lv.back().first) return lv.back().second;
  for (std::size_t i = 1; i < lv.size(); ++i) {
    if (f <= lv[i].first) {
      const float w = (f - lv[i - 1].first) / (lv[i].first - lv[i - 1].first);
      return lv[i - 1].second + w * (lv[i].second - lv[i - 1].second);
    }
  }
  return lv.back().second;
}

glm::vec3 shade_point(glm::vec3 v, const ShadeFrame& frame, const float* caf, std::size_t stride,
                      const std::vector<ShadeLight>& lights, const ShadeParams& params) {
  const glm::vec3 ambient = params.k_amb * params.ambient;
  glm::vec3 direct(0.0f);
  for (std::size_t l = 0; l < lights.size(); ++l) {
    const float d = directional_term(v, frame, lights[l].direction, params);
    direct += (caf[l * stride] * d) * lights[l].radiance;
  }
  return ambient + height_factor(v.y, frame, params) * direct;
}

void billboard_shade(const glm::vec3* points, const int* index, std::size_t n, const float* caf,
                     std::size_t q, const ShadeFrame& frame, const std::vector<ShadeLight>& lights,
                     const ShadeParams& params, float* out, int threads) {
  parallel_for(n, threads, [&](std::size_t i) {
    const auto b = static_cast<std::size_t>(index[i]);
    const glm::vec3 c = shade_point(points[i], frame, caf + b, q, lights, params);
    out[3 * i] = c.x;
    out[3 * i + 1] = c.y;
    out[3 * i + 2] = c.z;
  });
}

void billboard_corners(const glm::vec3* centres, const glm::vec2* sizes, const float* rotation,
                       std::size_t n, glm::vec3 right, glm::vec3 up, float* out) {
  const float sx[4] = {-0.5f, 0.5f, 0.5f, -0.5f};
  const float sy[4] = {-0.5f, -0.5f, 0.5f, 0.5f};
  for (std::size_t i = 0; i < n; ++i) {
    double c, s;
    yaw_cos_sin(rotation[i], c, s);
    const glm::vec3 r2 = static_cast<float>(c) * right + static_cast<float>(s) * up;
    const glm::vec3 u2 = static_cast<float>(-s) * right + static_cast<float>(c) * up;
    for (int k = 0; k < 4; ++k) {
      const glm::vec3 v = centres[i] + (sx[k] * sizes[i].x) * r2 + (sy[k] * sizes[i].y) * u2;
      out[12 * i + 3 * k] = v.x;
      out[12 * i + 3 * k + 1] = v.y;
      out[12 * i + 3 * k + 2] = v.z;
    }
  }
}

void billboard_vertex_colours(const glm::vec3* centres, const glm::vec2* sizes,
                              const float* rotation, const int* index, std::size_t n,
                              const float* caf, std::size_t q, const ShadeFrame& frame,
                              const std::vector<ShadeLight>& lights, const ShadeParams& params,
                              glm::vec3 right, glm::vec3 up, float* out, float* corners,
                              int threads) {
  std::vector<float> local;
  if (corners == nullptr) {
    local.resize(n * 12);
    corners = local.data();
  }
  billboard_corners(centres, sizes, rotation, n, right, up, corners);
  std::vector<glm::vec3> points(n * 4);
  std::vector<int> vertex_index(n * 4);
  for (std::size_t v = 0; v < n * 4; ++v) {
    points[v] = glm::vec3(corners[3 * v], corners[3 * v + 1], corners[3 * v + 2]);
    vertex_index[v] = index[v / 4];
  }
  billboard_shade(points.data(), vertex_index.data(), n * 4, caf, q, frame, lights, params, out,
                  threads);
}

}  // namespace cumuli
