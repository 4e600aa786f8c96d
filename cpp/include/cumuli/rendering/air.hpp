// The physical mode's finishing passes on a finished image (RENDER_CONTRACT "Physical
// lighting", "Air" and "Resolve"), the same for both backends: the air between the camera and
// what it sees (aerial perspective and the aureole), then the 3×3 tent resolve. The numpy twins
// are cumuli.rendering.air.add_air and cumuli.rendering.resolve.tent_filter; this pass does
// per pixel what they do per array, threaded over rows.
//
// Aerial perspective, extinction k: a pixel of coverage α = clamp(a, 0, 1) is its clouds'
// premultiplied radiance C over its background B (the renderers' background, recomputed where
// 0 < α < 1; the pixel itself where α = 0). B fades with the distance t_bg of its air (the
// ground plane's where the ray meets it, else air_height/|d.y|), C with the midpoint D of the
// ray's chord through the first box it enters:
//   faded_B = B + (1 − e^{−k·t_bg})·(horizon − B)
//   rgb     = C + (1 − e^{−k·D})·(α·horizon − C) + (1 − α)·faded_B      (α > 0)
// Aureole: E_sun·haze·p(min(cos θ, cos r_disc)) added, times (1 − α) + α·(1 − e^{−k·D}).
#pragma once

#include <cstdint>

#include <vector>

#include "cumuli/primitives.hpp"
#include "cumuli/rendering/ground.hpp"
#include "cumuli/rendering/marcher.hpp"
#include "cumuli/rendering/physical.hpp"
#include "cumuli/sky.hpp"

namespace cumuli {

struct AirParams {
  float extinction = 0.0f;  // k per world unit; 0: no aerial perspective
  float height = 0.0f;      // air_height: the hazy layer's thickness
  float haze = 0.0f;        // the aureole's optical depth; 0: no aureole
  PhysicalParams phase;     // its phase function: phase.phase(c, 1)
  bool resolve = false;     // the 3×3 tent after the air

  void validate() const;  // throws std::invalid_argument
};

// Finishes the (height, width, 4) linear RGBA image `rgba` (row 0 on top) into `out` (the same
// size): the air, then the resolve. `out` may be `rgba` itself (in place, the same result: a
// 1080p frame then needs no second 33 MB image), but must not overlap it otherwise. `boxes`: the
// drawables' layer boxes (for the clouds' depth). The result does not depend on the thread count.
// `unfiltered` (height·width bytes, optional): pixels whose byte is nonzero skip the resolve's
// tent (the edge pass's supersampled pixels, already antialiased) but still see the air.
void finish_physical(const float* rgba, float* out, int width, int height,
                     const CameraParams& camera, const SkyParams& sky, const SunParams& sun,
                     const GroundParams& ground, const std::vector<Box>& boxes,
                     const AirParams& air, int threads, const std::uint8_t* unfiltered = nullptr);

}  // namespace cumuli
