// Sorted candidate intervals along a ray (Algorithm 1's candidate list; Algorithm 2 reuses it).
//
// Shared by the light pass and the CPU marcher so that both see the same primitives in the same
// order as the GLSL marcher. The caller owns the buffer: no allocation per ray.
#pragma once

#include "cumuli/cloud.hpp"

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

// The intervals where the ray o + t·d (d need not be unit) meets the cloud's primitives (grown by
// candidate_scale), clipped to [t_min, t_max] and sorted by t_in with an insertion sort, as the
// paper does. At most `capacity` are kept: when full, the one that starts farthest is dropped.
// Returns the number written to `out`.
int collect_candidates(const CloudShape& cloud, glm::vec3 origin, glm::vec3 dir, float t_min,
                       float t_max, Candidate* out, int capacity);

}  // namespace cumuli
