// Coarse occupancy grids for empty-space skipping in the 2018 marcher (Jiménez de Parga &
// Gómez Palomo 2018, Algorithms 1 and 3; RENDER_CONTRACT "Empty-space
// skipping").
//
// A cloud's candidate box (candidate_bounds) is cut into kOccupancyRes³ cells. A cell is marked
// empty only when no density model can give ρ > 0 anywhere in it: |q| is Lipschitz in world
// space with constant 1/r_min (r_min the primitive's smallest radius), so over a cell of centre
// c and half-diagonal h, |q(p)| ≥ |q(c)| − h/r_min. A pseudo-spheroid cell (eq. 2: ρ = 0 where
// |q_j| > 1 for the attributed primitive j) is empty when every primitive has that lower bound
// above 1; a metaball cell (eqs. 19–21: ρ = 0 where Σ 1/|q_i|² < 1) when the sum of the upper
// bounds 1/max(0, |q_i(c)| − h/r_min,i)² stays below 1. Both tests carry a margin for float32
// rounding, so the grid is conservative: the marcher may skip samples in empty cells without
// changing a pixel. The grid is the same for the GL marcher (a texture) and the C++ twin.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/model/cloud.hpp"
#include "cumuli/primitives.hpp"

namespace cumuli {

constexpr int kOccupancyRes = 16;

struct OccupancyGrid {
  Box box;                     // the cloud's candidate box
  std::vector<uint8_t> cells;  // [z][y][x], 1 = may hold density, 0 = certainly empty
  int res = kOccupancyRes;

  // The cell index of p (x, y, z), false when p is outside the box.
  bool cell_of(glm::vec3 p, int& ix, int& iy, int& iz) const;
  bool occupied(int ix, int iy, int iz) const {
    return cells[(static_cast<std::size_t>(iz) * res + iy) * res + ix] != 0;
  }
  // The ray parameter where o + t·d leaves cell (ix, iy, iz) (d's components may be 0).
  float cell_exit(int ix, int iy, int iz, glm::vec3 o, glm::vec3 d) const;
};

// The grid of a cloud (deterministic; independent of any thread count).
OccupancyGrid build_occupancy(const CloudShape& cloud, int res = kOccupancyRes);

}  // namespace cumuli
