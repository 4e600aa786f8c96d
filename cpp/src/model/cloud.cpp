#include "cumuli/model/cloud.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "cumuli/parallel.hpp"

namespace cumuli {

Box CloudShape::bounds() const {
  Box b{glm::vec3(INFINITY), glm::vec3(-INFINITY)};
  for (const auto& e : primitives) {
    glm::vec3 lo, hi;
    e.bounds(lo, hi);
    b.lo = glm::min(b.lo, lo);
    b.hi = glm::max(b.hi, hi);
  }
  return b;
}

glm::vec3 CloudShape::centre() const {
  const Box b = bounds();
  return 0.5f * (b.lo + b.hi);
}

float CloudShape::mean_squared_radius() const {
  if (primitives.empty()) return 0.0f;
  double s = 0.0;
  for (const auto& e : primitives) s += glm::dot(e.radii, e.radii) / 3.0;
  return static_cast<float>(s / primitives.size());
}

void CloudShape::validate() const {
  if (primitives.empty()) throw std::invalid_argument("cloud has no primitives");
  for (const auto& e : primitives) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(e.centre[k])) throw std::invalid_argument("cloud centres must be finite");
      if (!std::isfinite(e.radii[k]) || e.radii[k] <= 0.0f)
        throw std::invalid_argument("cloud radii must be finite and positive");
      for (int j = 0; j < 3; ++j)
        if (!std::isfinite(e.rotation[j][k]))
          throw std::invalid_argument("cloud rotations must be finite");
    }
  }
  // Rotation columns are the axes: they must be orthonormal, or to_local (which uses Rᵀ as the
  // inverse) and bounds() (which uses the columns) describe different shapes.
  for (const auto& e : primitives) {
    const glm::mat3 rtr = glm::transpose(e.rotation) * e.rotation;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        if (!(std::fabs(rtr[a][b] - (a == b ? 1.0f : 0.0f)) <= 1e-3f))
          throw std::invalid_argument("cloud rotations must be orthonormal (columns = unit axes)");
  }
  if (!(density.kappa >= 0.0f && density.kappa <= 1.0f))
    throw std::invalid_argument("kappa must be in [0, 1]");
  if (!(density.phi > 0.0f) || !std::isfinite(density.phi))
    throw std::invalid_argument("phi must be finite and positive");
}

void DensitySource::many(const float* points, std::size_t count, float* out) const {
  if (count == 0) return;
  if (constant >= 0.0f) {
    std::fill(out, out + count, constant);
    return;
  }
  if (evaluations != nullptr) *evaluations += count;
  noise->fbm_many(points, count, out, fbm, 1);
}

const float* noise_points(const CloudShape& cloud, const float* points, std::size_t count) {
  const glm::vec3 o = cloud.noise_offset;
  if (o == glm::vec3(0.0f)) return points;
  thread_local std::vector<float> moved;
  moved.resize(3 * count);
  for (std::size_t i = 0; i < count; ++i) {
    moved[3 * i] = points[3 * i] - o.x;
    moved[3 * i + 1] = points[3 * i + 1] - o.y;
    moved[3 * i + 2] = points[3 * i + 2] - o.z;
  }
  return moved.data();
}

DensitySample spheroid_density_given(float kappa, float q, float rho) {
  const float gamma = std::exp(-q / ((1.0f - kappa) + 2.0f * kappa * rho));
  if (!(rho < gamma)) return {0.0f, gamma};
  return {rho, gamma};
}

DensitySample spheroid_density(const CloudShape& cloud, int j, glm::vec3 p,
                               const DensitySource& src) {
  const float q = cloud.primitives[static_cast<std::size_t>(j)].normalised_distance(p);
  if (q > 1.0f) return {};
  return spheroid_density_given(cloud.density.kappa, q, src(p - cloud.noise_offset));
}

bool metaball_inside(const CloudShape& cloud, glm::vec3 p) {
  float field = 0.0f;
  for (const auto& e : cloud.primitives) {
    const glm::vec3 q = e.to_local_given(p, e.unrotated());
    const float d2 = glm::dot(q, q);
    if (d2 <= 1e-12f) return true;
    field += 1.0f / d2;
    if (field >= 1.0f) return true;
  }
  return !(field < 1.0f);  // (a NaN field counts as inside, as it always has)
}

DensitySample metaball_density(const CloudShape& cloud, glm::vec3 p, const DensitySource& src) {
  if (!metaball_inside(cloud, p)) return {};
  return {metaball_rho(cloud, src(p - cloud.noise_offset)), 1.0f};
}

DensitySample cloud_density(const CloudShape& cloud, int j, glm::vec3 p, const DensitySource& src) {
  return cloud.density.model == DensityModel::Metaball ? metaball_density(cloud, p, src)
                                                       : spheroid_density(cloud, j, p, src);
}

DensitySample field_density(const CloudShape& cloud, glm::vec3 p, const DensitySource& src) {
  if (cloud.density.model == DensityModel::Metaball) return metaball_density(cloud, p, src);
  int best = 0;
  float best_q = INFINITY;
  for (std::size_t k = 0; k < cloud.primitives.size(); ++k) {
    const float q = cloud.primitives[k].normalised_distance(p);
    if (q < best_q) {
      best_q = q;
      best = static_cast<int>(k);
    }
  }
  return spheroid_density(cloud, best, p, src);
}

namespace {

// A row's buffers (one per thread, reused from row to row; taken once per row: each access to
// a thread_local in a shared library can cost a call).
struct GridRow {
  std::vector<int> in_row, owner_cell;
  std::vector<float> x, y, z, q2;  // the row's samples, cell by cell, and their smallest |q|²
  std::vector<float> pts, qs, rho;
};
GridRow& grid_row() {
  thread_local GridRow row;
  return row;
}

}  // namespace

std::vector<float> density_grid(const CloudShape& cloud, const DensitySource& src, const Box& box,
                                const int res[3], int ss, int threads) {
  if (ss < 1 || ss > 8) throw std::invalid_argument("supersample must be in [1, 8]");
  const std::size_t nx = static_cast<std::size_t>(res[0]), ny = static_cast<std::size_t>(res[1]),
                    nz = static_cast<std::size_t>(res[2]);
  std::vector<float> out(nx * ny * nz);
  const glm::vec3 cell =
      (box.hi - box.lo) /
      glm::vec3(static_cast<float>(res[0]), static_cast<float>(res[1]), static_cast<float>(res[2]));
  const float inv_n = 1.0f / static_cast<float>(ss * ss * ss);
  // Spheroids: a sample's density is that of the primitive nearest in normalised distance, and
  // zero unless that distance is ≤ 1, i.e. unless the sample lies inside it. So only primitives
  // whose (slightly grown) bounds meet the cell can give a sample a density: each cell tests
  // those, in index order (the same nearest primitive, the same first one on a tie), and the
  // values are those of testing every primitive.
  const bool spheroid = cloud.density.model != DensityModel::Metaball;
  const std::size_t np = cloud.primitives.size();
  std::vector<glm::vec3> plo(np), phi(np);
  for (std::size_t k = 0; k < np; ++k) {
    cloud.primitives[k].bounds(plo[k], phi[k]);
    const glm::vec3 pad = 1e-4f * (phi[k] - plo[k]) + 1e-6f;
    plo[k] -= pad;
    phi[k] += pad;
  }
  std::vector<char> unrotated(np);
  for (std::size_t k = 0; k < np; ++k) unrotated[k] = cloud.primitives[k].unrotated();
  // The cells along x whose span [x0, x1] a primitive's bounds meet: a run (x0 and x1 grow with
  // x), found with the same float comparisons as testing each cell.
  const auto cell_x0 = [&](std::size_t x) { return box.lo.x + static_cast<float>(x) * cell.x; };
  const auto meets = [&](std::size_t k, std::size_t x) {
    const float x0 = cell_x0(x), x1 = x0 + cell.x;
    return plo[k].x <= x1 && phi[k].x >= x0;
  };
  // Per row: the samples that can hold density (inside their nearest primitive, or inside the
  // metaball iso-surface) are gathered first, their fBm evaluated in one bulk call, then eq. (2)
  // (or eq. 21) finishes each and the cells sum their samples in the same order as one
  // field_density per sample would: the same values, with the SIMD fBm kernels. A spheroid
  // sample's smallest |q|² is taken a primitive at a time over the samples of the cells it
  // meets (a loop that vectorises; min does not depend on the order).
  const float kappa = cloud.density.kappa;
  const std::size_t m = static_cast<std::size_t>(ss * ss * ss);
  parallel_for(nz * ny, threads, [&](std::size_t row) {
    const std::size_t z = row / ny, y = row % ny;
    const glm::vec3 row_lo =
        box.lo + glm::vec3(0.0f, static_cast<float>(y), static_cast<float>(z)) * cell;
    const glm::vec3 row_hi = row_lo + cell;
    GridRow& buf = grid_row();
    std::vector<int>&in_row = buf.in_row, &owner_cell = buf.owner_cell;
    std::vector<float>&pts = buf.pts, &qs = buf.qs;
    in_row.clear();
    for (std::size_t k = 0; k < np; ++k)
      if (plo[k].y <= row_hi.y && phi[k].y >= row_lo.y && plo[k].z <= row_hi.z &&
          phi[k].z >= row_lo.z)
        in_row.push_back(static_cast<int>(k));
    if (spheroid && in_row.empty()) return;
    // The row's samples, cell by cell (c (z) outermost, then b (y), then a (x) within a cell).
    const std::size_t count = nx * m;
    buf.x.resize(count);
    buf.y.resize(count);
    buf.z.resize(count);
    buf.q2.assign(count, INFINITY);
    float *sx = buf.x.data(), *sy = buf.y.data(), *sz = buf.z.data(), *q2 = buf.q2.data();
    for (std::size_t x = 0, i = 0; x < nx; ++x)
      for (int c = 0; c < ss; ++c)
        for (int b = 0; b < ss; ++b)
          for (int a = 0; a < ss; ++a, ++i) {
            const glm::vec3 f((static_cast<float>(x) + (static_cast<float>(a) + 0.5f) / ss),
                              (static_cast<float>(y) + (static_cast<float>(b) + 0.5f) / ss),
                              (static_cast<float>(z) + (static_cast<float>(c) + 0.5f) / ss));
            const glm::vec3 p = box.lo + f * cell;
            sx[i] = p.x;
            sy[i] = p.y;
            sz[i] = p.z;
          }
    if (spheroid) {
      for (const int k : in_row) {
        const std::size_t kk = static_cast<std::size_t>(k);
        // First cell whose x1 reaches the primitive, then on while its x0 does not pass it.
        std::size_t first = static_cast<std::size_t>(
            std::clamp((plo[kk].x - box.lo.x) / cell.x - 1.0f, 0.0f, static_cast<float>(nx)));
        while (first > 0 && meets(kk, first - 1)) --first;
        while (first < nx && !meets(kk, first)) {
          if (cell_x0(first) > phi[kk].x) {
            first = nx;  // past the primitive: it meets no cell of the row
            break;
          }
          ++first;
        }
        std::size_t end = first;
        while (end < nx && meets(kk, end)) ++end;
        if (end > first)
          min_q2(cloud.primitives[kk], unrotated[kk] != 0, sx + first * m, sy + first * m,
                 sz + first * m, (end - first) * m, q2 + first * m);
      }
    }
    // The samples that can hold density, written at the next slot whether or not they do
    // (branch-free for spheroids: the edge samples' tests are unpredictable).
    pts.resize(3 * count);
    qs.resize(count);
    owner_cell.resize(count);
    std::size_t n = 0;
    for (std::size_t i = 0; i < count; ++i) {
      float best_q = 0.0f;
      bool dense = true;
      if (spheroid) {
        best_q = std::sqrt(q2[i]);
        dense = best_q <= 1.0f;
      } else {
        dense = metaball_inside(cloud, glm::vec3(sx[i], sy[i], sz[i]));
      }
      pts[3 * n] = sx[i];
      pts[3 * n + 1] = sy[i];
      pts[3 * n + 2] = sz[i];
      qs[n] = best_q;
      owner_cell[n] = static_cast<int>(i / m);
      n += dense ? 1 : 0;
    }
    std::vector<float>& rho = buf.rho;
    rho.resize(n);
    src.many(noise_points(cloud, pts.data(), n), n, rho.data());
    double sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      sum +=
          spheroid ? spheroid_density_given(kappa, qs[i], rho[i]).rho : metaball_rho(cloud, rho[i]);
      if (i + 1 == n || owner_cell[i + 1] != owner_cell[i]) {
        out[row * nx + static_cast<std::size_t>(owner_cell[i])] =
            ss == 1 ? static_cast<float>(sum) : static_cast<float>(sum) * inv_n;
        sum = 0.0;
      }
    }
  });
  return out;
}

}  // namespace cumuli
