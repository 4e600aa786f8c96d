// Sorted candidate intervals along a ray (Algorithm 1's candidate list; Algorithm 2 reuses it).
//
// Shared by the light pass and the CPU marcher so that both see the same primitives in the same
// order as the GLSL marcher. The caller owns the buffer: no allocation per ray.
#pragma once

#include <cmath>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "cumuli/model/cloud.hpp"

namespace cumuli {

struct Candidate {
  float t_in = 0.0f;
  float t_out = 0.0f;
  int primitive = -1;
};

// Scale applied to every primitive when collecting candidates. 1 for pseudo-spheroids. For
// metaballs the iso-surface Σ 1/|q_i|² ≥ 1 reaches beyond the primitives: if every |q_i| > √N the
// sum is < 1, so primitives grown by √N bound it exactly.
float candidate_scale(const CloudShape& cloud);

// World bounds of the primitives grown by candidate_scale: every candidate interval lies inside.
// The render pass tests rays against it; the light pass pads it into the light grid's box.
Box candidate_bounds(const CloudShape& cloud);

// The intervals where the ray o + t·d (d need not be unit) meets the cloud's primitives (grown by
// candidate_scale), clipped to [t_min, t_max] and sorted by t_in with an insertion sort, as the
// paper does (ties keep the primitive order). At most `capacity` are kept: when full, the one
// that starts farthest is dropped. With `sorted` false they stay in primitive order and the first
// `capacity` found are kept (the marchers' candidate_sort="none", a cost reference).
// Returns the number written to `out`.
int collect_candidates(const CloudShape& cloud, glm::vec3 origin, glm::vec3 dir, float t_min,
                       float t_max, Candidate* out, int capacity, bool sorted = true);
// The same, testing only the primitives listed in `subset` (`count` indices, increasing): the
// same list whenever the others surely miss the ray (the light pass culls them per column).
int collect_candidates(const CloudShape& cloud, const int* subset, int count, glm::vec3 origin,
                       glm::vec3 dir, float t_min, float t_max, Candidate* out, int capacity,
                       bool sorted = true);

// The union-march attribution rule (RENDER_CONTRACT march="union", Algorithm 2's NDT): a sample
// at ray parameter s, world point p, belongs to the covering candidate (t_in ≤ s ≤ t_out) whose
// primitive gives the smallest |q| at p, the first in candidate order on ties; `fallback` when
// none covers s (rounding can leave s just past an interval). Returns the primitive index.
// The CPU marcher calls this per sample; the light pass evaluates the same rule incrementally
// (UnionAttribution in lighting.cpp: |q|² from the candidate test's quadratic, active list).
int union_owner(const CloudShape& cloud, const Candidate* cand, int n, float s, glm::vec3 p,
                int fallback);
// The same, with the owner's |q| at p in `q_owner` (computed once: the comparison's own value).
int union_owner(const CloudShape& cloud, const Candidate* cand, int n, float s, glm::vec3 p,
                int fallback, float& q_owner);

// A cone of directions: those within `half_angle` radians of the unit `axis`.
struct DirectionCone {
  glm::dvec3 axis{0.0, 0.0, 1.0};
  double half_angle = 0.0;
};

// collect_candidates for the rays of one origin (a camera's): the terms of each primitive's
// intersection that depend only on the origin are computed once, and every direction gets the
// same intervals, bit for bit, as collect_candidates(cloud, origin, dir, ...).
class CandidateFan {
 public:
  CandidateFan(const CloudShape& cloud, glm::vec3 origin);
  // Sorts the primitives into bins, one per cone of `bins` (a screen tile's rays): bin b lists,
  // in increasing order, every primitive whose cull cone meets cone b. collect(dir, b, ...) for
  // a direction inside cone b then tests only those; the others' cones lie wholly outside it,
  // so the cull test would have dropped them anyway, and the intervals stay the same bit for bit.
  void bin(const std::vector<DirectionCone>& bins);
  int collect(glm::vec3 dir, float t_min, float t_max, Candidate* out, int capacity,
              bool sorted = true) const;
  // The cloud's primitives.
  std::size_t size() const { return terms_.size(); }
  // The primitives bin b holds (every primitive when there are no bins or b < 0).
  int bin_size(int b) const {
    if (b < 0 || static_cast<std::size_t>(b) + 1 >= bin_start_.size())
      return static_cast<int>(terms_.size());
    return bin_start_[static_cast<std::size_t>(b) + 1] - bin_start_[static_cast<std::size_t>(b)];
  }
  // The same for a direction inside the cone of bin `b` (bin()); b < 0: every primitive.
  int collect(glm::vec3 dir, int b, float t_min, float t_max, Candidate* out, int capacity,
              bool sorted = true) const;
  // Primitive j's normalised distance |q| at p: Ellipsoid::normalised_distance, the rotation
  // skipped when it is the identity (it then changes at most the sign of a zero, which the
  // squares take off: the same |q| bit for bit).
  float q(int j, glm::vec3 p) const { return std::sqrt(q2(j, p)); }
  // |q|², whose square root is q(j, p) bit for bit (glm::length is sqrt(dot(v, v))).
  float q2(int j, glm::vec3 p) const {
    const Term& e = terms_[static_cast<std::size_t>(j)];
    const glm::vec3 v = p - e.centre;
    const glm::vec3 w = (e.identity ? v : e.rt * v) / e.unscaled;
    return glm::dot(w, w);
  }
  // The ray origin + s·dir in primitive j's unit frame (own radii): its |q|² at s is
  // |from + s·along|², q2(j, origin + s·dir) up to rounding.
  void ray_frame(int j, glm::vec3 dir, glm::vec3& from, glm::vec3& along) const {
    const Term& e = terms_[static_cast<std::size_t>(j)];
    from = e.o_own;
    along = (e.identity ? dir : e.rt * dir) / e.unscaled;
  }

 private:
  // collect() over the primitives members[0 .. count) (increasing), or the first `count` when
  // members is null.
  int collect_in(glm::vec3 dir, const int* members, int count, float t_min, float t_max,
                 Candidate* out, int capacity, bool sorted) const;

  struct Term {
    glm::mat3 rt;     // the rotation's transpose
    glm::vec3 radii;  // grown by candidate_scale
    glm::vec3 o;      // the origin in the unit-sphere frame
    float c;          // |o|² − 1
    glm::vec3 centre;
    glm::vec3 unscaled;  // the primitive's own radii (|q| is the primitive's, not the grown one's)
    glm::vec3 o_own;     // the origin in the own radii's unit frame
    bool identity;       // the rotation is exactly the identity
    // The cone from the origin around the grown primitive's bounding sphere, widened well beyond
    // the exact test's rounding: a direction d with d·axis < cos_cull·|d| surely misses.
    glm::vec3 axis;
    float cos_cull;
    double cull_angle;  // the cone's half-angle (cos_cull's, before the float rounding); > π: none
  };
  std::vector<Term> terms_;
  std::vector<int> bin_start_;  // bin b holds bin_members_[bin_start_[b] .. bin_start_[b + 1])
  std::vector<int> bin_members_;
};

}  // namespace cumuli
