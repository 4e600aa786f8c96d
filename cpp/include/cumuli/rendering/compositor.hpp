// The compositor (RENDER_CONTRACT "Compositor"): premultiplied layers, one per drawable of any
// kind, combined over the sky per pixel, front to back by each layer's box entry along the
// camera ray — the rule the 2018 marcher applies to its own clouds (boxes that overlap along a
// ray are not interleaved). Both backends composite with this function, so a mixed scene's GL
// and CPU images differ only where their layers do.
#pragma once

#include <vector>

#include "cumuli/phase.hpp"
#include "cumuli/primitives.hpp"
#include "cumuli/rendering/ground.hpp"
#include "cumuli/rendering/marcher.hpp"
#include "cumuli/rendering/solids.hpp"

namespace cumuli {

// One drawable's layer: (height·width·4) floats (colour premultiplied, alpha = 1 − T), row 0 at
// the top, and the world box every contribution of the drawable lies in.
struct Layer {
  const float* rgba = nullptr;
  Box box;
  // What lies behind the layer shows through (1 − A)^view_scale of it: the physical mode's δ-M
  // view of a medium (its forward peak carries the light behind on), 1: its coverage's 1 − A.
  float view_scale = 1.0f;
};

// out (height·width·4): rgb = Σ_k T_k·C_k + T_v·background(d), alpha = 1 − T (the background is
// the ground where the ray meets an enabled ground, else the sky: ground.hpp), with T_k the product
// of (1 − A_j)^{v_j} over the layers j the ray enters before k (entry max(t_in, 0), ties in layer
// order; v_j their view_scale), T_v over all of them and T the product of their (1 − A_j). A layer
// whose box the ray misses (or that lies behind the camera) contributes nothing at that pixel.
// `solid` (height·width·4: rgb, view depth) may be null. The result does not depend on the thread
// count.
void composite_layers(const std::vector<Layer>& layers, const CameraParams& camera, int width,
                      int height, const SkyParams& sky, const SunParams& sun,
                      const GroundParams& ground, float* out, int threads,
                      const float* solid = nullptr);

// The solid image (height·width·4 floats, row 0 on top): rgb shaded (rendering/solids.hpp), alpha
// the view depth Z = t·(d·f) of the nearest solid, +∞ where the ray meets none.
void draw_solids(const std::vector<SolidSphere>& solids, const CameraParams& camera, int width,
                 int height, const SunParams& sun, float* out, int threads);

// The split composite of rendering/solids.hpp: `layers` m + 1 premultiplied images, farthest first,
// `solids` m solid images (solids[j] between layers[j] and layers[j + 1]); out a premultiplied
// layer.
void composite_split(const std::vector<const float*>& layers,
                     const std::vector<const float*>& solids, int width, int height, float* out,
                     int threads);

}  // namespace cumuli
