#include "cumuli/candidates.hpp"

#include <algorithm>
#include <cmath>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

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

// collect_candidates over the primitives index(0), ..., index(n − 1); hit(j, iv) intersects the
// ray with primitive j (grown by candidate_scale).
template <class Index, class Hit>
int collect(Index index, int n, Hit hit, float t_min, float t_max, Candidate* out, int capacity,
            bool sorted) {
  int count = 0;
  for (int i = 0; i < n; ++i) {
    const std::size_t j = static_cast<std::size_t>(index(i));
    Interval iv;
    if (!hit(j, iv)) continue;
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

template <class Index>
int collect(const CloudShape& cloud, Index index, int n, glm::vec3 origin, glm::vec3 dir,
            float t_min, float t_max, Candidate* out, int capacity, bool sorted) {
  const float scale = candidate_scale(cloud);
  auto hit = [&](std::size_t j, Interval& iv) {
    Ellipsoid e = cloud.primitives[j];
    e.radii *= scale;
    return intersect(e, origin, dir, iv);
  };
  return collect(index, n, hit, t_min, t_max, out, capacity, sorted);
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

CandidateFan::CandidateFan(const CloudShape& cloud, glm::vec3 origin) {
  const float scale = candidate_scale(cloud);
  terms_.reserve(cloud.primitives.size());
  for (Ellipsoid e : cloud.primitives) {
    const glm::vec3 own = e.radii;
    e.radii *= scale;
    // intersect()'s terms that do not depend on the direction, the same expressions.
    const glm::mat3 rt = glm::transpose(e.rotation);
    const glm::vec3 o = (rt * (origin - e.centre)) / e.radii;
    // The cull cone, in double: half-angle asin(R/L) of the bounding sphere (R the largest grown
    // radius, L the distance to its centre) plus a slack. The exact test below accepts rays up
    // to ~√ε (3.5e-4 rad) beyond the unit sphere in the primitive's frame (its b² − a·c cancels
    // for a far origin), which the frame's stretch widens by at most r_max/r_min in the world;
    // the slack is 6× that. An origin in or near the sphere is never culled.
    const double r_max = std::max(e.radii.x, std::max(e.radii.y, e.radii.z));
    const double r_min = std::min(e.radii.x, std::min(e.radii.y, e.radii.z));
    const glm::dvec3 v = glm::dvec3(e.centre) - glm::dvec3(origin);
    const double len = glm::length(v);
    const double slack = 2e-3 * r_max / std::max(r_min, 1e-30);
    float cos_cull = -2.0f;  // never culled
    double cull_angle = 4.0;
    glm::vec3 axis(0.0f);
    if (std::isfinite(slack) && len > r_max * (1.0 + 1e-2) && std::isfinite(len)) {
      const double angle = std::asin(r_max / len) + slack;
      if (angle < 3.0) {
        cos_cull = static_cast<float>(std::cos(angle) - 1e-6);
        cull_angle = angle;
        axis = glm::vec3(v / len);
      }
    }
    const glm::vec3 o_own = (rt * (origin - e.centre)) / own;
    terms_.push_back(Term{rt, e.radii, o, glm::dot(o, o) - 1.0f, e.centre, own, o_own,
                          e.unrotated(), axis, cos_cull, cull_angle});
  }
}

void CandidateFan::bin(const std::vector<DirectionCone>& bins) {
  // Primitive j's cull cone (axis a, half-angle α) meets cone b (axis c, half-angle β) when
  // ∠(a, c) ≤ α + β, i.e. a·c ≥ cos(α + β) = cos α·cos β − sin α·sin β for α + β < π. A pad of
  // 10⁻⁵ rad on β covers the rounding of the float axes and ray directions (≲ 10⁻⁶ rad).
  constexpr double kPad = 1e-5;
  const std::size_t n = terms_.size();
  std::vector<double> cos_a(n), sin_a(n);
  for (std::size_t j = 0; j < n; ++j) {
    cos_a[j] = std::cos(terms_[j].cull_angle);
    sin_a[j] = std::sin(terms_[j].cull_angle);
  }
  bin_start_.assign(1, 0);
  bin_members_.clear();
  for (const DirectionCone& cone : bins) {
    const double beta = cone.half_angle + kPad;
    const double cos_b = std::cos(beta), sin_b = std::sin(beta);
    for (std::size_t j = 0; j < n; ++j) {
      const Term& e = terms_[j];
      const bool meets = e.cull_angle + beta >= 3.0 || glm::dot(glm::dvec3(e.axis), cone.axis) >=
                                                           cos_a[j] * cos_b - sin_a[j] * sin_b;
      if (meets) bin_members_.push_back(static_cast<int>(j));
    }
    bin_start_.push_back(static_cast<int>(bin_members_.size()));
  }
}

int CandidateFan::collect(glm::vec3 dir, int b, float t_min, float t_max, Candidate* out,
                          int capacity, bool sorted) const {
  if (b < 0 || static_cast<std::size_t>(b) + 1 >= bin_start_.size())
    return collect(dir, t_min, t_max, out, capacity, sorted);
  const int* members = bin_members_.data() + bin_start_[static_cast<std::size_t>(b)];
  const int count =
      bin_start_[static_cast<std::size_t>(b) + 1] - bin_start_[static_cast<std::size_t>(b)];
  return collect_in(dir, members, count, t_min, t_max, out, capacity, sorted);
}

int CandidateFan::collect(glm::vec3 dir, float t_min, float t_max, Candidate* out, int capacity,
                          bool sorted) const {
  return collect_in(dir, nullptr, static_cast<int>(terms_.size()), t_min, t_max, out, capacity,
                    sorted);
}

int CandidateFan::collect_in(glm::vec3 dir, const int* members, int count, float t_min, float t_max,
                             Candidate* out, int capacity, bool sorted) const {
  const float dir_len = glm::length(dir);
  auto hit = [&](std::size_t j, Interval& iv) {
    const Term& e = terms_[j];
    if (glm::dot(dir, e.axis) < e.cos_cull * dir_len) return false;  // surely a miss
    // The rest of intersect(), operation by operation.
    const glm::vec3 d = (e.rt * dir) / e.radii;
    const float a = glm::dot(d, d);
    if (!(a > 0.0f)) return false;
    const float b = glm::dot(e.o, d);
    const float disc = b * b - a * e.c;
    if (disc < 0.0f) return false;
    const float sq = std::sqrt(disc);
    iv.t_in = (-b - sq) / a;
    iv.t_out = (-b + sq) / a;
    return true;
  };
  if (members == nullptr)
    return cumuli::collect([](int i) { return i; }, count, hit, t_min, t_max, out, capacity,
                           sorted);
  return cumuli::collect([members](int i) { return members[i]; }, count, hit, t_min, t_max, out,
                         capacity, sorted);
}

int union_owner(const CloudShape& cloud, const Candidate* cand, int n, float s, glm::vec3 p,
                int fallback) {
  float q;
  return union_owner(cloud, cand, n, s, p, fallback, q);
}

int union_owner(const CloudShape& cloud, const Candidate* cand, int n, float s, glm::vec3 p,
                int fallback, float& q_owner) {
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
  const int owner = best < 0 ? fallback : cand[best].primitive;
  q_owner = best_q != INFINITY
                ? best_q
                : cloud.primitives[static_cast<std::size_t>(owner)].normalised_distance(p);
  return owner;
}

}  // namespace cumuli
