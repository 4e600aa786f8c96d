// The physical mode's outline (RENDER_CONTRACT "Edges"; cumuli.rendering.edges): the pixels
// whose 3×3 neighbourhood's coverage spans more than a threshold, which the edge pass marches
// again with more rays. numpy's twin is the separable max − min of edges.edge_mask's reference.
#pragma once

#include <cstdint>

namespace cumuli {

// out[r·width + c] = 1 where max − min of alpha over the 3×3 neighbourhood of (r, c) (edges
// clamped) exceeds `range`, else 0. `alpha` is (height, width) row-major. The result does not
// depend on the thread count (each row is its own).
void coverage_edges(const float* alpha, int width, int height, float range, std::uint8_t* out,
                    int threads);

}  // namespace cumuli
