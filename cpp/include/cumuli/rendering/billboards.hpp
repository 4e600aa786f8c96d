// Billboard clouds as sprites (Torchelsen & Musse 2005 §3.2 and §5, "vertex-shader" billboards):
// the sprite list one frame draws of a batch of
// billboard clouds — each a variant (its geometry, in its local frame) placed by an instance
// transform world = R_y(yaw)·local + offset — for both drawers (the GL sprite pipeline and its
// CPU twin, rendering/sprites.hpp), so that culling, fades, order and shading are computed
// once, in C++, whatever the backend.
//
// Per instance i of variant V (a BillboardCloud is one instance with yaw 0, offset 0):
//   * culled when its bounding sphere lies outside the frustum (never changes a pixel);
//   * alpha_i = opacity_V · instance alpha (formation/dissipation fades, [W] via [TM]).
// Per billboard q (world centre p = R_y(yaw)·p_local + offset, in double then float32; view
// depth Z = (p − eye)·f):
//   * skipped when Z ≤ near, when its screen rectangle misses the image, or when its alpha is 0
//     (none of which changes a pixel);
//   * alpha = alpha_i · near fade smoothstep(z0, z1, Z) · far fade (1 − smoothstep(0.9·R, R, Z))
//     (FlightGear-style fades; each optional; beyond [TM]);
//   * colour: vertex mode ([TM]) — the four corner colours of light/caf.hpp's shading evaluated
//     in the variant's local frame (corners for the camera's right/up and the lights turned by
//     −yaw; the CAF block of the instance); fragment mode — the per-sprite data the rasteriser
//     shades each pixel with (cloud frame in world space, CAF per light).
// Order, back to front: per cloud (default, [TM]/Harris) instances by decreasing distance of
// their cloud centre c_C from the eye, then each instance's billboards by decreasing key;
// global_sort: all billboards by decreasing key. Key: distance |p − eye| or depth Z; ties keep
// the input order (stable), so the list does not depend on the thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "cumuli/light/caf.hpp"
#include "cumuli/rendering/sprites.hpp"

namespace cumuli {

// One variant's geometry (local frame), borrowed from the caller's arrays.
struct BillboardVariant {
  const glm::vec3* centres = nullptr;
  const glm::vec2* sizes = nullptr;  // width, height
  const float* rotation = nullptr;   // degrees about the view axis
  const std::int32_t* texture = nullptr;
  const std::int32_t* box = nullptr;  // owning box of each billboard
  std::size_t billboards = 0;
  std::size_t boxes = 0;
  ShadeFrame frame;               // from its boxes (directional term, height levels)
  glm::vec3 sphere_centre{0.0f};  // bounding sphere of its quads at any orientation
  float sphere_radius = 0.0f;
  float opacity = 1.0f;
  std::int32_t texture_base = 0;  // added to texture: the cell in the combined atlas
};

struct BillboardInstance {
  std::int32_t variant = 0;
  glm::vec3 offset{0.0f};
  float yaw = 0.0f;           // degrees about +y
  float alpha = 1.0f;         // formation/dissipation fade, in [0, 1]
  std::size_t caf_first = 0;  // first column of its CAF block
};

struct BillboardDrawSettings {
  bool caf_per_box = true;  // CAF columns are boxes (else billboards)
  bool global_sort = false;
  SpriteSort sort = SpriteSort::Distance;
  bool cull = true;
  bool fade_near = false;
  float near_start = 0.0f, near_end = 1.0f;  // z0 < z1
  bool fade_far = false;
  float range = 1.0f;     // R > 0
  bool fragment = false;  // per-pixel shading data instead of vertex colours

  void validate() const;
};

struct BillboardSpriteList {
  std::vector<glm::vec3> centre;  // world
  std::vector<glm::vec2> half;    // half width, half height
  std::vector<float> rotation;    // degrees
  std::vector<float> alpha;
  std::vector<std::int32_t> texture;     // combined-atlas cell
  std::vector<float> colour;             // (n, 4, 3) corner colours (vertex mode; zeros otherwise)
  std::vector<glm::vec4> frame;          // fragment mode: (c_C world, R_C)
  std::vector<glm::vec2> yrange;         // fragment mode: (y_lo, y_hi) world
  std::vector<float> caf;                // fragment mode: (n, lights)
  std::vector<std::uint32_t> instance;   // provenance: instance index
  std::vector<std::uint32_t> billboard;  //             billboard index in its variant
};

// The sprites of a frame. caf is (lights × columns) row-major: instance i's billboard q reads
// column caf_first_i + (its box, or q). lights are in world space (unit directions).
BillboardSpriteList billboard_sprites(const std::vector<BillboardVariant>& variants,
                                      const std::vector<BillboardInstance>& instances,
                                      const float* caf, std::size_t columns,
                                      const std::vector<ShadeLight>& lights,
                                      const ShadeParams& params, const SpriteCamera& camera,
                                      const BillboardDrawSettings& settings, int threads);

}  // namespace cumuli
