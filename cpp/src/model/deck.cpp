#include "cumuli/model/deck.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "cumuli/parallel.hpp"

namespace cumuli {

namespace {

float smooth(float a, float b, float t) {
  const float u = std::min(1.0f, std::max(0.0f, (t - a) / (b - a)));
  return u * u * (3.0f - 2.0f * u);
}

// One axis of a clamped bilinear lookup at texel coordinate u (texel centres at i + ½).
struct Tap {
  int lo;
  int hi;
  float w;
};

Tap tap(float u, int n) {
  const float c = std::min(static_cast<float>(n - 1), std::max(0.0f, u - 0.5f));
  const int lo = static_cast<int>(std::floor(c));
  return Tap{lo, std::min(lo + 1, n - 1), c - static_cast<float>(lo)};
}

// Σ_{i=1..octaves} gainⁱ: the fBm's largest value (a lattice is < 1), summed in double.
float fbm_weight(const FbmParams& p) {
  double w = 0.0, g = 1.0;
  for (int i = 0; i < p.octaves; ++i) {
    g *= static_cast<double>(p.gain);
    w += g;
  }
  return static_cast<float>(w);
}

// ρ from b = P + c − 1 and the normalised fBm n.
float combine(const DeckShape& s, float b, float n) {
  if (!(b > 0.0f)) return 0.0f;
  const float e = s.detail * (1.0f - n);
  if (!(b > e)) return 0.0f;
  return s.density * std::min(1.0f, (b - e) / (1.0f - e));
}

// Scratch of one thread's batch: the points that need the fBm, and their b.
struct Batch {
  std::vector<std::size_t> index;
  std::vector<float> b;
  std::vector<float> points;
  std::vector<float> fbm;
};

// ρ at `count` points on this thread: the fBm only where b > 0 (bit-identical to evaluating it
// everywhere: fbm_many gives each point the value fbm() gives it).
void evaluate(const DeckShape& s, const DeckMap& map, const Noise& noise, const float* pts,
              std::size_t count, float* out, Batch& batch) {
  batch.index.clear();
  batch.b.clear();
  batch.points.clear();
  const float span = s.top - s.base;
  for (std::size_t i = 0; i < count; ++i) {
    const float x = pts[3 * i], y = pts[3 * i + 1], z = pts[3 * i + 2];
    out[i] = 0.0f;
    const float h = (y - s.base) / span;
    if (!(h >= 0.0f && h <= 1.0f)) continue;
    const float b = deck_profile(s.type, h) + deck_coverage(s, map, x, z) - 1.0f;
    if (!(b > 0.0f)) continue;
    batch.index.push_back(i);
    batch.b.push_back(b);
    batch.points.insert(batch.points.end(), {x - s.offset_x, y, z - s.offset_z});
  }
  const std::size_t n = batch.index.size();
  if (n == 0) return;
  batch.fbm.resize(n);
  noise.fbm_many(batch.points.data(), n, batch.fbm.data(), s.fbm, 1);
  const float w = fbm_weight(s.fbm);
  for (std::size_t k = 0; k < n; ++k) {
    const float v =
        std::min(1.0f, std::max(0.0f, 0.5f + kDeckDetailContrast * (batch.fbm[k] / w - 0.5f)));
    out[batch.index[k]] = combine(s, batch.b[k], v);
  }
}

bool finite(double v) { return std::isfinite(v); }

}  // namespace

void DeckShape::validate() const {
  if (!std::isfinite(base) || !std::isfinite(top) || !(top > base))
    throw std::invalid_argument("top must be greater than base (both finite)");
  if (!std::isfinite(top - base))
    throw std::invalid_argument("top - base must be finite in float32");
  if (!std::isfinite(density) || density < 0.0f)
    throw std::invalid_argument("density must be finite and >= 0");
  if (!(detail >= 0.0f && detail <= 1.0f)) throw std::invalid_argument("detail must be in [0, 1]");
  fbm.validate();
  if (!std::isfinite(offset_x) || !std::isfinite(offset_z))
    throw std::invalid_argument("the wind offset must be finite");
  if (!finite(x0) || !finite(x1) || !finite(z0) || !finite(z1) || !(x1 > x0) || !(z1 > z0))
    throw std::invalid_argument("extent must be finite with x1 > x0 and z1 > z0");
  if (!std::isfinite(static_cast<float>(x1) - static_cast<float>(x0)) ||
      !std::isfinite(static_cast<float>(z1) - static_cast<float>(z0)))
    throw std::invalid_argument("extent must be finite in float32");
}

void DeckMap::validate() const {
  if (values == nullptr) throw std::invalid_argument("coverage map is missing");
  if (nx < 1 || nz < 1 || nx > kMaxDeckMapEdge || nz > kMaxDeckMapEdge)
    throw std::invalid_argument("coverage map edges must be in [1, " +
                                std::to_string(kMaxDeckMapEdge) + "]");
}

float deck_profile(DeckType type, float h) {
  if (!(h >= 0.0f && h <= 1.0f)) return 0.0f;
  switch (type) {
    case DeckType::Stratus:
      return smooth(0.0f, 0.1f, h) * (1.0f - smooth(0.6f, 0.95f, h));
    case DeckType::Stratocumulus:
      return smooth(0.0f, 0.25f, h) * (1.0f - smooth(0.3f, 1.0f, h));
    case DeckType::Altostratus:
      return smooth(0.6f, 0.75f, h) * (1.0f - smooth(0.85f, 1.0f, h));
  }
  return 0.0f;
}

float deck_coverage(const DeckShape& s, const DeckMap& map, float x, float z) {
  const float x0 = static_cast<float>(s.x0), x1 = static_cast<float>(s.x1);
  const float z0 = static_cast<float>(s.z0), z1 = static_cast<float>(s.z1);
  const float u = (x - s.offset_x - x0) / (x1 - x0) * static_cast<float>(map.nx);
  const float v = (z - s.offset_z - z0) / (z1 - z0) * static_cast<float>(map.nz);
  const Tap tx = tap(u, map.nx), tz = tap(v, map.nz);
  const float* r0 = map.values + static_cast<std::size_t>(tz.lo) * map.nx;
  const float* r1 = map.values + static_cast<std::size_t>(tz.hi) * map.nx;
  const float a = r0[tx.lo] + tx.w * (r0[tx.hi] - r0[tx.lo]);
  const float b = r1[tx.lo] + tx.w * (r1[tx.hi] - r1[tx.lo]);
  return std::min(1.0f, std::max(0.0f, a + tz.w * (b - a)));
}

float deck_combine(const DeckShape& shape, float profile, float coverage, float n) {
  return combine(shape, profile + coverage - 1.0f, n);
}

void deck_density_many(const DeckShape& shape, const DeckMap& map, const Noise& noise,
                       const float* points, std::size_t count, float* out, int threads) {
  shape.validate();
  map.validate();
  parallel_chunks(count, threads, [&](std::size_t begin, std::size_t end) {
    Batch batch;
    evaluate(shape, map, noise, points + 3 * begin, end - begin, out + begin, batch);
  });
}

void deck_lattice(const DeckShape& shape, const DeckMap& map, const Noise& noise, int nx, int ny,
                  int nz, float* out, int threads) {
  shape.validate();
  map.validate();
  const int edges[3] = {nx, ny, nz};
  for (const int e : edges)
    if (e < 1 || e > kMaxDeckLatticeEdge)
      throw std::invalid_argument("resolution must be in [1, " +
                                  std::to_string(kMaxDeckLatticeEdge) + "] per axis");
  const std::size_t plane = static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny);
  if (plane * static_cast<std::size_t>(nz) > kMaxDeckVoxels)
    throw std::invalid_argument("resolution has more than 2^27 voxels");
  // Texel centres per axis: in double, rounded once to float.
  const auto centres = [](double lo, double hi, int n) {
    std::vector<float> c(static_cast<std::size_t>(n));
    const double step = (hi - lo) / n;
    for (int i = 0; i < n; ++i) c[i] = static_cast<float>(lo + (i + 0.5) * step);
    return c;
  };
  const std::vector<float> xs = centres(shape.x0, shape.x1, nx);
  const std::vector<float> ys = centres(shape.base, shape.top, ny);
  const std::vector<float> zs = centres(shape.z0, shape.z1, nz);
  parallel_for(static_cast<std::size_t>(nz), threads, [&](std::size_t k) {
    std::vector<float> pts(3 * plane);
    for (std::size_t j = 0; j < static_cast<std::size_t>(ny); ++j)
      for (std::size_t i = 0; i < static_cast<std::size_t>(nx); ++i) {
        float* p = &pts[3 * (j * nx + i)];
        p[0] = xs[i];
        p[1] = ys[j];
        p[2] = zs[k];
      }
    Batch batch;
    evaluate(shape, map, noise, pts.data(), plane, out + k * plane, batch);
  });
}

}  // namespace cumuli
