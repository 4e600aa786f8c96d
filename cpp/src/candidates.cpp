#include "cumuli/candidates.hpp"

#include <algorithm>
#include <cmath>

namespace cumuli {

float candidate_scale(const CloudShape& cloud) {
  if (cloud.density.model != DensityModel::Metaball) return 1.0f;
  return std::sqrt(static_cast<float>(std::max<std::size_t>(cloud.primitives.size(), 1)));
}

int collect_candidates(const CloudShape& cloud, glm::vec3 origin, glm::vec3 dir, float t_min,
                       float t_max, Candidate* out, int capacity) {
  const float scale = candidate_scale(cloud);
  int count = 0;
  for (std::size_t j = 0; j < cloud.primitives.size(); ++j) {
    Ellipsoid e = cloud.primitives[j];
    e.radii *= scale;
    Interval iv;
    if (!intersect(e, origin, dir, iv)) continue;
    const float t0 = std::max(iv.t_in, t_min);
    const float t1 = std::min(iv.t_out, t_max);
    if (!(t1 > t0)) continue;
    // Insertion sort by t_in; when full, keep the nearest `capacity`.
    int pos = count;
    if (count == capacity) {
      if (capacity == 0 || t0 >= out[capacity - 1].t_in) continue;
      pos = capacity - 1;
    } else {
      ++count;
    }
    while (pos > 0 && out[pos - 1].t_in > t0) {
      out[pos] = out[pos - 1];
      --pos;
    }
    out[pos] = Candidate{t0, t1, static_cast<int>(j)};
  }
  return count;
}

}  // namespace cumuli
