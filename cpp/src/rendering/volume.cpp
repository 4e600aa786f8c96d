#include "cumuli/rendering/volume.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>

#include "cumuli/parallel.hpp"

namespace cumuli {

namespace {
constexpr float kInv4Pi = 0.0795774715459477f;

// One axis of the B-spline at texel coordinate u (texel i's centre at i + ½): the four
// clamped texel indices i − 1 … i + 2 and their weights.
inline void bspline_axis(float u, int n, int idx[4], float w[4]) {
  const float x = u - 0.5f;
  const float fl = std::floor(x);
  const float f = x - fl;
  const float f2 = f * f, f3 = f2 * f;
  w[0] = (1.0f - 3.0f * f + 3.0f * f2 - f3) / 6.0f;
  w[1] = (4.0f - 6.0f * f2 + 3.0f * f3) / 6.0f;
  w[2] = (1.0f + 3.0f * f + 3.0f * f2 - 3.0f * f3) / 6.0f;
  w[3] = f3 / 6.0f;
  const int i = static_cast<int>(fl);
  for (int k = 0; k < 4; ++k) idx[k] = std::clamp(i - 1 + k, 0, n - 1);
}
}  // namespace

float sample_cubic_bspline(const float* vol, const VolumeGrid& g, glm::vec3 p) {
  // The 64 taps, separably (x, then y, then z): the same sum as the GLSL's eight trilinear
  // lookups at shifted points, up to float rounding.
  const glm::vec3 u = (p - g.box.lo) / g.voxel_size();
  int ix[4], iy[4], iz[4];
  float wx[4], wy[4], wz[4];
  bspline_axis(u.x, g.w, ix, wx);
  bspline_axis(u.y, g.h, iy, wy);
  bspline_axis(u.z, g.d, iz, wz);
  const std::size_t W = static_cast<std::size_t>(g.w), H = static_cast<std::size_t>(g.h);
  float sum = 0.0f;
  for (int c = 0; c < 4; ++c) {
    float plane = 0.0f;
    for (int b = 0; b < 4; ++b) {
      const float* row = vol + (static_cast<std::size_t>(iz[c]) * H + iy[b]) * W;
      plane += wy[b] *
               (wx[0] * row[ix[0]] + wx[1] * row[ix[1]] + wx[2] * row[ix[2]] + wx[3] * row[ix[3]]);
    }
    sum += wz[c] * plane;
  }
  return sum;
}

float erode_density(float rho, glm::vec3 p, const VolumeRenderParams& params) {
  if (!(params.detail > 0.0f) || params.noise == nullptr || !(rho > 0.0f)) return rho;
  float top = 0.0f, a = 1.0f;
  for (int i = 0; i < params.detail_fbm.octaves; ++i) {
    a *= params.detail_fbm.gain;
    top += a;
  }
  const float n = top > 0.0f ? params.noise->fbm(p, params.detail_fbm) / top : 0.0f;
  const float e = params.detail * n;
  const float rn = std::min(rho * params.detail_inv_max, 1.0f);
  return std::max(rn - e, 0.0f) / (1.0f - e) / params.detail_inv_max;
}

std::vector<float> render_volume_cpu(const float* density, const float* light, const VolumeGrid& g,
                                     const VolumeCameraRays& cam, const VolumeRenderParams& p,
                                     int threads) {
  g.validate();
  if (p.width < 1 || p.height < 1) throw std::invalid_argument("width and height must be >= 1");
  if (!(p.step > 0.0f) || !std::isfinite(p.step)) throw std::invalid_argument("step must be > 0");
  if (p.solids.size() > static_cast<std::size_t>(kMaxSolids))
    throw std::invalid_argument("at most 16 solids");
  for (const auto& s : p.solids) s.validate();
  if (p.physical) {
    p.phys.validate();
    if (p.grids == nullptr)
      throw std::invalid_argument("the physical mode needs the physical light");
    p.grids->validate();
    if (!(p.detail >= 0.0f && p.detail <= 0.95f))
      throw std::invalid_argument("detail must be in [0, 0.95]");
    if (!(p.detail_inv_max > 0.0f) || !std::isfinite(p.detail_inv_max))
      throw std::invalid_argument("detail_inv_max must be finite and > 0");
    if (p.detail > 0.0f) {
      if (p.noise == nullptr) throw std::invalid_argument("detail needs the noise");
      p.detail_fbm.validate();
    }
  }
  const std::size_t npix = static_cast<std::size_t>(p.width) * p.height;
  std::vector<float> img(npix * 4);
  const float aspect = static_cast<float>(p.width) / static_cast<float>(p.height);
  parallel_for(npix, threads, [&](std::size_t i) {
    const int row = static_cast<int>(i / p.width), col = static_cast<int>(i % p.width);
    const float sx = (2.0f * (col + 0.5f) / p.width - 1.0f) * cam.tan_half_fov * aspect;
    const float sy = (1.0f - 2.0f * (row + 0.5f) / p.height) * cam.tan_half_fov;
    const glm::vec3 d = glm::normalize(cam.forward + sx * cam.right + sy * cam.up);
    glm::vec3 colour(0.0f);
    float T = 1.0f;
    float T_view = 1.0f;  // the radiance's transmittance (the physical mode's δ-M view; else T)
    Interval span;
    const float t_solid = p.solids.empty() ? kNoSolid : nearest_solid(p.solids, cam.position, d);
    const bool hit = intersect(g.box, cam.position, 1.0f / d, span);
    if (hit) span.t_out = std::min(span.t_out, t_solid);
    if (hit && span.t_out > std::max(span.t_in, 0.0f)) {
      const float t0 = std::max(span.t_in, 0.0f);
      const float len = span.t_out - t0;
      const int n = std::max(1, static_cast<int>(std::ceil(len / p.step)));
      const float h = len / static_cast<float>(n);
      if (p.physical) {
        const OctaveTerms terms(p.phys, glm::dot(d, p.sun.direction));
        const float xi = jitter(row, col, p.phys.jitter_seed);
        for (int k = 0; k < n && T_view >= p.phys.min_transmittance; ++k) {
          const glm::vec3 x = cam.position + (t0 + (static_cast<float>(k) + xi) * h) * d;
          float rho =
              p.cubic ? sample_cubic_bspline(density, g, x) : sample_trilinear(density, g, x);
          if (!(rho > 0.0f)) continue;
          rho = erode_density(rho, x, p);
          if (!(rho > 0.0f)) continue;
          const float dtau = std::exp(-p.sigma_t * rho * h);
          // The radiance sees σ·view_scale (the δ-M view); each unit of σ emits the source.
          const float dview = std::exp(-p.sigma_t * rho * p.phys.view_scale * h);
          colour += T_view * ((1.0f - dview) / p.phys.view_scale) *
                    p.grids->source(x, terms, p.sun.radiance, p.phys.albedo, p.phys.view_diffuse);
          T *= dtau;
          T_view *= dview;
        }
        // Stopped: opaque, as the 2018 marcher's (no light from behind leaks through the rest).
        if (T_view < p.phys.min_transmittance) T = T_view = 0.0f;
      }
      const float phase = henyey_greenstein(p.g, glm::dot(d, p.sun.direction));
      for (int k = 0; k < n && T >= kVolumeMinTransmittance && !p.physical; ++k) {
        const glm::vec3 x = cam.position + (t0 + (k + 0.5f) * h) * d;
        const float rho = sample_trilinear(density, g, x);
        if (rho <= 0.0f) continue;
        float L[4];
        sample_trilinear(light, g, 4, x, L);
        const glm::vec3 S =
            p.albedo * (p.sun.radiance * (L[0] * phase) + glm::vec3(L[1], L[2], L[3]) * kInv4Pi);
        const float dtau = std::exp(-p.sigma_t * rho * h);
        colour += T * (1.0f - dtau) * S;
        T *= dtau;
      }
      if (!p.physical) T_view = T;
    }
    const glm::vec3 rgb = p.with_sky ? colour + T_view * sky_radiance(p.sky, p.sun, d) : colour;
    float* px = &img[i * 4];
    px[0] = rgb.x;
    px[1] = rgb.y;
    px[2] = rgb.z;
    px[3] = 1.0f - T;
  });
  return img;
}

}  // namespace cumuli
