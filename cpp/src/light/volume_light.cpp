#include "cumuli/light/volume_light.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <glm/ext/vector_double3.hpp>

#include "cumuli/parallel.hpp"
#include "cumuli/rng.hpp"

namespace cumuli {

namespace {
constexpr double kPi = 3.14159265358979323846;
const float kSqrt4Pi = static_cast<float>(std::sqrt(4.0 * kPi));

void check_order(int order) {
  if (order < 1 || order > kMaxShOrder)
    throw std::invalid_argument("sh_order must be in [1, 4]");
}

void check_step(float step_voxels) {
  if (!(step_voxels > 0.0f) || !std::isfinite(step_voxels))
    throw std::invalid_argument("step must be finite and > 0 (in voxels)");
}

// Per-axis clamp-to-edge split of texel coordinate u (GL texel centres at i + ½).
inline void split_axis(float u, int n, int& i0, int& i1, float& f) {
  const float s = u - 0.5f;
  const float fl = std::floor(s);
  f = s - fl;
  const int i = static_cast<int>(fl);
  i0 = std::clamp(i, 0, n - 1);
  i1 = std::clamp(i + 1, 0, n - 1);
}
}  // namespace

void VolumeGrid::validate() const {
  if (w < 1 || h < 1 || d < 1) throw std::invalid_argument("volume shape must be >= 1 on every axis");
  for (int k = 0; k < 3; ++k)
    if (!(box.hi[k] > box.lo[k]) || !std::isfinite(box.lo[k]) || !std::isfinite(box.hi[k]))
      throw std::invalid_argument("box_max must be greater than box_min on every axis (finite)");
}

void sample_trilinear(const float* vol, const VolumeGrid& g, int channels, glm::vec3 p, float* out) {
  const glm::vec3 u = (p - g.box.lo) / g.voxel_size();
  int x0, x1, y0, y1, z0, z1;
  float fx, fy, fz;
  split_axis(u.x, g.w, x0, x1, fx);
  split_axis(u.y, g.h, y0, y1, fy);
  split_axis(u.z, g.d, z0, z1, fz);
  const std::size_t W = static_cast<std::size_t>(g.w), H = static_cast<std::size_t>(g.h);
  auto at = [&](int x, int y, int z) { return vol + ((z * H + y) * W + x) * channels; };
  for (int c = 0; c < channels; ++c) {
    const float c00 = at(x0, y0, z0)[c] + fx * (at(x1, y0, z0)[c] - at(x0, y0, z0)[c]);
    const float c10 = at(x0, y1, z0)[c] + fx * (at(x1, y1, z0)[c] - at(x0, y1, z0)[c]);
    const float c01 = at(x0, y0, z1)[c] + fx * (at(x1, y0, z1)[c] - at(x0, y0, z1)[c]);
    const float c11 = at(x0, y1, z1)[c] + fx * (at(x1, y1, z1)[c] - at(x0, y1, z1)[c]);
    const float c0 = c00 + fy * (c10 - c00);
    const float c1 = c01 + fy * (c11 - c01);
    out[c] = c0 + fz * (c1 - c0);
  }
}

float sample_trilinear(const float* vol, const VolumeGrid& g, glm::vec3 p) {
  float v;
  sample_trilinear(vol, g, 1, p, &v);
  return v;
}

float optical_depth_ray(const float* vol, const VolumeGrid& g, glm::vec3 p, glm::vec3 dir,
                        float step_voxels) {
  Interval span;
  if (!intersect(g.box, p, 1.0f / dir, span) || span.t_out <= 0.0f) return 0.0f;
  const float t0 = std::max(span.t_in, 0.0f);
  const float len = span.t_out - t0;
  if (len <= 0.0f) return 0.0f;
  const glm::vec3 vs = g.voxel_size();
  const float dt = step_voxels * std::min(vs.x, std::min(vs.y, vs.z));
  const int n = std::max(1, static_cast<int>(std::ceil(len / dt)));
  const float h = len / static_cast<float>(n);
  double sum = 0.0;
  for (int i = 0; i < n; ++i)
    sum += sample_trilinear(vol, g, p + (t0 + (i + 0.5f) * h) * dir);
  return static_cast<float>(sum * h);
}

std::vector<float> sun_optical_depth(const float* volumes, int count, const VolumeGrid& g,
                                     glm::vec3 to_sun, float step_voxels, int threads) {
  g.validate();
  check_step(step_voxels);
  const float len = glm::length(to_sun);
  if (!(len > 0.0f) || !std::isfinite(len)) throw std::invalid_argument("sun direction must be non-zero");
  const glm::vec3 dir = to_sun / len;
  const std::size_t nv = g.voxels();
  std::vector<float> out(nv * static_cast<std::size_t>(count));
  parallel_for(out.size(), threads, [&](std::size_t i) {
    const std::size_t v = i % nv;
    const int x = static_cast<int>(v % g.w), y = static_cast<int>((v / g.w) % g.h),
              z = static_cast<int>(v / (static_cast<std::size_t>(g.w) * g.h));
    out[i] = optical_depth_ray(volumes + (i / nv) * nv, g, g.centre(x, y, z), dir, step_voxels);
  });
  return out;
}

// --- spherical harmonics -------------------------------------------------------------------

void sh_eval(int order, glm::vec3 d, float* out) {
  const float x = d.x, y = d.y, z = d.z;
  out[0] = 0.282094791773878f;
  if (order < 2) return;
  out[1] = 0.488602511902920f * y;
  out[2] = 0.488602511902920f * z;
  out[3] = 0.488602511902920f * x;
  if (order < 3) return;
  out[4] = 1.092548430592079f * x * y;
  out[5] = 1.092548430592079f * y * z;
  out[6] = 0.315391565252520f * (3.0f * z * z - 1.0f);
  out[7] = 1.092548430592079f * x * z;
  out[8] = 0.546274215296040f * (x * x - y * y);
  if (order < 4) return;
  out[9] = 0.590043589926644f * y * (3.0f * x * x - y * y);
  out[10] = 2.890611442640554f * x * y * z;
  out[11] = 0.457045799464466f * y * (5.0f * z * z - 1.0f);
  out[12] = 0.373176332590115f * z * (5.0f * z * z - 3.0f);
  out[13] = 0.457045799464466f * x * (5.0f * z * z - 1.0f);
  out[14] = 1.445305721320277f * z * (x * x - y * y);
  out[15] = 0.590043589926644f * x * (x * x - 3.0f * y * y);
}

SphereQuadrature::SphereQuadrature(int n_theta) {
  if (n_theta < 1 || n_theta > 64) throw std::invalid_argument("sh_samples must be in [1, 64]");
  const int n = n_theta, m = 2 * n_theta;
  for (int i = 0; i < n; ++i) {
    // Gauss–Legendre node i by Newton's method on P_n from the Chebyshev guess.
    double mu = std::cos(kPi * (i + 0.75) / (n + 0.5)), dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = mu;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * mu * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (mu * p1 - p0) / (mu * mu - 1.0);
      const double step = p1 / dp;
      mu -= step;
      if (std::abs(step) < 1e-15) break;
    }
    const double wmu = 2.0 / ((1.0 - mu * mu) * dp * dp);
    const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    for (int j = 0; j < m; ++j) {
      const double phi = 2.0 * kPi * (j + 0.5) / m;
      dirs.emplace_back(static_cast<float>(s * std::cos(phi)), static_cast<float>(s * std::sin(phi)),
                        static_cast<float>(mu));
      weights.push_back(static_cast<float>(wmu * 2.0 * kPi / m));
    }
  }
}

std::vector<float> sh_optical_depth(const float* volumes, int count, const VolumeGrid& g,
                                    int order, int n_theta, float step_voxels, int threads) {
  g.validate();
  check_order(order);
  check_step(step_voxels);
  const SphereQuadrature quad(n_theta);
  const int nc = order * order;
  std::vector<float> basis(quad.dirs.size() * nc);
  for (std::size_t k = 0; k < quad.dirs.size(); ++k) sh_eval(order, quad.dirs[k], &basis[k * nc]);
  const std::size_t nv = g.voxels();
  std::vector<float> out(nv * static_cast<std::size_t>(count) * nc);
  parallel_for(nv * static_cast<std::size_t>(count), threads, [&](std::size_t i) {
    const std::size_t v = i % nv;
    const int x = static_cast<int>(v % g.w), y = static_cast<int>((v / g.w) % g.h),
              z = static_cast<int>(v / (static_cast<std::size_t>(g.w) * g.h));
    const glm::vec3 p = g.centre(x, y, z);
    const float* vol = volumes + (i / nv) * nv;
    double acc[kMaxShOrder * kMaxShOrder] = {};
    for (std::size_t k = 0; k < quad.dirs.size(); ++k) {
      const double f = optical_depth_ray(vol, g, p, quad.dirs[k], step_voxels) * quad.weights[k];
      for (int c = 0; c < nc; ++c) acc[c] += f * basis[k * nc + c];
    }
    for (int c = 0; c < nc; ++c) out[i * nc + c] = static_cast<float>(acc[c]);
  });
  return out;
}

std::vector<float> sky_sh(const SkyParams& sky_params, int order, int n_theta) {
  check_order(order);
  SkyParams no_disc = sky_params;
  no_disc.sun_disc_intensity = 0.0f;
  const SunParams sun;
  const SphereQuadrature quad(n_theta);
  const int nc = order * order;
  std::vector<double> acc(3 * static_cast<std::size_t>(nc), 0.0);
  float y[kMaxShOrder * kMaxShOrder];
  for (std::size_t k = 0; k < quad.dirs.size(); ++k) {
    sh_eval(order, quad.dirs[k], y);
    const glm::vec3 L3 = sky_radiance(no_disc, sun, quad.dirs[k]);
    for (int ch = 0; ch < 3; ++ch) {
      const float L = L3[ch];
      for (int c = 0; c < nc; ++c) acc[ch * nc + c] += static_cast<double>(L) * quad.weights[k] * y[c];
    }
  }
  return std::vector<float>(acc.begin(), acc.end());
}

std::vector<float> sh_triple(int order) {
  check_order(order);
  // Degree 3(order − 1) polynomials need n_theta ≥ (3(order − 1) + 1)/2; 2·order is enough.
  const SphereQuadrature quad(2 * order);
  const int nc = order * order;
  std::vector<double> acc(static_cast<std::size_t>(nc) * nc * nc, 0.0);
  float y[kMaxShOrder * kMaxShOrder];
  for (std::size_t q = 0; q < quad.dirs.size(); ++q) {
    sh_eval(order, quad.dirs[q], y);
    for (int i = 0; i < nc; ++i)
      for (int j = 0; j < nc; ++j)
        for (int k = 0; k < nc; ++k)
          acc[(static_cast<std::size_t>(i) * nc + j) * nc + k] +=
              static_cast<double>(quad.weights[q]) * y[i] * y[j] * y[k];
  }
  return std::vector<float>(acc.begin(), acc.end());
}

ShExpTable shexp_squaring(int order) {
  ShExpTable t;
  t.order = order;
  t.squaring = true;
  t.triple = sh_triple(order);
  t.a.assign(1, 1.0f);
  t.b.assign(1, 1.0f);
  return t;
}

namespace {
// c = projection of the product of the functions with coefficients a and b.
void sh_product(int nc, const float* triple, const double* a, const double* b, double* c) {
  for (int k = 0; k < nc; ++k) c[k] = 0.0;
  for (int i = 0; i < nc; ++i) {
    if (a[i] == 0.0) continue;
    for (int j = 0; j < nc; ++j) {
      const double ab = a[i] * b[j];
      const float* t = triple + (static_cast<std::size_t>(i) * nc + j) * nc;
      for (int k = 0; k < nc; ++k) c[k] += ab * t[k];
    }
  }
}
}  // namespace

void ShExpTable::apply(const float* g, float* out) const {
  const int nc = order * order;
  if (squaring) {
    double n2 = 0.0;
    for (int c = 1; c < nc; ++c) n2 += static_cast<double>(g[c]) * g[c];
    const double norm = std::sqrt(n2);
    int k = 0;
    while (norm / std::ldexp(1.0, k) > 0.25 && k < 40) ++k;
    const double s = std::ldexp(1.0, -k);
    double h[kMaxShOrder * kMaxShOrder]{}, e[kMaxShOrder * kMaxShOrder]{},
        tmp[kMaxShOrder * kMaxShOrder]{};
    h[0] = 0.0;
    for (int c = 1; c < nc; ++c) h[c] = s * g[c];
    sh_product(nc, triple.data(), h, h, tmp);  // exp*(ĥ) ≈ 1 + ĥ + ½ ĥ*ĥ
    for (int c = 0; c < nc; ++c) e[c] = h[c] + 0.5 * tmp[c];
    e[0] += kSqrt4Pi;
    for (int i = 0; i < k; ++i) {
      sh_product(nc, triple.data(), e, e, tmp);
      for (int c = 0; c < nc; ++c) e[c] = tmp[c];
    }
    const double scale = std::exp(static_cast<double>(g[0]) / kSqrt4Pi);
    for (int c = 0; c < nc; ++c) out[c] = static_cast<float>(scale * e[c]);
    return;
  }
  double n2 = 0.0;
  for (int c = 1; c < nc; ++c) n2 += static_cast<double>(g[c]) * g[c];
  const float norm = static_cast<float>(std::sqrt(n2));
  const int bins = static_cast<int>(a.size());
  float av = a[0], bv = b[0];
  if (bins > 1 && max_norm > 0.0f) {
    const float s = std::clamp(norm / max_norm * bins - 0.5f, 0.0f, static_cast<float>(bins - 1));
    const int i0 = std::min(static_cast<int>(s), bins - 2);
    const float f = s - static_cast<float>(i0);
    av = a[i0] + f * (a[i0 + 1] - a[i0]);
    bv = b[i0] + f * (b[i0 + 1] - b[i0]);
  }
  const float scale = std::exp(g[0] / kSqrt4Pi);
  out[0] = scale * av * kSqrt4Pi;
  for (int c = 1; c < nc; ++c) out[c] = scale * bv * g[c];
}

ShExpTable fit_shexp(const float* f, std::size_t count, int order, float sigma_t, int bins,
                     int n_theta) {
  check_order(order);
  if (bins < 1 || bins > 4096) throw std::invalid_argument("shexp_bins must be in [1, 4096]");
  if (!(sigma_t >= 0.0f) || !std::isfinite(sigma_t))
    throw std::invalid_argument("sigma_t must be finite and >= 0");
  const SphereQuadrature quad(n_theta);
  const int nc = order * order;
  std::vector<float> basis(quad.dirs.size() * nc);
  for (std::size_t k = 0; k < quad.dirs.size(); ++k) sh_eval(order, quad.dirs[k], &basis[k * nc]);

  ShExpTable t;
  t.order = order;
  std::vector<float> norms(count);
  for (std::size_t i = 0; i < count; ++i) {
    double n2 = 0.0;
    for (int c = 1; c < nc; ++c) n2 += std::pow(static_cast<double>(sigma_t) * f[i * nc + c], 2);
    norms[i] = static_cast<float>(std::sqrt(n2));
    t.max_norm = std::max(t.max_norm, norms[i]);
  }
  std::vector<double> t0(bins, 0.0), num(bins, 0.0), den(bins, 0.0);
  std::vector<int> cnt(bins, 0);
  for (std::size_t i = 0; i < count; ++i) {
    float gh[kMaxShOrder * kMaxShOrder];
    gh[0] = 0.0f;
    for (int c = 1; c < nc; ++c) gh[c] = -sigma_t * f[i * nc + c];
    // τ̃ = projection of exp(ĝ·y(ω)): the transmittance over exp(g₀/√4π).
    double tau[kMaxShOrder * kMaxShOrder] = {};
    for (std::size_t k = 0; k < quad.dirs.size(); ++k) {
      double e = 0.0;
      for (int c = 1; c < nc; ++c) e += static_cast<double>(gh[c]) * basis[k * nc + c];
      const double v = std::exp(e) * quad.weights[k];
      for (int c = 0; c < nc; ++c) tau[c] += v * basis[k * nc + c];
    }
    const int bin = t.max_norm > 0.0f
                        ? std::min(bins - 1, static_cast<int>(norms[i] / t.max_norm * bins))
                        : 0;
    t0[bin] += tau[0];
    for (int c = 1; c < nc; ++c) {
      num[bin] += tau[c] * gh[c];
      den[bin] += static_cast<double>(gh[c]) * gh[c];
    }
    ++cnt[bin];
  }
  t.a.assign(bins, 1.0f);
  t.b.assign(bins, 1.0f);
  std::vector<int> filled;
  for (int i = 0; i < bins; ++i) {
    if (cnt[i] == 0) continue;
    filled.push_back(i);
    t.a[i] = static_cast<float>(t0[i] / cnt[i] / kSqrt4Pi);
    // With ĝ = 0 exp(ĝ·y) = 1 and b is free: its small-norm limit (exp ≈ 1 + x) is 1.
    t.b[i] = den[i] > 1e-20 ? static_cast<float>(num[i] / den[i]) : 1.0f;
  }
  for (int i = 0; i < bins; ++i) {
    if (cnt[i] != 0 || filled.empty()) continue;
    int best = filled[0];
    for (int j : filled)
      if (std::abs(j - i) < std::abs(best - i)) best = j;
    t.a[i] = t.a[best];
    t.b[i] = t.b[best];
  }
  return t;
}

std::vector<float> light_volume(const float* f_sun, const float* f_sh, const VolumeGrid& g,
                                const ShExpTable& table, const float* sky_coeffs, float sigma_t,
                                int threads) {
  const int nc = table.order * table.order;
  const std::size_t nv = g.voxels();
  std::vector<float> out(nv * 4);
  parallel_for(nv, threads, [&](std::size_t v) {
    float gv[kMaxShOrder * kMaxShOrder], tau[kMaxShOrder * kMaxShOrder];
    for (int c = 0; c < nc; ++c) gv[c] = -sigma_t * f_sh[v * nc + c];
    table.apply(gv, tau);
    out[v * 4] = std::exp(-sigma_t * f_sun[v]);
    for (int ch = 0; ch < 3; ++ch) {
      double e = 0.0;
      for (int c = 0; c < nc; ++c) e += static_cast<double>(sky_coeffs[ch * nc + c]) * tau[c];
      // Band-limited products can ring slightly below zero; irradiance cannot.
      out[v * 4 + 1 + ch] = static_cast<float>(std::max(0.0, e));
    }
  });
  return out;
}

// --- multiple scattering ---------------------------------------------------------------------

std::vector<glm::vec3> volume_sample_points(const VolumeGrid& g, int count, std::uint64_t seed) {
  g.validate();
  if (count < 1 || count > (1 << 20)) throw std::invalid_argument("ms_points must be in [1, 2^20]");
  int m = 1;
  while (m * m * m < count) ++m;
  const int cells = m * m * m;
  std::vector<int> order(static_cast<std::size_t>(cells));
  for (int i = 0; i < cells; ++i) order[i] = i;
  Rng rng(seed);
  for (int i = cells - 1; i > 0; --i) {  // Fisher–Yates with cumuli's own uniform
    const int j = static_cast<int>(rng.uniform_double() * (i + 1));
    std::swap(order[i], order[std::min(j, i)]);
  }
  std::vector<glm::vec3> pts;
  pts.reserve(static_cast<std::size_t>(count));
  const glm::vec3 cell = (g.box.hi - g.box.lo) / static_cast<float>(m);
  for (int i = 0; i < count; ++i) {
    const int c = order[i];
    const glm::vec3 idx(c % m, (c / m) % m, c / (m * m));
    const glm::vec3 jitter(rng.uniform(), rng.uniform(), rng.uniform());
    pts.push_back(g.box.lo + (idx + jitter) * cell);
  }
  return pts;
}

float optical_depth_segment(const float* vol, const VolumeGrid& g, glm::vec3 a, glm::vec3 b,
                            float step_voxels) {
  const float len = glm::length(b - a);
  if (len <= 0.0f) return 0.0f;
  const glm::vec3 vs = g.voxel_size();
  const float dt = step_voxels * std::min(vs.x, std::min(vs.y, vs.z));
  const int n = std::max(1, static_cast<int>(std::ceil(len / dt)));
  const float h = len / static_cast<float>(n);
  const glm::vec3 dir = (b - a) / len;
  double sum = 0.0;
  for (int i = 0; i < n; ++i) sum += sample_trilinear(vol, g, a + ((i + 0.5f) * h) * dir);
  return static_cast<float>(sum * h);
}

std::vector<float> point_optical_depth(const float* volumes, int count, const VolumeGrid& g,
                                       const std::vector<glm::vec3>& points, float step_voxels,
                                       int threads) {
  g.validate();
  check_step(step_voxels);
  const std::size_t nv = g.voxels(), np = points.size();
  std::vector<float> out(static_cast<std::size_t>(count) * nv * np);
  parallel_for(static_cast<std::size_t>(count) * nv, threads, [&](std::size_t i) {
    const std::size_t v = i % nv;
    const int x = static_cast<int>(v % g.w), y = static_cast<int>((v / g.w) % g.h),
              z = static_cast<int>(v / (static_cast<std::size_t>(g.w) * g.h));
    const glm::vec3 p = g.centre(x, y, z);
    const float* vol = volumes + (i / nv) * nv;
    for (std::size_t k = 0; k < np; ++k)
      out[i * np + k] = optical_depth_segment(vol, g, p, points[k], step_voxels);
  });
  return out;
}

void add_multiple_scattering(const float* density, float* light, const VolumeGrid& g,
                             const float* point_depth, const std::vector<glm::vec3>& points,
                             glm::vec3 sun_radiance, float sigma_t, float albedo, int orders,
                             int threads) {
  g.validate();
  if (orders < 0 || orders > 16) throw std::invalid_argument("ms_orders must be in [0, 16]");
  if (orders == 0 || points.empty()) return;
  const std::size_t nv = g.voxels(), np = points.size();
  const glm::vec3 size = g.box.hi - g.box.lo;
  const double volume = static_cast<double>(size.x) * size.y * size.z;
  const float weight = static_cast<float>(volume / np);
  const float d_min = 0.5f * static_cast<float>(std::cbrt(volume / np));
  const float d2_min = d_min * d_min;
  // E of the previous order at the voxels (RGB), starting with the single scattering.
  std::vector<float> prev(nv * 3), total(nv * 3, 0.0f);
  for (std::size_t v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c) prev[v * 3 + c] = sun_radiance[c] * light[v * 4] + light[v * 4 + 1 + c];
  std::vector<glm::vec3> src(np);
  std::vector<float> next(nv * 3);
  for (int n = 0; n < orders; ++n) {
    for (std::size_t k = 0; k < np; ++k) {
      float e[3];
      sample_trilinear(prev.data(), g, 3, points[k], e);
      const float rho = sample_trilinear(density, g, points[k]);
      src[k] = (weight * sigma_t * rho * albedo * 0.0795774715459477f) * glm::vec3(e[0], e[1], e[2]);
    }
    parallel_for(nv, threads, [&](std::size_t v) {
      const int x = static_cast<int>(v % g.w), y = static_cast<int>((v / g.w) % g.h),
                z = static_cast<int>(v / (static_cast<std::size_t>(g.w) * g.h));
      const glm::vec3 p = g.centre(x, y, z);
      glm::dvec3 acc(0.0);
      for (std::size_t k = 0; k < np; ++k) {
        const glm::vec3 d = points[k] - p;
        const float g2 = std::max(glm::dot(d, d), d2_min);
        acc += glm::dvec3(src[k] * (std::exp(-sigma_t * point_depth[v * np + k]) / g2));
      }
      for (int c = 0; c < 3; ++c) next[v * 3 + c] = static_cast<float>(acc[c]);
    });
    for (std::size_t i = 0; i < nv * 3; ++i) total[i] += next[i];
    prev.swap(next);
  }
  for (std::size_t v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c) light[v * 4 + 1 + c] += total[v * 3 + c];
}

}  // namespace cumuli
