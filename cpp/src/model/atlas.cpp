#include "cumuli/model/atlas.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <glm/vec3.hpp>

#include "cumuli/noise.hpp"
#include "cumuli/parallel.hpp"
#include "cumuli/rng.hpp"

namespace cumuli {

namespace {

float smoothstep(float e0, float e1, float x) {
  const float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

// What distinguishes the styles.
struct StyleParams {
  float k;            // contrast of the threshold
  float t;            // fBm threshold
  float sx, sy;       // lattice texels per unit of x and y
  float ry;           // mask ellipse: r = sqrt(x² + (y / ry)²)
  float flat_share;   // share of flat-bottomed sprites
  float dark, light;  // grey level at the bottom and at the top
  glm::vec3 tint;
};

StyleParams style_params(AtlasStyle s) {
  switch (s) {
    case AtlasStyle::Sunny:
      return {4.0f, 0.26f, 1.2f, 1.2f, 1.0f, 0.35f, 0.72f, 1.0f, glm::vec3(1.0f, 1.0f, 1.0f)};
    case AtlasStyle::Rainy:
      return {7.0f, 0.22f, 1.2f, 1.2f, 1.0f, 0.35f, 0.38f, 0.62f, glm::vec3(0.94f, 0.96f, 1.0f)};
    case AtlasStyle::Wispy:
    default:
      return {3.0f, 0.34f, 0.35f, 2.5f, 0.55f, 0.0f, 0.90f, 1.0f, glm::vec3(1.0f, 1.0f, 1.0f)};
  }
}

}  // namespace

void atlas_grid(int n, int& nx, int& ny) {
  nx = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
  if (nx * nx < n) ++nx;  // guard against sqrt rounding
  ny = (n + nx - 1) / nx;
}

SpriteAtlas sprite_atlas(AtlasStyle style, int n, int size, std::uint64_t seed, int threads) {
  if (n < 1 || n > kMaxAtlasSprites)
    throw std::invalid_argument("n must be in [1, " + std::to_string(kMaxAtlasSprites) + "]");
  if (size < kMinAtlasSprite || size > kMaxAtlasSprite)
    throw std::invalid_argument("size must be in [" + std::to_string(kMinAtlasSprite) + ", " +
                                std::to_string(kMaxAtlasSprite) + "]");
  SpriteAtlas atlas;
  atlas_grid(n, atlas.nx, atlas.ny);
  atlas.size = size;
  const std::size_t width = static_cast<std::size_t>(atlas.nx) * size;
  const std::size_t height = static_cast<std::size_t>(atlas.ny) * size;
  atlas.rgba.assign(width * height * 4, 0.0f);

  // The table (version 1), not the default: an atlas (and a file that names it by its seed) keeps
  // the sprites it had before noise versions existed.
  const Noise noise(seed, 64, Noise::kVersionTable);
  const FbmParams fbm{5, 0.5f, 2.0f, 1.0f};
  const StyleParams sp = style_params(style);
  struct Sprite {
    glm::vec3 offset;
    bool flat;
    float base;
  };
  std::vector<Sprite> sprites(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    Rng rng = Rng::stream(seed, static_cast<std::uint64_t>(i));
    Sprite& s = sprites[static_cast<std::size_t>(i)];
    s.offset = glm::vec3(64.0f * rng.uniform(), 64.0f * rng.uniform(), 64.0f * rng.uniform());
    s.flat = rng.uniform() < sp.flat_share;
    s.base = -0.45f + 0.2f * rng.uniform();
  }
  // Texel centre → [−1, 1] with the outermost centres at |x| ≥ 1.
  const float half = 0.5f * static_cast<float>(size);
  const float scale = 1.0f / (half - 1.0f);
  float* out = atlas.rgba.data();
  const std::size_t rows = static_cast<std::size_t>(n) * static_cast<std::size_t>(size);
  parallel_for(rows, threads, [&](std::size_t job) {
    const int i = static_cast<int>(job / static_cast<std::size_t>(size));
    const int py = static_cast<int>(job % static_cast<std::size_t>(size));
    const Sprite& s = sprites[static_cast<std::size_t>(i)];
    const int cx = i % atlas.nx, cy = i / atlas.nx;
    const float y = -((static_cast<float>(py) + 0.5f) - half) * scale;  // y up
    float* row = out + ((static_cast<std::size_t>(cy) * size + py) * width +
                        static_cast<std::size_t>(cx) * size) *
                           4;
    for (int px = 0; px < size; ++px) {
      const float x = ((static_cast<float>(px) + 0.5f) - half) * scale;
      const float yr = y / sp.ry;
      const float r = std::sqrt(x * x + yr * yr);
      const float mask = 1.0f - smoothstep(0.6f, 1.0f, r);
      float a = 0.0f, value = 0.0f;
      if (mask > 0.0f && std::abs(x) < 1.0f && std::abs(y) < 1.0f) {
        value = noise.fbm(glm::vec3(x * sp.sx, y * sp.sy, 0.0f) + s.offset, fbm);
        a = std::clamp(sp.k * (value - sp.t), 0.0f, 1.0f) * mask;
        if (s.flat) a *= smoothstep(s.base - 0.08f, s.base + 0.08f, y);
      }
      // Darker towards the bottom, a little noise in the shade.
      const float grey = (sp.dark + (sp.light - sp.dark) * smoothstep(-1.0f, 0.6f, y)) *
                         std::clamp(0.9f + 0.3f * (value - 0.45f), 0.75f, 1.0f);
      float* t = row + 4 * px;
      t[0] = std::min(1.0f, grey * sp.tint.x);
      t[1] = std::min(1.0f, grey * sp.tint.y);
      t[2] = std::min(1.0f, grey * sp.tint.z);
      t[3] = a;
    }
  });
  return atlas;
}

}  // namespace cumuli
