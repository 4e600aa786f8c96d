#include "cumuli/candidates.hpp"

#include <algorithm>
#include <cmath>

#include <glm/common.hpp>

namespace cumuli {

float candidate_scale(const CloudShape& cloud) {
  if (cloud.density.model != DensityModel::Metaball) return 1.0f;
  return std::sqrt(static_cast<float>(std::max<std::size_t>(cloud.primitives.size(), 1)));
}

Box candidate_bounds(const CloudShape& cloud) {
  const float scale = candidate_scale(cloud);
  Box b{glm::vec3(INFINITY), glm::vec3(-INFINITY)};
  for (Ellipsoid e : cloud.primitives) {
    e.radii *= scale;
    glm::vec3 lo, hi;
    e.bounds(lo, hi);
    b.lo = glm::min(b.lo, lo);
    b.hi = glm::max(b.hi, hi);
  }
  return b;
}

namespace {

// collect_candidates over the primitives index(0), ..., index(n − 1).
template <class Index>
int collect(const CloudShape& cloud, Index index, int n, glm::vec3 origin, glm::vec3 dir,
            float t_min, float t_max, Candidate* out, int capacity, bool sorted) {
  const float scale = candidate_scale(cloud);
  int count = 0;
  for (int i = 0; i < n; ++i) {
    const std::size_t j = static_cast<std::size_t>(index(i));
    Ellipsoid e = cloud.primitives[j];
    e.radii *= scale;
    Interval iv;
    if (!intersect(e, origin, dir, iv)) continue;
    const float t0 = std::max(iv.t_in, t_min);
    const float t1 = std::min(iv.t_out, t_max);
    if (!(t1 > t0)) continue;
    if (!sorted) {
      if (count < capacity) out[count++] = Candidate{t0, t1, static_cast<int>(j)};
      continue;
    }
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

}  // namespace

int collect_candidates(const CloudShape& cloud, glm::vec3 origin, glm::vec3 dir, float t_min,
                       float t_max, Candidate* out, int capacity, bool sorted) {
  return collect(
      cloud, [](int i) { return i; }, static_cast<int>(cloud.primitives.size()), origin, dir, t_min,
      t_max, out, capacity, sorted);
}

int collect_candidates(const CloudShape& cloud, const int* subset, int count, glm::vec3 origin,
                       glm::vec3 dir, float t_min, float t_max, Candidate* out, int capacity,
                       bool sorted) {
  return collect(
      cloud, [subset](int i) { return subset[i]; }, count, origin, dir, t_min, t_max, out, capacity,
      sorted);
}

int union_owner(const CloudShape& cloud, const Candidate* cand, int n, float s, glm::vec3 p,
                int fallback) {
  // |q| is computed only once a second candidate covers s: the common case of one covering
  // primitive costs nothing.
  auto q_of = [&](int m) {
    return cloud.primitives[static_cast<std::size_t>(cand[m].primitive)].normalised_distance(p);
  };
  int best = -1;
  float best_q = INFINITY;
  for (int m = 0; m < n && cand[m].t_in <= s; ++m) {
    if (s > cand[m].t_out) continue;
    if (best < 0) {
      best = m;
      continue;
    }
    if (best_q == INFINITY) best_q = q_of(best);
    const float q = q_of(m);
    if (q < best_q) {
      best_q = q;
      best = m;
    }
  }
  return best < 0 ? fallback : cand[best].primitive;
}

}  // namespace cumuli
