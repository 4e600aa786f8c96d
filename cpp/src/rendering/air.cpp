#include "cumuli/rendering/air.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <glm/geometric.hpp>

#include "cumuli/parallel.hpp"

namespace cumuli {

void AirParams::validate() const {
  if (!(std::isfinite(extinction) && extinction >= 0.0f))
    throw std::invalid_argument("air extinction must be finite and >= 0");
  if (!(std::isfinite(height) && height >= 0.0f))
    throw std::invalid_argument("air height must be finite and >= 0");
  if (!(std::isfinite(haze) && haze >= 0.0f))
    throw std::invalid_argument("haze must be finite and >= 0");
  if (haze > 0.0f) phase.validate();
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// 1 − e^{−k·t} in float32 (1 where t is infinite), as air.py's _fade (expm1 in float64, then
// rounded). glibc's expm1 was a third of the pass's time (once per pixel), its exp a fraction of
// that: 1 − e^{−x} in float64 loses ~10⁻¹⁶/x of relative accuracy, far below float32's rounding
// for x ≥ 10⁻⁵, and below it x·(1 − x/2) is within x²/6 of it. The same float32 either way but
// for a rare last-bit rounding.
float fade(double k, double t) {
  if (!std::isfinite(t)) return 1.0f;
  const double x = k * t;
  return static_cast<float>(x < 1e-5 ? x * (1.0 - 0.5 * x) : 1.0 - std::exp(-x));
}

// Distance along the ray to the ground plane, +∞ where it misses it (or there is none).
double ground_distance(const GroundParams& ground, double above, double dy) {
  if (!ground.enabled || !(dy < 0.0 && above > 0.0)) return kInf;
  return above / -dy;
}

// The midpoint of the ray's chord through the first box it enters (from 0 when it starts
// inside), NaN where it enters none.
double cloud_depth(const std::vector<Box>& boxes, const double o[3], const double d[3]) {
  double depth = std::numeric_limits<double>::quiet_NaN(), entry = kInf;
  double inv[3];
  for (int k = 0; k < 3; ++k) inv[k] = 1.0 / d[k];
  for (const Box& b : boxes) {
    double t0 = 0.0, t1 = kInf;
    for (int k = 0; k < 3; ++k) {
      double a = (static_cast<double>(b.lo[k]) - o[k]) * inv[k];
      double c = (static_cast<double>(b.hi[k]) - o[k]) * inv[k];
      // A ray parallel to a slab's faces: inside it (NaN on a face) or not at all.
      if (std::isnan(a)) a = -kInf;
      if (std::isnan(c)) c = kInf;
      t0 = std::max(t0, std::min(a, c));
      t1 = std::min(t1, std::max(a, c));
    }
    if (t1 >= t0 && t0 < entry) {
      entry = t0;
      depth = 0.5 * (t0 + t1);
    }
  }
  return depth;
}

// The aureole's phase at cosine c, in float64 (air.py's phase_values, whose Mie phase is the
// core's float32 approx_mie: here the same blend in float64, d^{3/2} as d·√d, a pixel's worth
// of pow calls fewer; it agrees to float rounding).
double aureole_phase(const PhysicalParams& p, double c) {
  constexpr double kFourPi = 12.566370614359172;
  auto hg = [c](double g) {
    const double d = 1.0 + g * g - 2.0 * g * c;
    return (1.0 - g * g) / (kFourPi * d * std::sqrt(d));
  };
  if (p.mie) {
    const ApproxMie& m = p.mie_params;
    const double gd = m.g_d, alpha = m.alpha, wd = m.w_d;
    const double draine =
        hg(gd) * (1.0 + alpha * c * c) / (1.0 + alpha * (1.0 + 2.0 * gd * gd) / 3.0);
    return (1.0 - wd) * hg(static_cast<double>(m.g_hg)) + wd * draine;
  }
  const double g1 = p.g1;
  if (!p.dual_hg) return hg(g1);
  const double w = p.blend;
  return (1.0 - w) * hg(g1) + w * hg(static_cast<double>(p.g2));
}

struct AirPass {
  const CameraParams& camera;
  const SkyParams& sky;
  const SunParams& sun;
  const GroundParams& ground;
  const std::vector<Box>& boxes;
  const AirParams& air;
  CameraRays rays;
  double origin[3];
  double above;  // the camera's height over the ground plane
  double rim;    // cos of the sun disc's radius: the aureole is held at the rim inside the disc
  double glow_rgb[3];
  bool fading, glowing;

  AirPass(const CameraParams& cam, int width, int height, const SkyParams& sk, const SunParams& sn,
          const GroundParams& gr, const std::vector<Box>& bx, const AirParams& a)
      : camera(cam), sky(sk), sun(sn), ground(gr), boxes(bx), air(a), rays(cam, width, height) {
    for (int k = 0; k < 3; ++k) origin[k] = static_cast<double>(cam.position[k]);
    above = origin[1] - static_cast<double>(gr.height);
    constexpr double kDegToRad = 0.017453292519943295;
    rim = std::cos(static_cast<double>(sk.sun_disc_radius) * kDegToRad);
    for (int k = 0; k < 3; ++k)
      glow_rgb[k] = static_cast<double>(a.haze) * static_cast<double>(sn.radiance[k]);
    fading = a.extinction > 0.0f;
    glowing =
        a.haze > 0.0f && (sn.radiance.x != 0.0f || sn.radiance.y != 0.0f || sn.radiance.z != 0.0f);
  }

  void pixel(int row, int col, float* px) const {
    const glm::vec3 dir = rays.direction(row, col);
    const double d[3] = {dir.x, dir.y, dir.z};
    glm::vec3 rgb(px[0], px[1], px[2]);
    const float alpha = std::clamp(px[3], 0.0f, 1.0f);
    // The background's share of the pixel: (1 − α)^{view_scale}, the δ-M view's transmittance
    // (the clouds' forward peak carries what lies behind on), and the clouds' the rest.
    // pow(1, v) is 1: the sky's pixels (most of a frame) skip the call.
    const float clear = alpha == 0.0f ? 1.0f : std::pow(1.0f - alpha, air.phase.view_scale);
    const float cover = 1.0f - clear;
    float front = 0.0f;
    if (fading) {
      const double k = air.extinction;
      double t_bg = ground_distance(ground, above, d[1]);
      if (!std::isfinite(t_bg)) {
        const double dy = std::abs(d[1]);
        t_bg = dy > 0.0 ? static_cast<double>(air.height) / dy : kInf;
      }
      const float behind = fade(k, t_bg);
      const glm::vec3 horizon = sky.horizon;
      glm::vec3 bg = rgb;  // where nothing covers the pixel, its colour is its background
      if (alpha > 0.0f && alpha < 1.0f) bg = background(sky, sun, ground, camera.position, dir);
      glm::vec3 faded = bg + behind * (horizon - bg);
      if (alpha > 0.0f) {
        const double depth = cloud_depth(boxes, origin, d);
        front = fade(k, std::isnan(depth) ? 0.0 : depth);
        const glm::vec3 clouds = rgb - clear * bg;  // the clouds' own (premultiplied) radiance
        faded = clouds + front * (cover * horizon - clouds) + clear * faded;
      }
      rgb = faded;
    }
    if (glowing) {
      const double c = d[0] * static_cast<double>(sun.direction.x) +
                       d[1] * static_cast<double>(sun.direction.y) +
                       d[2] * static_cast<double>(sun.direction.z);
      const double p = aureole_phase(air.phase, std::min(c, rim));
      const float share = clear + cover * front;
      for (int k = 0; k < 3; ++k) rgb[k] += static_cast<float>(p * glow_rgb[k]) * share;
    }
    px[0] = rgb.x;
    px[1] = rgb.y;
    px[2] = rgb.z;
  }
};

// One row of the tent along x (edges clamped): dst = ¼·left + ½·centre + ¼·right.
void tent_row(const float* src, float* dst, int width) {
  for (int c = 0; c < width; ++c) {
    const float* l = src + 4 * std::max(c - 1, 0);
    const float* m = src + 4 * c;
    const float* r = src + 4 * std::min(c + 1, width - 1);
    for (int k = 0; k < 4; ++k) dst[4 * c + k] = 0.25f * l[k] + 0.5f * m[k] + 0.25f * r[k];
  }
}

}  // namespace

void finish_physical(const float* rgba, float* out, int width, int height,
                     const CameraParams& camera, const SkyParams& sky, const SunParams& sun,
                     const GroundParams& ground, const std::vector<Box>& boxes,
                     const AirParams& air, int threads, const std::uint8_t* unfiltered) {
  if (width < 1 || height < 1) throw std::invalid_argument("width and height must be >= 1");
  camera.validate();
  air.validate();
  const AirPass pass(camera, width, height, sky, sun, ground, boxes, air);
  const std::size_t row_floats = static_cast<std::size_t>(width) * 4;
  constexpr int kBlockRows = 32;  // the resolve's rows per block (below)
  const int blocks = (height + kBlockRows - 1) / kBlockRows;
  // In place, a block of the resolve reads the edge rows of its neighbours, which they may have
  // written already: those rows (each block's first and last) are read from copies made first.
  auto is_edge = [&](int r) {
    return r % kBlockRows == 0 || r == std::min(height, (r / kBlockRows + 1) * kBlockRows) - 1;
  };
  std::vector<float> edge_rows;  // block b's first row at slot 2b, its last at 2b + 1
  auto edge_copy = [&](int r) {
    const int slot = 2 * (r / kBlockRows) + (r % kBlockRows == 0 ? 0 : 1);
    return edge_rows.data() + static_cast<std::size_t>(slot) * row_floats;
  };
  if (rgba == out && air.resolve) {
    edge_rows.resize(static_cast<std::size_t>(blocks) * 2 * row_floats);
    for (int r = 0; r < height; ++r)
      if (is_edge(r)) std::copy_n(rgba + r * row_floats, row_floats, edge_copy(r));
  }
  // Row r of the image as it came in.
  auto source_row = [&](int r) -> const float* {
    return !edge_rows.empty() && is_edge(r) ? edge_copy(r) : rgba + r * row_floats;
  };
  // Row r seen through the air, into `dst` (which may be the row itself).
  auto air_row = [&](int r, float* dst) {
    const float* src = source_row(r);
    if (src != dst) std::copy_n(src, row_floats, dst);
    if (pass.fading || pass.glowing)
      for (int c = 0; c < width; ++c) pass.pixel(r, c, dst + 4 * c);
  };
  if (!air.resolve) {
    parallel_chunks(static_cast<std::size_t>(height), threads, [&](std::size_t r0, std::size_t r1) {
      for (std::size_t r = r0; r < r1; ++r) air_row(static_cast<int>(r), out + r * row_floats);
    });
    return;
  }
  // The tent needs each row's neighbours through the air and filtered along x: a block of rows
  // keeps the last three in a ring, and computes the two rows beyond its ends itself (a few
  // per cent more air) instead of holding a whole second image. Within a block, row r is read
  // (into the ring) before it is written, so the block may write over its own input.
  parallel_chunks(static_cast<std::size_t>(blocks), threads, [&](std::size_t b0, std::size_t b1) {
    std::vector<float> aired(3 * row_floats), across(3 * row_floats);
    auto ring = [&](std::vector<float>& v, int r) { return v.data() + (r % 3) * row_floats; };
    auto prepare = [&](int r) {  // row r (in the image) through the air and along x
      air_row(r, ring(aired, r + 1));
      tent_row(ring(aired, r + 1), ring(across, r + 1), width);
    };
    for (std::size_t b = b0; b < b1; ++b) {
      const int r0 = static_cast<int>(b) * kBlockRows;
      const int r1 = std::min(height, r0 + kBlockRows);
      // Ring slot (r + 1) % 3 holds row r; row −1 and row `height` are copies of the edge rows.
      prepare(r0);
      if (r0 > 0) prepare(r0 - 1);
      for (int r = r0; r < r1; ++r) {
        if (r + 1 < height) prepare(r + 1);
        const float* up = ring(across, (r > 0 ? r - 1 : r) + 1);
        const float* mid = ring(across, r + 1);
        const float* down = ring(across, (r + 1 < height ? r + 1 : r) + 1);
        const float* own = ring(aired, r + 1);
        float* dst = out + static_cast<std::size_t>(r) * row_floats;
        const std::uint8_t* keep =
            unfiltered != nullptr ? unfiltered + static_cast<std::size_t>(r) * width : nullptr;
        for (std::size_t i = 0; i < row_floats; ++i)
          dst[i] = keep != nullptr && keep[i / 4] != 0
                       ? own[i]
                       : 0.25f * up[i] + 0.5f * mid[i] + 0.25f * down[i];
      }
    }
  });
}

}  // namespace cumuli
