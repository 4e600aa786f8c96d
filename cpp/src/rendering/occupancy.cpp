#include "cumuli/rendering/occupancy.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

#include "cumuli/candidates.hpp"

namespace cumuli {

bool OccupancyGrid::cell_of(glm::vec3 p, int& ix, int& iy, int& iz) const {
  if (!box.contains(p)) return false;
  const glm::vec3 u = (p - box.lo) / (box.hi - box.lo) * static_cast<float>(res);
  auto idx = [this](float v) { return std::clamp(static_cast<int>(v), 0, res - 1); };
  ix = idx(u.x);
  iy = idx(u.y);
  iz = idx(u.z);
  return true;
}

float OccupancyGrid::cell_exit(int ix, int iy, int iz, glm::vec3 o, glm::vec3 d) const {
  const glm::vec3 size = (box.hi - box.lo) / static_cast<float>(res);
  const int idx[3] = {ix, iy, iz};
  float t = INFINITY;
  for (int a = 0; a < 3; ++a) {
    if (d[a] > 0.0f) {
      t = std::min(t, (box.lo[a] + static_cast<float>(idx[a] + 1) * size[a] - o[a]) / d[a]);
    } else if (d[a] < 0.0f) {
      t = std::min(t, (box.lo[a] + static_cast<float>(idx[a]) * size[a] - o[a]) / d[a]);
    }
  }
  return t;
}

namespace {

// A primitive's terms of the bound, computed once (not once per cell): its world-to-unit-sphere
// frame in double, 1/r_min and its world bounds.
struct PrimitiveBound {
  glm::dmat3 rt;
  glm::dvec3 centre, radii;
  float inv_rmin;
  Box bounds;

  explicit PrimitiveBound(const Ellipsoid& e)
      : rt(glm::transpose(glm::dmat3(e.rotation))),
        centre(e.centre),
        radii(e.radii),
        inv_rmin(1.0f / std::min(e.radii.x, std::min(e.radii.y, e.radii.z))) {
    e.bounds(bounds.lo, bounds.hi);
  }
  // |q(c)| − h/r_min: the lower bound of |q| over a cell of centre c and half-diagonal h.
  double lower(const glm::dvec3& c, double half_diag) const {
    return glm::length((rt * (c - centre)) / radii) - half_diag * inv_rmin;
  }
};

}  // namespace

OccupancyGrid build_occupancy(const CloudShape& cloud, int res) {
  if (res < 1 || res > 256) throw std::invalid_argument("occupancy resolution must be in [1, 256]");
  OccupancyGrid g;
  g.res = res;
  g.box = candidate_bounds(cloud);
  g.cells.assign(static_cast<std::size_t>(res) * res * res, 0);
  std::vector<PrimitiveBound> prims;
  prims.reserve(cloud.primitives.size());
  for (const Ellipsoid& e : cloud.primitives) prims.emplace_back(e);
  // Computed in double with a relative margin: float32 rounding in the marcher's |q| cannot
  // turn a cell the bound calls empty into one with density.
  const glm::dvec3 lo(g.box.lo), size = (glm::dvec3(g.box.hi) - lo) / static_cast<double>(res);
  const double half_diag = 0.5 * glm::length(size);
  constexpr double kMargin = 1e-3;
  auto centre = [&](int x, int y, int z) { return lo + (glm::dvec3(x, y, z) + 0.5) * size; };
  auto index = [res](int x, int y, int z) {
    return (static_cast<std::size_t>(z) * res + y) * res + x;
  };

  if (cloud.density.model == DensityModel::Metaball) {
    // Σ 1/|q_i|² over every primitive (in order: the sum's rounding is part of the result).
    for (int z = 0; z < res; ++z)
      for (int y = 0; y < res; ++y)
        for (int x = 0; x < res; ++x) {
          const glm::dvec3 c = centre(x, y, z);
          bool occupied = false;
          double field = 0.0;
          for (std::size_t j = 0; j < prims.size() && !occupied; ++j) {
            const double m = prims[j].lower(c, half_diag) * (1.0 - kMargin);
            if (m <= 1e-6) {
              occupied = true;
            } else {
              field += 1.0 / (m * m);
              occupied = field >= 1.0 - kMargin;
            }
          }
          g.cells[index(x, y, z)] = occupied ? 1 : 0;
        }
    return g;
  }

  // Pseudo-spheroids: a cell is occupied when some primitive's bounds meet it and its lower bound
  // on |q| is at most 1. An OR over primitives, so each primitive visits only the cells its
  // bounds can meet (the range widened by a cell, the exact test below deciding).
  for (const PrimitiveBound& p : prims) {
    int first[3], last[3];
    for (int a = 0; a < 3; ++a) {
      const double u0 = std::floor((p.bounds.lo[a] - lo[a]) / size[a]) - 1.0;
      const double u1 = std::floor((p.bounds.hi[a] - lo[a]) / size[a]) + 1.0;
      // A flat box (size 0) or a primitive beyond it: every cell along a, the test deciding.
      const bool finite = std::isfinite(u0) && std::isfinite(u1);
      first[a] = finite ? static_cast<int>(std::clamp(u0, 0.0, res - 1.0)) : 0;
      last[a] = finite ? static_cast<int>(std::clamp(u1, 0.0, res - 1.0)) : res - 1;
    }
    for (int z = first[2]; z <= last[2]; ++z)
      for (int y = first[1]; y <= last[1]; ++y)
        for (int x = first[0]; x <= last[0]; ++x) {
          const std::size_t i = index(x, y, z);
          if (g.cells[i] != 0) continue;
          const glm::dvec3 c = centre(x, y, z);
          const glm::dvec3 clo = c - 0.5 * size, chi = c + 0.5 * size;
          const Box& b = p.bounds;
          const bool meets =
              clo.x <= b.hi.x + kMargin * size.x && chi.x >= b.lo.x - kMargin * size.x &&
              clo.y <= b.hi.y + kMargin * size.y && chi.y >= b.lo.y - kMargin * size.y &&
              clo.z <= b.hi.z + kMargin * size.z && chi.z >= b.lo.z - kMargin * size.z;
          if (meets && p.lower(c, half_diag) <= 1.0 + kMargin) g.cells[i] = 1;
        }
  }
  return g;
}

}  // namespace cumuli
