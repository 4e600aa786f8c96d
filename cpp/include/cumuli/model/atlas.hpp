// Procedural sprite atlas for billboard clouds (Torchelsen & Musse 2005, §3.2, Fig. 5).
//
// [TM] uses Wang's hand-painted 16-sprite sheet, which is not redistributable; cumuli draws a
// seeded sheet instead. Sprite i sits in cell (i mod nx, i div nx) of an nx × ny grid of
// size × size texels (row 0 on top). At texel-centre coordinates x, y ∈ [−1, 1] (y up) with
// radius r:
//
//   α = clamp(k·(fbm(p) − t), 0, 1) · m(r),   m(r) = 1 − smoothstep(0.6, 1, r)
//
// p = (x·sx, y·sy, 0) + o_i, fbm of cumuli's Noise (seed `seed`, 64³, 5 octaves), o_i a per-sprite
// offset from Rng::stream(seed, i). The coordinates are scaled so that the outermost texel centres
// have |x| ≥ 1 or |y| ≥ 1, hence α = 0 on every sprite's border. Colours (straight alpha, linear):
// "sunny" white with a darker bottom, "rainy" darker grey and denser, "wispy" white with noise
// stretched along x and an elliptical mask. Some "sunny"/"rainy" sprites are flat-bottomed.
#pragma once

#include <cstdint>
#include <vector>

namespace cumuli {

enum class AtlasStyle { Sunny, Rainy, Wispy };

constexpr int kMaxAtlasSprites = 256;
constexpr int kMinAtlasSprite = 8;
constexpr int kMaxAtlasSprite = 512;

struct SpriteAtlas {
  int nx = 0, ny = 0;       // grid of sprites
  int size = 0;             // texels per sprite edge
  std::vector<float> rgba;  // (ny·size, nx·size, 4) row-major, row 0 on top
};

// Grid for n sprites: nx = ceil(sqrt(n)), ny = ceil(n / nx) (16 → 4 × 4).
void atlas_grid(int n, int& nx, int& ny);

// Throws std::invalid_argument naming the bad parameter (n in [1, 256], size in [8, 512]).
SpriteAtlas sprite_atlas(AtlasStyle style, int n, int size, std::uint64_t seed, int threads);

}  // namespace cumuli
