// Structure-of-arrays helpers: several std::vector columns that describe the same rows (the
// weather's cloud instances, a billboard cloud's sprites) are filtered together.
#pragma once

#include <cstddef>
#include <vector>

namespace cumuli {

// Keep the rows i with keep[i] != 0 in every column, in order; returns the rows kept.
// Every column must have at least keep.size() rows.
template <class... Column>
std::size_t keep_rows(const std::vector<char>& keep, Column&... columns) {
  std::size_t w = 0;
  for (std::size_t i = 0; i < keep.size(); ++i) {
    if (!keep[i]) continue;
    ((columns[w] = columns[i]), ...);
    ++w;
  }
  (columns.resize(w), ...);
  return w;
}

}  // namespace cumuli
