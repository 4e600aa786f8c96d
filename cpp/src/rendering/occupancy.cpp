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

OccupancyGrid build_occupancy(const CloudShape& cloud, int res) {
  if (res < 1 || res > 256) throw std::invalid_argument("occupancy resolution must be in [1, 256]");
  OccupancyGrid g;
  g.res = res;
  g.box = candidate_bounds(cloud);
  g.cells.assign(static_cast<std::size_t>(res) * res * res, 0);
  const auto& prims = cloud.primitives;
  std::vector<float> inv_rmin(prims.size());
  std::vector<Box> bounds(prims.size());
  for (std::size_t j = 0; j < prims.size(); ++j) {
    const glm::vec3 r = prims[j].radii;
    inv_rmin[j] = 1.0f / std::min(r.x, std::min(r.y, r.z));
    prims[j].bounds(bounds[j].lo, bounds[j].hi);
  }
  const bool metaball = cloud.density.model == DensityModel::Metaball;
  // Computed in double with a relative margin: float32 rounding in the marcher's |q| cannot
  // turn a cell the bound calls empty into one with density.
  const glm::dvec3 lo(g.box.lo), size = (glm::dvec3(g.box.hi) - lo) / static_cast<double>(res);
  const double half_diag = 0.5 * glm::length(size);
  constexpr double kMargin = 1e-3;
  for (int z = 0; z < res; ++z)
    for (int y = 0; y < res; ++y)
      for (int x = 0; x < res; ++x) {
        const glm::dvec3 c = lo + (glm::dvec3(x, y, z) + 0.5) * size;
        const glm::dvec3 clo = c - 0.5 * size, chi = c + 0.5 * size;
        bool occupied = false;
        double field = 0.0;
        for (std::size_t j = 0; j < prims.size() && !occupied; ++j) {
          const Ellipsoid& e = prims[j];
          const glm::dmat3 rt = glm::transpose(glm::dmat3(e.rotation));
          const glm::dvec3 q = (rt * (c - glm::dvec3(e.centre))) / glm::dvec3(e.radii);
          const double lower = glm::length(q) - half_diag * inv_rmin[j];
          if (metaball) {
            const double m = lower * (1.0 - kMargin);
            if (m <= 1e-6) {
              occupied = true;
            } else {
              field += 1.0 / (m * m);
              occupied = field >= 1.0 - kMargin;
            }
          } else {
            const Box& b = bounds[j];  // the cell must also meet the primitive's bounds
            const bool meets =
                clo.x <= b.hi.x + kMargin * size.x && chi.x >= b.lo.x - kMargin * size.x &&
                clo.y <= b.hi.y + kMargin * size.y && chi.y >= b.lo.y - kMargin * size.y &&
                clo.z <= b.hi.z + kMargin * size.z && chi.z >= b.lo.z - kMargin * size.z;
            occupied = meets && lower <= 1.0 + kMargin;
          }
        }
        g.cells[(static_cast<std::size_t>(z) * res + y) * res + x] = occupied ? 1 : 0;
      }
  return g;
}

}  // namespace cumuli
