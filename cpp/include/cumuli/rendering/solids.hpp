// Opaque solids inside clouds: Harris 2002 §3.1.1 ("impostor splitting", Fig. 7). A Solid is an
// analytic opaque sphere — the "airplane" stand-in — drawn per pixel by ray–sphere intersection,
// shaded Lambert by the sun plus an ambient term, depth-tested among the solids. The GLSL twins are
// shaders/common/solid.glsl (intersection, used by the marchers to stop at a solid) and
// shaders/solids/solid.frag.glsl (the solid image).
//
// Ray o + t·d (d unit): oc = o − c, b = oc·d, k = oc·oc − r², disc = b² − k; a miss when disc < 0
// or when the far root −b + √disc < 0; else t = max(−b − √disc, 0) (an eye inside the sphere sees
// it at t = 0). Shading at p = o + t·d with n = (p − c)/r:
//   rgb = colour ⊙ (ambient + max(0, n·s)·sun_radiance),   s towards the sun.
// The solid image holds rgb and the view depth Z = t·(d·f) (f the camera's forward) in alpha,
// +∞ where no solid is hit — what the compositor (rendering/compositor.hpp) and the sprite depth
// test read. Split composite ([H] §3.1.1): cloud layers L_0 (farthest) … L_m (nearest) and solid
// images S_0 … S_{m−1} (S_j lies between L_j and L_{j+1}) are combined back to front:
//   dst = L_0; for j: where S_j is hit nearer than every solid drawn so far, dst = (S_j.rgb, 1);
//   dst = L_{j+1} + (1 − L_{j+1}.a)·dst          (depth test on for solids, off for layers).
#pragma once

#include <limits>
#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/phase.hpp"

namespace cumuli {

struct SolidSphere {
  glm::vec3 centre{0.0f};
  float radius = 1.0f;
  glm::vec3 colour{0.6f};
  glm::vec3 ambient{0.15f};

  void validate() const;  // throws std::invalid_argument
};

constexpr float kNoSolid = std::numeric_limits<float>::infinity();
// Most solids one scene holds (the GLSL uniform arrays' size).
constexpr int kMaxSolids = 16;

// Nearest t ≥ 0 at which the ray meets the sphere, or kNoSolid.
float ray_sphere(glm::vec3 origin, glm::vec3 dir, glm::vec3 centre, float radius);
// Nearest hit over all solids (ties: the first); `which` gets its index or −1.
float nearest_solid(const std::vector<SolidSphere>& solids, glm::vec3 origin, glm::vec3 dir,
                    int* which = nullptr);
glm::vec3 shade_solid(const SolidSphere& solid, glm::vec3 point, const SunParams& sun);

// draw_solids and composite_split (what the compositor does with solids) are in
// rendering/compositor.hpp.

}  // namespace cumuli
