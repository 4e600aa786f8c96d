// Bindings of the light stage (python/cumuli/light): the NDT light-grid precompute (light/ndt.hpp,
// Algorithm 2, eqs. 3–7) and the endless animation's volume light (light/volume_light.hpp: sun
// and sky optical depths, SH exponential, multiple scattering). Long loops release the GIL.
#include "cumuli/light/ndt.hpp"

#include <array>
#include <stdexcept>
#include <string>

#include <pybind11/stl.h>

#include "common.hpp"
#include "cumuli/light/volume_light.hpp"

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
        } else if (method == "shared") {
          s.method = LightMethod::Shared;
        } else {
          throw py::value_error("method must be 'ndt', 'naive' or 'shared', got '" + method + "'");
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

namespace {

DepthMethod depth_method(const std::string& method) {
  if (method == "sweep") return DepthMethod::Sweep;
  if (method == "march") return DepthMethod::March;
  throw py::value_error("method must be 'sweep' or 'march', got '" + method + "'");
}

ShExpTable table_of(const py::array_t<float>& a, const py::array_t<float>& b, float max_norm,
                    int order, bool squaring) {
  if (squaring) return shexp_squaring(order);
  ShExpTable t;
  t.order = order;
  t.max_norm = max_norm;
  if (a.ndim() != 1 || b.ndim() != 1 || a.shape(0) != b.shape(0) || a.shape(0) < 1)
    throw py::value_error("shexp tables a and b must be 1-D of the same non-zero length");
  t.a.assign(a.data(), a.data() + a.shape(0));
  t.b.assign(b.data(), b.data() + b.shape(0));
  return t;
}

}  // namespace

void bind_volume_light(py::module_& m) {
  m.def(
      "sun_optical_depth",
      [](const FloatArray& vols, V3 lo, V3 hi, V3 to_sun, float step, int threads,
         const std::string& method) {
        const VolumeGrid g = grid_of(vols, 1, lo, hi, "volumes");
        const DepthMethod how = depth_method(method);
        const int n = static_cast<int>(vols.shape(0));
        const float* v = vols.data();
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = sun_optical_depth(v, n, g, v3(to_sun), step, threads, how);
        }
        return to_array(out, shape_of(vols));
      },
      py::arg("volumes"), py::arg("box_min"), py::arg("box_max"), py::arg("to_sun"),
      py::arg("step"), py::arg("threads"), py::arg("method") = "march",
      "Optical depth towards the sun per voxel: (N, D, H, W); method 'march' or 'sweep'.");

  m.def(
      "sh_optical_depth",
      [](const FloatArray& vols, V3 lo, V3 hi, int order, int n_theta, float step, int threads,
         const std::string& method) {
        const VolumeGrid g = grid_of(vols, 1, lo, hi, "volumes");
        const DepthMethod how = depth_method(method);
        const int n = static_cast<int>(vols.shape(0));
        const float* v = vols.data();
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = sh_optical_depth(v, n, g, order, n_theta, step, threads, how);
        }
        auto shape = shape_of(vols);
        shape.push_back(order * order);
        return to_array(out, shape);
      },
      py::arg("volumes"), py::arg("box_min"), py::arg("box_max"), py::arg("order"),
      py::arg("n_theta"), py::arg("step"), py::arg("threads"), py::arg("method") = "march",
      "SH coefficients of per-voxel optical depth over directions: (N, D, H, W, order²).");

  m.def(
      "sh_eval",
      [](int order, const FloatArray& dirs) {
        require_points(dirs, "directions");
        if (order < 1 || order > kMaxShOrder) throw py::value_error("sh_order must be in [1, 4]");
        const py::ssize_t n = dirs.shape(0);
        auto out = new_array({n, order * order});
        for (py::ssize_t i = 0; i < n; ++i) {
          const float* d = dirs.data() + 3 * i;
          sh_eval(order, glm::vec3(d[0], d[1], d[2]), out.mutable_data() + i * order * order);
        }
        return out;
      },
      py::arg("order"), py::arg("directions"));

  m.def(
      "sphere_quadrature",
      [](int n_theta) {
        const SphereQuadrature q(n_theta);
        auto dirs = new_array({static_cast<py::ssize_t>(q.dirs.size()), 3});
        for (std::size_t i = 0; i < q.dirs.size(); ++i)
          for (int k = 0; k < 3; ++k) dirs.mutable_data()[3 * i + k] = q.dirs[i][k];
        return py::make_tuple(dirs, to_array(q.weights, {static_cast<py::ssize_t>(q.weights.size())}));
      },
      py::arg("n_theta"));

  m.def(
      "sky_sh",
      [](const py::tuple& sky, int order, int n_theta) {
        return to_array(sky_sh(sky_of(sky), order, n_theta), {3, order * order});
      },
      py::arg("sky"), py::arg("order"), py::arg("n_theta"));

  m.def(
      "fit_shexp",
      [](const FloatArray& f, int order, float sigma_t, int bins, int n_theta) {
        if (f.ndim() != 2 || f.shape(1) != order * order)
          throw py::value_error("optical-depth SH samples must have shape (M, order²)");
        const float* pf = f.data();
        const std::size_t m = static_cast<std::size_t>(f.shape(0));
        ShExpTable t;
        {
          py::gil_scoped_release release;
          t = fit_shexp(pf, m, order, sigma_t, bins, n_theta);
        }
        const auto nb = static_cast<py::ssize_t>(t.a.size());
        return py::make_tuple(to_array(t.a, {nb}), to_array(t.b, {nb}), t.max_norm);
      },
      py::arg("f"), py::arg("order"), py::arg("sigma_t"), py::arg("bins"), py::arg("n_theta"));

  m.def(
      "shexp_apply",
      [](const FloatArray& g, const FloatArray& a, const FloatArray& b, float max_norm, int order,
         bool squaring) {
        if (g.ndim() != 2 || g.shape(1) != order * order)
          throw py::value_error("SH vectors must have shape (M, order²)");
        if (order < 1 || order > kMaxShOrder) throw py::value_error("sh_order must be in [1, 4]");
        const ShExpTable t = table_of(a, b, max_norm, order, squaring);
        auto out = new_array(shape_of(g));
        for (py::ssize_t i = 0; i < g.shape(0); ++i)
          t.apply(g.data() + i * order * order, out.mutable_data() + i * order * order);
        return out;
      },
      py::arg("g"), py::arg("a"), py::arg("b"), py::arg("max_norm"), py::arg("order"),
      py::arg("squaring") = false);

  m.def(
      "light_volume",
      [](const FloatArray& f_sun, const FloatArray& f_sh, V3 lo, V3 hi, const FloatArray& a,
         const FloatArray& b, float max_norm, int order, bool squaring, const FloatArray& sky,
         float sigma_t, int threads) {
        const VolumeGrid g = grid_of(f_sun, 0, lo, hi, "sun optical depth");
        const VolumeGrid gs = grid_of(f_sh, 0, lo, hi, "sky optical depth", 1);
        if (gs.w != g.w || gs.h != g.h || gs.d != g.d || f_sh.shape(3) != order * order)
          throw py::value_error("sky optical depth must have shape (D, H, W, order²)");
        if (sky.ndim() != 2 || sky.shape(0) != 3 || sky.shape(1) != order * order)
          throw py::value_error("sky SH must have shape (3, order²)");
        if (!(sigma_t >= 0.0f)) throw py::value_error("sigma_t must be >= 0");
        const ShExpTable t = table_of(a, b, max_norm, order, squaring);
        const float *ps = f_sun.data(), *ph = f_sh.data(), *pk = sky.data();
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = light_volume(ps, ph, g, t, pk, sigma_t, threads);
        }
        return to_array(out, {g.d, g.h, g.w, 4});
      },
      "Per-voxel (τ_sun, E_sky RGB): (D, H, W, 4).");

  m.def(
      "volume_sample_points",
      [](V3 lo, V3 hi, int count, std::uint64_t seed) {
        VolumeGrid g;
        g.box = Box{v3(lo), v3(hi)};
        const auto pts = volume_sample_points(g, count, seed);
        auto out = new_array({static_cast<py::ssize_t>(pts.size()), 3});
        for (std::size_t i = 0; i < pts.size(); ++i)
          for (int k = 0; k < 3; ++k) out.mutable_data()[3 * i + k] = pts[i][k];
        return out;
      },
      py::arg("box_min"), py::arg("box_max"), py::arg("count"), py::arg("seed"));

  m.def(
      "point_optical_depth",
      [](const FloatArray& vols, V3 lo, V3 hi, const FloatArray& points, float step, int threads,
         const std::string& method) {
        const VolumeGrid g = grid_of(vols, 1, lo, hi, "volumes");
        const DepthMethod how = depth_method(method);
        require_points(points, "points");
        std::vector<glm::vec3> pts(static_cast<std::size_t>(points.shape(0)));
        for (std::size_t i = 0; i < pts.size(); ++i)
          pts[i] = glm::vec3(points.data()[3 * i], points.data()[3 * i + 1], points.data()[3 * i + 2]);
        const int n = static_cast<int>(vols.shape(0));
        const float* v = vols.data();
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = point_optical_depth(v, n, g, pts, step, threads, how);
        }
        auto shape = shape_of(vols);
        shape.push_back(static_cast<py::ssize_t>(pts.size()));
        return to_array(out, shape);
      },
      py::arg("volumes"), py::arg("box_min"), py::arg("box_max"), py::arg("points"),
      py::arg("step"), py::arg("threads"), py::arg("method") = "march",
      "Optical depth from every voxel centre to every sample point: (N, D, H, W, K).");

  m.def(
      "add_multiple_scattering",
      [](const FloatArray& density, const FloatArray& light, V3 lo, V3 hi,
         const FloatArray& point_depth, const FloatArray& points, V3 sun_radiance, float sigma_t,
         float albedo, int orders, int threads) {
        const VolumeGrid g = grid_of(density, 0, lo, hi, "density");
        const VolumeGrid lg = grid_of(light, 0, lo, hi, "light", 1);
        const VolumeGrid pg = grid_of(point_depth, 0, lo, hi, "point optical depth", 1);
        require_points(points, "points");
        const auto np = points.shape(0);
        if (lg.w != g.w || lg.h != g.h || lg.d != g.d || light.shape(3) != 4)
          throw py::value_error("light must have shape (D, H, W, 4) matching the density");
        if (pg.w != g.w || pg.h != g.h || pg.d != g.d || point_depth.shape(3) != np)
          throw py::value_error("point optical depth must have shape (D, H, W, K)");
        std::vector<glm::vec3> pts(static_cast<std::size_t>(np));
        for (std::size_t i = 0; i < pts.size(); ++i)
          pts[i] = glm::vec3(points.data()[3 * i], points.data()[3 * i + 1], points.data()[3 * i + 2]);
        auto out = new_array(shape_of(light));
        std::copy(light.data(), light.data() + light.size(), out.mutable_data());
        float* po = out.mutable_data();
        const float *pd = density.data(), *pp = point_depth.data();
        {
          py::gil_scoped_release release;
          add_multiple_scattering(pd, po, g, pp, pts, v3(sun_radiance), sigma_t, albedo, orders,
                                  threads);
        }
        return out;
      },
      "Light plus `orders` orders of isotropic multiple scattering through the sample points.");
}

}  // namespace cumuli::bind
