#include "cumuli/light/particles.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "cumuli/parallel.hpp"

namespace cumuli {

namespace {

constexpr float kFourPi = 12.566370614359172f;
// e^{−4.5} and the window's normaliser, written as literals so that the GLSL twin uses the very
// same float32 values.
constexpr float kGaussTail = 0.011108996538242306f;

float clamp_index(float v, int n) { return std::clamp(v, 0.0f, static_cast<float>(n - 1)); }

float lerp(float a, float b, float t) { return a + t * (b - a); }

}  // namespace

float splat_kernel(SplatKernel kernel, float peak, float d) {
  if (!(d < 1.0f)) return 0.0f;
  const float d2 = d * d;
  if (kernel == SplatKernel::Hermite) return peak * ((1.0f - 3.0f * d2) + 2.0f * d2 * d);
  return peak * ((std::exp(-4.5f * d2) - kGaussTail) / (1.0f - kGaussTail));
}

void ParticleLightSettings::validate() const {
  if (resolution < kMinResolution || resolution > kMaxResolution)
    throw std::invalid_argument("light_resolution must be in [8, 4096], got " +
                                std::to_string(resolution));
  if (!std::isfinite(solid_angle) || !(solid_angle > 0.0f) || solid_angle > kFourPi)
    throw std::invalid_argument("solid_angle must be in (0, 4π]");
  if (!std::isfinite(hg_g) || !(hg_g > -1.0f) || !(hg_g < 1.0f))
    throw std::invalid_argument("hg_g must be in (-1, 1)");
  if (!std::isfinite(peak) || !(peak > 0.0f) || peak > 1.0f)
    throw std::invalid_argument("peak must be in (0, 1]");
  if (!std::isfinite(readback_solid_angle) || !(readback_solid_angle > 0.0f) ||
      readback_solid_angle > kFourPi)
    throw std::invalid_argument("readback_solid_angle must be in (0, 4π]");
  if (quantize != 0 && quantize != 8) throw std::invalid_argument("quantize must be 0 or 8");
}

float forward_factor(float albedo, float tau, const ParticleLightSettings& settings) {
  if (!settings.forward) return 0.0f;
  return albedo * tau * settings.forward_phase() * settings.solid_angle / kFourPi;
}

void check_energy(const ParticleView& particles, const ParticleLightSettings& settings) {
  if (settings.allow_gain || !settings.forward) return;
  for (std::size_t k = 0; k < particles.n; ++k) {
    const float g = forward_factor(particles.albedo[k], particles.tau[k], settings);
    const float alpha = 1.0f - std::exp(-particles.tau[k]);
    if (g > alpha)
      throw std::invalid_argument(
          "solid_angle too large: particle " + std::to_string(k) +
          " scatters forward a·τ·p_fwd·γ/4π = " + std::to_string(g) +
          " > its opacity 1 − e^{−τ} = " + std::to_string(alpha) +
          ", so it would add light (lower solid_angle, or pass allow_gain=True)");
  }
}

LightFrame light_frame(const ParticleView& particles, glm::vec3 sun_direction) {
  LightFrame frame;
  const Sphere sphere = particle_sphere(particles);
  frame.centre = sphere.centre;
  frame.radius = sphere.radius;
  frame.forward = -sun_direction;
  // SkyWorks' degenerate-basis guard: a light straight up or down takes +x as its up.
  const glm::vec3 up = std::abs(frame.forward.y) > 1.0f - 1e-6f ? glm::vec3(1.0f, 0.0f, 0.0f)
                                                                : glm::vec3(0.0f, 1.0f, 0.0f);
  frame.right = glm::normalize(glm::cross(frame.forward, up));
  frame.up = glm::cross(frame.right, frame.forward);
  return frame;
}

void particle_shadow(const LightFrame& frame, const float* buffer, int n, const glm::vec3* points,
                     std::size_t count, float* out) {
  const float nl = static_cast<float>(n);
  const float two_r = 2.0f * frame.radius;
  for (std::size_t k = 0; k < count; ++k) {
    const glm::vec3 v = points[k] - frame.centre;
    const float x = (glm::dot(v, frame.right) + frame.radius) / two_r * nl;
    const float y = (glm::dot(v, frame.up) + frame.radius) / two_r * nl;
    if (!(glm::dot(v, frame.forward) >= -frame.radius) || !(x >= 0.0f && x <= nl) ||
        !(y >= 0.0f && y <= nl)) {
      out[k] = 1.0f;
      continue;
    }
    const float u = x - 0.5f, w = y - 0.5f;
    const float fu = std::floor(u), fw = std::floor(w);
    const float wx = u - fu, wy = w - fw;
    const int x0 = static_cast<int>(std::clamp(fu, 0.0f, nl - 1.0f));
    const int x1 = static_cast<int>(std::clamp(fu + 1.0f, 0.0f, nl - 1.0f));
    const int y0 = static_cast<int>(std::clamp(fw, 0.0f, nl - 1.0f));
    const int y1 = static_cast<int>(std::clamp(fw + 1.0f, 0.0f, nl - 1.0f));
    const auto at = [&](int xx, int yy) { return buffer[static_cast<std::size_t>(yy) * n + xx]; };
    const float a = at(x0, y0) + wx * (at(x1, y0) - at(x0, y0));
    const float b = at(x0, y1) + wx * (at(x1, y1) - at(x0, y1));
    out[k] = a + wy * (b - a);
  }
}

std::vector<LightSplat> light_splats(const ParticleView& particles, const LightFrame& frame,
                                     const ParticleLightSettings& settings) {
  const std::size_t n = particles.n;
  const float nl = static_cast<float>(settings.resolution);
  const float two_r = 2.0f * frame.radius;
  std::vector<float> t(n);
  std::vector<LightSplat> splats(n);
  for (std::size_t k = 0; k < n; ++k) {
    const glm::vec3 v = particles.centre(k) - frame.centre;
    t[k] = glm::dot(v, frame.forward);
    LightSplat& s = splats[k];
    s.x = (glm::dot(v, frame.right) + frame.radius) / two_r * nl;
    s.y = (glm::dot(v, frame.up) + frame.radius) / two_r * nl;
    s.r_px = particles.radii[k] * nl / two_r;
    s.forward = forward_factor(particles.albedo[k], particles.tau[k], settings);
    s.alpha = 1.0f - std::exp(-particles.tau[k]);
    s.index = static_cast<std::uint32_t>(k);
    if (settings.readback == Readback::SolidAngle) {
      // SkyWorks: a patch subtending γ_r at the distance from the light box's near plane.
      const float dist = t[k] + frame.radius;
      const float side =
          std::floor(std::sqrt(settings.readback_solid_angle * dist * dist) * nl / two_r);
      s.patch = static_cast<std::int32_t>(std::clamp(side, 1.0f, nl));
    }
  }
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return t[a] < t[b]; });
  std::vector<LightSplat> sorted(n);
  for (std::size_t i = 0; i < n; ++i) sorted[i] = splats[order[i]];
  return sorted;
}

float light_read_back(const float* buffer, int n, const LightSplat& s, Readback mode) {
  if (mode == Readback::Pixel) {
    const int ix = static_cast<int>(clamp_index(std::floor(s.x), n));
    const int iy = static_cast<int>(clamp_index(std::floor(s.y), n));
    return buffer[iy * n + ix];
  }
  if (mode == Readback::Bilinear) {
    const float u = s.x - 0.5f, v = s.y - 0.5f;
    const float fu = std::floor(u), fv = std::floor(v);
    const float wx = u - fu, wy = v - fv;
    const int x0 = static_cast<int>(clamp_index(fu, n)),
              x1 = static_cast<int>(clamp_index(fu + 1.0f, n));
    const int y0 = static_cast<int>(clamp_index(fv, n)),
              y1 = static_cast<int>(clamp_index(fv + 1.0f, n));
    const float b0 = lerp(buffer[y0 * n + x0], buffer[y0 * n + x1], wx);
    const float b1 = lerp(buffer[y1 * n + x0], buffer[y1 * n + x1], wx);
    return lerp(b0, b1, wy);
  }
  const int side = s.patch;
  const float half = 0.5f * static_cast<float>(side);
  const float top = static_cast<float>(n - side);
  const int ox = static_cast<int>(std::clamp(std::floor(s.x - half), 0.0f, top));
  const int oy = static_cast<int>(std::clamp(std::floor(s.y - half), 0.0f, top));
  // Row sums, then their sum, in order: the GLSL twin sums the rows in parallel (a patch can
  // hold ~10⁶ pixels) and adds them up the same way.
  float sum = 0.0f;
  for (int y = oy; y < oy + side; ++y) {
    float row = 0.0f;
    for (int x = ox; x < ox + side; ++x) row += buffer[y * n + x];
    sum += row;
  }
  return sum / static_cast<float>(side * side);
}

void light_splat(float* buffer, int n, const LightSplat& s, float g,
                 const ParticleLightSettings& settings) {
  const float top = static_cast<float>(n - 1);
  // Pixels whose centre can lie within r_px of (x, y); the d < 1 test below decides.
  const int x0 = static_cast<int>(std::clamp(std::floor(s.x - s.r_px), 0.0f, top));
  const int x1 = static_cast<int>(std::clamp(std::floor(s.x + s.r_px), 0.0f, top));
  const int y0 = static_cast<int>(std::clamp(std::floor(s.y - s.r_px), 0.0f, top));
  const int y1 = static_cast<int>(std::clamp(std::floor(s.y + s.r_px), 0.0f, top));
  for (int iy = y0; iy <= y1; ++iy) {
    const float dy = (static_cast<float>(iy) + 0.5f) - s.y;
    for (int ix = x0; ix <= x1; ++ix) {
      const float dx = (static_cast<float>(ix) + 0.5f) - s.x;
      const float d = std::sqrt(dx * dx + dy * dy) / s.r_px;
      if (!(d < 1.0f)) continue;
      const float w = splat_kernel(settings.kernel, settings.peak, d);
      float& b = buffer[iy * n + ix];
      b = w * g + (1.0f - w * s.alpha) * b;
      if (settings.quantize == 8) {
        b = std::floor(std::clamp(b, 0.0f, 1.0f) * 255.0f + 0.5f) / 255.0f;
      } else if (settings.clamp) {
        b = std::clamp(b, 0.0f, 1.0f);
      }
    }
  }
}

void particle_light_one(const ParticleView& particles, glm::vec3 sun_direction,
                        const ParticleLightSettings& settings, float* light, std::size_t stride,
                        float* buffer) {
  const int n = settings.resolution;
  const LightFrame frame = light_frame(particles, sun_direction);
  const std::vector<LightSplat> splats = light_splats(particles, frame, settings);
  std::vector<float> own;
  float* b = buffer;
  if (b == nullptr) {
    own.resize(static_cast<std::size_t>(n) * n);
    b = own.data();
  }
  std::fill(b, b + static_cast<std::size_t>(n) * n, 1.0f);
  for (const LightSplat& s : splats) {
    const float intensity = light_read_back(b, n, s, settings.readback);
    light[static_cast<std::size_t>(s.index) * stride] = intensity;
    light_splat(b, n, s, s.forward * intensity, settings);
  }
}

void particle_light(const std::vector<ParticleView>& clouds, const std::vector<glm::vec3>& suns,
                    const ParticleLightSettings& settings, const std::vector<float*>& light_out,
                    const std::vector<float*>& buffers_out, int threads) {
  settings.validate();
  if (light_out.size() != clouds.size() || buffers_out.size() != clouds.size())
    throw std::invalid_argument("one light output (and one buffer slot) per cloud");
  if (suns.empty()) throw std::invalid_argument("lights must not be empty");
  for (const glm::vec3& s : suns)
    if (!(std::abs(glm::length(s) - 1.0f) < 1e-3f))
      throw std::invalid_argument("light directions must be unit vectors");
  for (const ParticleView& c : clouds) {
    c.validate();
    check_energy(c, settings);
  }
  const std::size_t lights = suns.size();
  const std::size_t area = static_cast<std::size_t>(settings.resolution) * settings.resolution;
  parallel_for(clouds.size() * lights, threads, [&](std::size_t task) {
    const std::size_t c = task / lights, l = task % lights;
    float* buffer = buffers_out[c] == nullptr ? nullptr : buffers_out[c] + l * area;
    particle_light_one(clouds[c], suns[l], settings, light_out[c] + l, lights, buffer);
  });
}

}  // namespace cumuli
