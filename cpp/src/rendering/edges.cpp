#include "cumuli/rendering/edges.hpp"

#include <algorithm>
#include <cstddef>
#include <stdexcept>
#include <vector>

#include "cumuli/parallel.hpp"

namespace cumuli {

void coverage_edges(const float* alpha, int width, int height, float range, std::uint8_t* out,
                    int threads) {
  if (width < 1 || height < 1) throw std::invalid_argument("width and height must be >= 1");
  const std::size_t w = static_cast<std::size_t>(width);
  parallel_chunks(static_cast<std::size_t>(height), threads, [&](std::size_t r0, std::size_t r1) {
    std::vector<float> hi(w), lo(w);
    for (std::size_t r = r0; r < r1; ++r) {
      // The column-wise max and min over rows r − 1 … r + 1, then along the row.
      const float* rows[3] = {alpha + (r > 0 ? r - 1 : r) * w, alpha + r * w,
                              alpha + (r + 1 < static_cast<std::size_t>(height) ? r + 1 : r) * w};
      for (std::size_t c = 0; c < w; ++c) {
        hi[c] = std::max(rows[0][c], std::max(rows[1][c], rows[2][c]));
        lo[c] = std::min(rows[0][c], std::min(rows[1][c], rows[2][c]));
      }
      std::uint8_t* dst = out + r * w;
      for (std::size_t c = 0; c < w; ++c) {
        const std::size_t a = c > 0 ? c - 1 : c, b = c + 1 < w ? c + 1 : c;
        const float top = std::max(hi[a], std::max(hi[c], hi[b]));
        const float bottom = std::min(lo[a], std::min(lo[c], lo[b]));
        dst[c] = static_cast<std::uint8_t>(top - bottom > range);
      }
    }
  });
}

}  // namespace cumuli
