// Bindings for cumuli/lighting.hpp: the light-grid precompute (Algorithm 2, eqs. 3–7).
#include "cumuli/lighting.hpp"

#include <array>
#include <stdexcept>
#include <string>

#include <pybind11/stl.h>

#include "common.hpp"

namespace cumuli::bind {

void bind_light(py::module_& m) {
  m.attr("LIGHT_MAX_RESOLUTION") = LightSettings::kMaxResolution;
  m.attr("LIGHT_MAX_STEPS_PER_RAY") = LightSettings::kMaxStepsPerRay;
  m.def(
      "light_grid",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& rotations,
         const std::string& model, float kappa, float phi, const Noise* noise,
         std::array<float, 3> sun_dir, std::array<int, 3> resolution, const std::string& method,
         float step, float extinction, float solid_angle, int octaves, float gain,
         float lacunarity, float frequency, float density_constant, int threads) {
        const CloudShape cloud =
            cloud_from_arrays(centres, radii, rotations, model, kappa, phi);
        LightSettings s;
        s.sun_dir = glm::vec3(sun_dir[0], sun_dir[1], sun_dir[2]);
        for (int a = 0; a < 3; ++a) s.resolution[a] = resolution[a];
        if (method == "ndt") {
          s.method = LightMethod::Ndt;
        } else if (method == "naive") {
          s.method = LightMethod::Naive;
        } else {
          throw py::value_error("method must be 'ndt' or 'naive', got '" + method + "'");
        }
        s.step = step;
        s.extinction = extinction;
        s.solid_angle = solid_angle;
        s.threads = threads;
        DensitySource src;
        src.noise = noise;
        src.fbm = FbmParams{octaves, gain, lacunarity, frequency};
        src.constant = density_constant;
        // Validate everything before allocating the output.
        const Box box = [&] {
          try {
            if (s.resolution[0] < 2 || s.resolution[1] < 2 || s.resolution[2] < 2 ||
                s.resolution[0] > LightSettings::kMaxResolution ||
                s.resolution[1] > LightSettings::kMaxResolution ||
                s.resolution[2] > LightSettings::kMaxResolution)
              s.validate(Box{});
            const Box b = light_grid_box(cloud, s.resolution);
            s.validate(b);
            if (density_constant < 0.0f) {
              if (noise == nullptr)
                throw std::invalid_argument("noise is required unless density_override is given");
              src.fbm.validate();
            }
            return b;
          } catch (const std::invalid_argument& e) {
            throw py::value_error(e.what());
          }
        }();
        auto grid = new_array({resolution[2], resolution[1], resolution[0]});
        py::array_t<std::uint32_t> samples({resolution[2], resolution[1], resolution[0]});
        float* g = grid.mutable_data();
        std::uint32_t* n = samples.mutable_data();
        LightStats stats;
        {
          py::gil_scoped_release release;
          stats = compute_light_grid(cloud, src, s, g, n);
        }
        return py::make_tuple(grid, samples, py::make_tuple(box.lo.x, box.lo.y, box.lo.z),
                              py::make_tuple(box.hi.x, box.hi.y, box.hi.z), stats.samples,
                              stats.seconds);
      },
      py::arg("centres"), py::arg("radii"), py::arg("rotations"), py::arg("model"),
      py::arg("kappa"), py::arg("phi"), py::arg("noise").none(true), py::arg("sun_dir"),
      py::arg("resolution"), py::arg("method"), py::arg("step"), py::arg("extinction"),
      py::arg("solid_angle"), py::arg("octaves"), py::arg("gain"), py::arg("lacunarity"),
      py::arg("frequency"), py::arg("density_constant"), py::arg("threads"),
      "Light grid L(v) [z, y, x] (see cumuli.light_grid). Returns (grid, samples, lo, hi, "
      "total_samples, seconds).");
}

}  // namespace cumuli::bind
