#include "cumuli/rendering/compositor.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <utility>

#include "cumuli/parallel.hpp"

namespace cumuli {

void composite_layers(const std::vector<Layer>& layers, const CameraParams& camera, int width,
                      int height, const SkyParams& sky, const SunParams& sun,
                      const GroundParams& ground, float* out, int threads, const float* solid) {
  if (width < 1 || height < 1) throw std::invalid_argument("width and height must be >= 1");
  camera.validate();
  const CameraRays rays(camera, width, height);
  parallel_chunks(static_cast<std::size_t>(height), threads, [&](std::size_t r0, std::size_t r1) {
    std::vector<std::pair<float, std::size_t>> hits;
    hits.reserve(layers.size());
    for (std::size_t r = r0; r < r1; ++r) {
      for (int c = 0; c < width; ++c) {
        const glm::vec3 dir = rays.direction(static_cast<int>(r), c);
        const glm::vec3 inv_dir = 1.0f / dir;
        // The marcher's rule (rendering/marcher.cpp): entered at max(t_in, 0), stable insertion
        // sort.
        hits.clear();
        for (std::size_t k = 0; k < layers.size(); ++k) {
          Interval iv;
          if (!intersect(layers[k].box, rays.origin, inv_dir, iv)) continue;
          if (!(iv.t_out >= 0.0f)) continue;
          hits.emplace_back(std::max(iv.t_in, 0.0f), k);
          for (std::size_t m = hits.size() - 1; m > 0 && hits[m - 1].first > hits[m].first; --m)
            std::swap(hits[m], hits[m - 1]);
        }
        const std::size_t px = r * static_cast<std::size_t>(width) + static_cast<std::size_t>(c);
        // A solid hit at t_s hides every layer entered at or after it (rendering/solids.hpp).
        const float* s = solid != nullptr ? solid + px * 4 : nullptr;
        const float t_solid = s != nullptr && s[3] < kNoSolid
                                  ? s[3] / ((dir.x * rays.forward.x + dir.y * rays.forward.y) +
                                            dir.z * rays.forward.z)
                                  : kNoSolid;
        glm::vec3 colour(0.0f);
        float T = 1.0f;       // the coverage's
        float T_view = 1.0f;  // what lies behind is seen through (the δ-M view of media)
        for (const auto& h : hits) {
          if (h.first >= t_solid) break;
          const Layer& layer = layers[h.second];
          const float* l = layer.rgba + px * 4;
          colour += T_view * glm::vec3(l[0], l[1], l[2]);
          const float clear = 1.0f - l[3];
          T *= clear;
          T_view *=
              layer.view_scale == 1.0f ? clear : std::pow(std::max(clear, 0.0f), layer.view_scale);
        }
        if (t_solid < kNoSolid) {
          colour += T_view * glm::vec3(s[0], s[1], s[2]);
          T = 0.0f;
          T_view = 0.0f;
        }
        const glm::vec3 rgb = colour + T_view * background(sky, sun, ground, rays.origin, dir);
        float* o = out + px * 4;
        o[0] = rgb.x;
        o[1] = rgb.y;
        o[2] = rgb.z;
        o[3] = 1.0f - T;
      }
    }
  });
}

}  // namespace cumuli
