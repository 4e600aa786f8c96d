#include "cumuli/rendering/sprites.hpp"

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

bool finite3(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

float lerp(float a, float b, float t) { return a + t * (b - a); }

// Bilinear lookup of atlas cell `cell` at texel coordinates (tx, ty) (texel centres at + ½),
// clamped to the cell's edge texels.
glm::vec4 sample_cell(const SpriteAtlas& atlas, int cell, float tx, float ty) {
  const int cw = atlas.width / atlas.nx, ch = atlas.height / atlas.ny;
  const int cx0 = (cell % atlas.nx) * cw, cy0 = (cell / atlas.nx) * ch;
  const float u = tx - 0.5f, v = ty - 0.5f;
  const float fu = std::floor(u), fv = std::floor(v);
  const float wx = u - fu, wy = v - fv;
  const float xlo = static_cast<float>(cx0), xhi = static_cast<float>(cx0 + cw - 1);
  const float ylo = static_cast<float>(cy0), yhi = static_cast<float>(cy0 + ch - 1);
  const int x0 = static_cast<int>(std::clamp(fu, xlo, xhi));
  const int x1 = static_cast<int>(std::clamp(fu + 1.0f, xlo, xhi));
  const int y0 = static_cast<int>(std::clamp(fv, ylo, yhi));
  const int y1 = static_cast<int>(std::clamp(fv + 1.0f, ylo, yhi));
  glm::vec4 out;
  for (int c = 0; c < 4; ++c) {
    const auto at = [&](int x, int y) {
      return atlas.rgba[(static_cast<std::size_t>(y) * atlas.width + x) * 4 + c];
    };
    out[c] = lerp(lerp(at(x0, y0), at(x1, y0), wx), lerp(at(x0, y1), at(x1, y1), wx), wy);
  }
  return out;
}

}  // namespace

void SpriteCamera::validate() const {
  if (width < 1 || height < 1 || width > kMaxEdge || height > kMaxEdge)
    throw std::invalid_argument("width and height must be in [1, 32768]");
  if (!finite3(position) || !finite3(forward) || !finite3(right) || !finite3(up))
    throw std::invalid_argument("camera must be finite");
  if (!std::isfinite(tan_half) || !(tan_half > 0.0f))
    throw std::invalid_argument("camera fov must be in (0, 180) degrees");
  if (!std::isfinite(near) || !(near > 0.0f)) throw std::invalid_argument("near must be > 0");
}

void SpriteAtlas::validate() const {
  if (rgba == nullptr || width < 1 || height < 1)
    throw std::invalid_argument("atlas must be a non-empty (H, W, 4) image");
  if (nx < 1 || ny < 1 || width % nx != 0 || height % ny != 0)
    throw std::invalid_argument("atlas grid must divide the atlas into equal cells");
}

ScreenSprite project_sprite(const Sprite& sprite, const SpriteCamera& camera) {
  ScreenSprite out;
  const glm::vec3 v = sprite.centre - camera.position;
  const float z = glm::dot(v, camera.forward);
  out.depth = z;
  if (!(z > camera.near)) return out;
  const float x = glm::dot(v, camera.right);
  const float y = glm::dot(v, camera.up);
  const float w = static_cast<float>(camera.width), h = static_cast<float>(camera.height);
  const float aspect = w / h;
  const float zt = z * camera.tan_half;
  out.jc = (w * 0.5f) * (x / (zt * aspect) + 1.0f);
  out.ic = (h * 0.5f) * (1.0f - y / zt);
  const float scale = (h * 0.5f) / zt;
  out.hx = sprite.half_size.x * scale;
  out.hy = sprite.half_size.y * scale;
  out.cos_r = std::cos(sprite.rotation);
  out.sin_r = std::sin(sprite.rotation);
  const float ex = std::abs(out.cos_r) * out.hx + std::abs(out.sin_r) * out.hy;
  const float ey = std::abs(out.sin_r) * out.hx + std::abs(out.cos_r) * out.hy;
  if (!std::isfinite(out.jc) || !std::isfinite(out.ic) || !std::isfinite(ex) ||
      !std::isfinite(ey) || !(out.hx > 0.0f) || !(out.hy > 0.0f))
    return out;
  out.visible = true;
  // Pixels whose centre may lie in the rectangle, one pixel of slack each side (the |s|, |t| ≤ 1
  // test decides), clamped in float before converting.
  out.j0 = static_cast<int>(std::clamp(std::floor(out.jc - ex) - 1.0f, 0.0f, w));
  out.j1 = static_cast<int>(std::clamp(std::floor(out.jc + ex) + 1.0f, -1.0f, w - 1.0f));
  out.i0 = static_cast<int>(std::clamp(std::floor(out.ic - ey) - 1.0f, 0.0f, h));
  out.i1 = static_cast<int>(std::clamp(std::floor(out.ic + ey) + 1.0f, -1.0f, h - 1.0f));
  return out;
}

void rasterise_sprites(const std::vector<Sprite>& sprites, const SpriteCamera& camera,
                       const SpriteRasterSettings& settings, const SpriteAtlas* atlas, float* out,
                       int threads, const SpriteShading* shading, const float* depth) {
  camera.validate();
  if (shading != nullptr) {
    shading->params.validate();
    if (!sprites.empty() && (shading->frame == nullptr || shading->yrange == nullptr ||
                             (shading->caf == nullptr && !shading->lights.empty())))
      throw std::invalid_argument("fragment shading needs a frame, y range and CAF per sprite");
  }
  if (!std::isfinite(settings.peak) || !(settings.peak > 0.0f) || settings.peak > 1.0f)
    throw std::invalid_argument("peak must be in (0, 1]");
  for (const Sprite& s : sprites) {
    if (s.texture < 0) continue;
    if (atlas == nullptr)
      throw std::invalid_argument("a sprite has a texture but there is no atlas");
    if (s.texture >= atlas->nx * atlas->ny)
      throw std::invalid_argument("sprite texture index beyond the atlas cells");
  }
  if (atlas != nullptr) atlas->validate();
  const int width = camera.width, height = camera.height;
  std::vector<ScreenSprite> screen(sprites.size());
  std::vector<char> flat(sprites.size());
  // Fragment shading: the rotated right and up of each sprite in world space.
  std::vector<glm::vec3> right2(shading ? sprites.size() : 0), up2(shading ? sprites.size() : 0);
  for (std::size_t k = 0; k < sprites.size(); ++k) {
    screen[k] = project_sprite(sprites[k], camera);
    if (shading != nullptr) {
      const float c = screen[k].cos_r, s = screen[k].sin_r;
      right2[k] = c * camera.right + s * camera.up;
      up2[k] = -s * camera.right + c * camera.up;
    }
    const auto& c = sprites[k].colour;
    flat[k] = c[0] == c[1] && c[0] == c[2] && c[0] == c[3];
  }
  const float cell_w = atlas ? static_cast<float>(atlas->width / atlas->nx) : 1.0f;
  const float cell_h = atlas ? static_cast<float>(atlas->height / atlas->ny) : 1.0f;
  parallel_chunks(static_cast<std::size_t>(height), threads, [&](std::size_t r0, std::size_t r1) {
    std::fill(out + r0 * width * 4, out + r1 * width * 4, 0.0f);
    for (std::size_t k = 0; k < sprites.size(); ++k) {
      const ScreenSprite& q = screen[k];
      if (!q.visible) continue;
      const Sprite& sp = sprites[k];
      const int i0 = std::max(q.i0, static_cast<int>(r0));
      const int i1 = std::min(q.i1, static_cast<int>(r1) - 1);
      for (int i = i0; i <= i1; ++i) {
        const float dy = (static_cast<float>(i) + 0.5f) - q.ic;
        for (int j = q.j0; j <= q.j1; ++j) {
          const float dx = (static_cast<float>(j) + 0.5f) - q.jc;
          const float s = (dx * q.cos_r - dy * q.sin_r) / q.hx;
          const float t = (-dx * q.sin_r - dy * q.cos_r) / q.hy;
          if (!(std::abs(s) <= 1.0f && std::abs(t) <= 1.0f)) continue;
          if (depth != nullptr && !(q.depth < depth[static_cast<std::size_t>(i) * width + j]))
            continue;
          glm::vec3 colour = sp.colour[0];
          if (shading != nullptr) {
            const glm::vec3 p =
                sp.centre + (s * sp.half_size.x) * right2[k] + (t * sp.half_size.y) * up2[k];
            const glm::vec4 fr = shading->frame[k];
            ShadeFrame frame;
            frame.centre = glm::vec3(fr.x, fr.y, fr.z);
            frame.radius = fr.w;
            frame.y_lo = shading->yrange[k].x;
            frame.y_hi = shading->yrange[k].y;
            colour = shade_point(p, frame, shading->caf + k * shading->lights.size(), 1,
                                 shading->lights, shading->params);
          } else if (!flat[k]) {
            if (s >= t) {
              colour = sp.colour[0] * ((1.0f - s) * 0.5f) + sp.colour[1] * ((s - t) * 0.5f) +
                       sp.colour[2] * ((t + 1.0f) * 0.5f);
            } else {
              colour = sp.colour[0] * ((1.0f - t) * 0.5f) + sp.colour[2] * ((s + 1.0f) * 0.5f) +
                       sp.colour[3] * ((t - s) * 0.5f);
            }
          }
          glm::vec3 rgb;
          float a;
          if (sp.texture < 0) {
            const float d = std::sqrt(s * s + t * t);
            if (!(d < 1.0f)) continue;
            const float w = splat_kernel(settings.kernel, settings.peak, d);
            rgb = w * colour;
            a = w * sp.alpha;
          } else {
            const int cell = sp.texture;
            const float tx = static_cast<float>((cell % atlas->nx) * (atlas->width / atlas->nx)) +
                             (s + 1.0f) * 0.5f * cell_w;
            const float ty = static_cast<float>((cell / atlas->nx) * (atlas->height / atlas->ny)) +
                             (1.0f - t) * 0.5f * cell_h;
            const glm::vec4 tex = sample_cell(*atlas, cell, tx, ty);
            a = tex.w * sp.alpha;
            rgb = colour * glm::vec3(tex.x, tex.y, tex.z) * a;
          }
          float* px = out + (static_cast<std::size_t>(i) * width + j) * 4;
          const float keep = 1.0f - a;
          px[0] = rgb.x + keep * px[0];
          px[1] = rgb.y + keep * px[1];
          px[2] = rgb.z + keep * px[2];
          px[3] = a + keep * px[3];
        }
      }
    }
  });
}

bool sphere_outside_frustum(glm::vec3 centre, float radius, const SpriteCamera& camera) {
  const glm::dvec3 v = glm::dvec3(centre) - glm::dvec3(camera.position);
  const double x = glm::dot(v, glm::dvec3(camera.right));
  const double y = glm::dot(v, glm::dvec3(camera.up));
  const double z = glm::dot(v, glm::dvec3(camera.forward));
  // Margin for float32 rounding of the sprite projection (never cull what might show).
  const double r = static_cast<double>(radius) * (1.0 + 1e-4) + 1e-6 * (glm::length(v) + 1.0);
  if (z + r <= static_cast<double>(camera.near)) return true;
  const double th = camera.tan_half;
  const double ta = th * static_cast<double>(camera.width) / static_cast<double>(camera.height);
  const double nx = std::sqrt(1.0 + ta * ta), ny = std::sqrt(1.0 + th * th);
  return (x - z * ta) / nx > r || (-x - z * ta) / nx > r || (y - z * th) / ny > r ||
         (-y - z * th) / ny > r;
}

ParticleSpriteList particle_sprites(const ParticleView& particles, const float* light,
                                    const std::vector<SpriteLight>& lights,
                                    const SpriteCamera& camera,
                                    const ParticleSpriteSettings& settings) {
  particles.validate();
  camera.validate();
  ParticleSpriteList out;
  if (settings.cull) {
    const Sphere sphere = particle_sphere(particles);
    if (sphere_outside_frustum(sphere.centre, sphere.radius, camera)) return out;
  }
  const std::size_t n = particles.n, nl = lights.size();
  std::vector<float> key(n);
  std::vector<std::uint32_t> kept;
  kept.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    const glm::vec3 p = particles.centre(k);
    const glm::vec3 v = p - camera.position;
    key[k] = settings.sort == SpriteSort::Depth ? glm::dot(v, camera.forward) : glm::length(v);
    if (settings.cull) {
      Sprite s;
      s.centre = p;
      s.half_size = glm::vec2(particles.radii[k]);
      const ScreenSprite q = project_sprite(s, camera);
      if (!q.visible || q.j0 > q.j1 || q.i0 > q.i1) continue;
    }
    kept.push_back(static_cast<std::uint32_t>(k));
  }
  // Back to front: decreasing key, ties by index (stable).
  std::stable_sort(kept.begin(), kept.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return key[a] > key[b]; });
  out.index = kept;
  out.colour.resize(kept.size());
  out.alpha.resize(kept.size());
  out.key.resize(kept.size());
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const std::size_t k = kept[i];
    out.key[i] = key[k];
    const glm::vec3 p = particles.centre(k);
    const glm::vec3 v = p - camera.position;
    const float len2 = glm::dot(v, v);
    const glm::vec3 dir = len2 > 0.0f ? v * (1.0f / std::sqrt(len2)) : glm::vec3(0.0f);
    const float scatter = particles.albedo[k] * particles.tau[k] * settings.solid_angle / kFourPi;
    glm::vec3 c = settings.ambient;
    for (std::size_t l = 0; l < nl; ++l) {
      const float cos_theta = glm::dot(dir, lights[l].direction);
      const float p_l = phase_4pi(settings.phase, settings.hg_g, cos_theta);
      c += (scatter * light[k * nl + l] * p_l) * lights[l].radiance;
    }
    out.colour[i] = c;
    out.alpha[i] = 1.0f - std::exp(-particles.tau[k]);
  }
  return out;
}

}  // namespace cumuli
