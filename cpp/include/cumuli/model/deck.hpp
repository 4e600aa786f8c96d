// Cloud decks: stratus, stratocumulus and altostratus layers (the model of `cumuli.CloudDeck`).
//
// A deck is a slab between heights `base` and `top`, very large in x and z. Its density follows
// the height gradient per cloud type and the coverage remap of Schneider 2015 ("The real-time
// volumetric cloudscapes of Horizon Zero Dawn", SIGGRAPH Advances in Real-Time Rendering),
// detailed with the fBm of Jiménez de Parga & Gómez Palomo 2018 (eq. 1, noise.hpp). At a world
// point p = (x, y, z), with s(a, b, t) = smoothstep (t' = clamp((t − a)/(b − a), 0, 1),
// s = t'²(3 − 2t')):
//
//   h = (y − base)/(top − base)                    height fraction; ρ = 0 outside [0, 1]
//   P(h)  the type's vertical profile in [0, 1]:
//     stratus        P = s(0, 0.1, h) · (1 − s(0.6, 0.95, h))     low, flat, soft base and top
//     stratocumulus  P = s(0, 0.25, h) · (1 − s(0.3, 1, h))       densest low-middle, tapering
//     altostratus    P = s(0.6, 0.75, h) · (1 − s(0.85, 1, h))    thin, high, smooth
//   c = map(x − ox, z − oz)                        coverage in [0, 1]: the [z, x] weather map,
//                                                  bilinear at texel centres over its extent
//                                                  (clamped at the edges), moved by the wind
//                                                  offset (ox, oz)
//   n = clamp(½ + k·(fbm(x − ox, y, z − oz)/Σᵢ gainⁱ − ½), 0, 1)
//                                                  the 2018 fBm normalised to [0, 1) and its
//                                                  contrast raised by k = kDeckDetailContrast
//                                                  (trilinear octaves average out: the normalised
//                                                  5-octave fBm has a std of ≈ 0.09, n ≈ 0.28)
//   b = P + c − 1                                  Schneider's coverage remap c·remap(P, 1 − c,
//                                                  1, 0, 1): the layer exists where coverage is
//                                                  high, thinning (its top and base eaten from
//                                                  the profile's tails) where it is low
//   e = detail · (1 − n)                           erosion by the fBm
//   ρ = density · clamp((b − e)/(1 − e), 0, 1)     Schneider's erosion remap(b, e, 1, 0, 1);
//                                                  ρ = 0 where b ≤ e, so 0 ≤ ρ ≤ density and
//                                                  ρ = 0 wherever c = 0
//
// The fBm moves with the map, so a deck at time t is the deck at time 0 translated by
// (ox, 0, oz). Every loop runs on `parallel_chunks` / `parallel_for` and a point's value does not
// depend on the thread count: results are bit-identical whatever it is, and the lattice equals
// the point function at its texel centres.
#pragma once

#include <cstddef>

#include "cumuli/noise.hpp"

namespace cumuli {

enum class DeckType : int { Stratus = 0, Stratocumulus = 1, Altostratus = 2 };

// k: how much the normalised fBm is stretched about ½ before it erodes.
constexpr float kDeckDetailContrast = 3.0f;

// Largest edge of a deck's weather map and of its lattice, and its most voxels.
constexpr int kMaxDeckMapEdge = 4096;
constexpr int kMaxDeckLatticeEdge = 1024;
constexpr std::size_t kMaxDeckVoxels = std::size_t{1} << 27;

// Everything but the weather map's values: heights, type, density, erosion, fBm, wind offset
// and the map's extent (x0, z0, x1, z1) in world units.
struct DeckShape {
  float base = 1500.0f;
  float top = 2200.0f;
  DeckType type = DeckType::Stratocumulus;
  float density = 1.0f;  // peak density
  float detail = 0.5f;   // erosion strength in [0, 1]
  FbmParams fbm{5, 0.5f, 2.0f, 1.0f / 800.0f};
  float offset_x = 0.0f;  // the map's (and the fBm's) shift: wind · time
  float offset_z = 0.0f;
  double x0 = -8000.0, z0 = -8000.0, x1 = 8000.0, z1 = 8000.0;

  // Throws std::invalid_argument naming the bad parameter.
  void validate() const;
};

// Read-only view of a weather map: nz × nx float32 values in [0, 1], indexed [z][x], over the
// shape's extent (texel centres at x0 + (i + ½)(x1 − x0)/nx).
struct DeckMap {
  const float* values = nullptr;
  int nx = 0;
  int nz = 0;

  // Throws std::invalid_argument unless 1 ≤ nx, nz ≤ kMaxDeckMapEdge and values is set.
  void validate() const;
};

// P(h) of `type` (0 outside [0, 1]).
float deck_profile(DeckType type, float h);

// The coverage c at world (x, z): the map bilinear at (x − ox, z − oz), clamped at its edges.
float deck_coverage(const DeckShape& shape, const DeckMap& map, float x, float z);

// ρ from P, c and the normalised fBm n (the last three lines of the model).
float deck_combine(const DeckShape& shape, float profile, float coverage, float n);

// ρ at `count` points (xyz interleaved) into `out`, on `threads` threads (0 = all).
void deck_density_many(const DeckShape& shape, const DeckMap& map, const Noise& noise,
                       const float* points, std::size_t count, float* out, int threads);

// ρ at the texel centres of an (nz, ny, nx) lattice over the slab [x0, x1] × [base, top] ×
// [z0, z1] into `out` ([z][y][x], nx·ny·nz floats), parallel over z-slices. A centre is
// lo + (i + ½)(hi − lo)/n, computed in double and rounded once to float.
void deck_lattice(const DeckShape& shape, const DeckMap& map, const Noise& noise, int nx, int ny,
                  int nz, float* out, int threads);

}  // namespace cumuli
