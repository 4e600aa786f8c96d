// Bindings of the light stage (python/cumuli/light): the NDT light-grid precompute (light/ndt.hpp,
// Algorithm 2, eqs. 3–7) and the endless animation's volume light (light/volume.hpp: sun
// and sky optical depths, SH exponential, multiple scattering), and the billboard clouds'
// absorption factors and vertex shading (light/caf.hpp). Long loops release the GIL.
#include "cumuli/light/ndt.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <stdexcept>
#include <string>

#include <pybind11/stl.h>
#include <glm/geometric.hpp>

#include "common.hpp"
#include "cumuli/light/caf.hpp"
#include "cumuli/light/particles.hpp"
#include "cumuli/light/physical.hpp"
#include "cumuli/light/volume.hpp"
#include "cumuli/parallel.hpp"
#include "cumuli/phase.hpp"

namespace cumuli::bind {

const Names<Directional> kDirectional = {{"linear", Directional::Linear},
                                         {"smoothstep", Directional::Smoothstep}};

// This stage's parameter structs as classes (module.cpp binds them before the functions that
// take them): fields as attributes, vectors as tuples, enumerations by name.
void bind_light_params(py::module_& m) {
  py::class_<ShadeParams> sh(m, "ShadeParams",
                             "Billboard shading ([TM]): directional term (d_min, d_max, k_dir, "
                             "linear / smoothstep), ambient, k_amb and height levels (f, h).");
  sh.def(py::init<>())
      .def_readwrite("d_min", &ShadeParams::d_min)
      .def_readwrite("d_max", &ShadeParams::d_max)
      .def_readwrite("k_dir", &ShadeParams::k_dir)
      .def_readwrite("k_amb", &ShadeParams::k_amb)
      .def_readwrite("height_levels", &ShadeParams::height_levels)
      .def("validate", &ShadeParams::validate);
  vec3_property(sh, "ambient", &ShadeParams::ambient, "ambient");
  enum_property(sh, "directional", &ShadeParams::directional, kDirectional);
}

void bind_light(py::module_& m) {
  m.attr("LIGHT_MAX_RESOLUTION") = LightSettings::kMaxResolution;
  m.attr("LIGHT_MAX_STEPS_PER_RAY") = LightSettings::kMaxStepsPerRay;
  m.def(
      "light_grid",
      [](const CloudShape& cloud, const Noise* noise, std::array<float, 3> sun_dir,
         std::array<int, 3> resolution, const std::string& method, float step, float extinction,
         float solid_angle, const FbmParams& fbm, float density_constant, int threads) {
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
        src.fbm = fbm;
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
      py::arg("cloud"), py::arg("noise").none(true), py::arg("sun_dir"), py::arg("resolution"),
      py::arg("method"), py::arg("step"), py::arg("extinction"), py::arg("solid_angle"),
      py::arg("fbm"), py::arg("density_constant"), py::arg("threads"),
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
      "sample_volume",
      [](const FloatArray& vol, V3 lo, V3 hi, const FloatArray& points, int threads) {
        const VolumeGrid g = grid_of(vol, 0, lo, hi, "volume");
        require_points(points, "points");
        const std::size_t n = static_cast<std::size_t>(points.shape(0));
        auto out = new_array({static_cast<py::ssize_t>(n)});
        const float *v = vol.data(), *p = points.data();
        float* o = out.mutable_data();
        {
          py::gil_scoped_release release;
          parallel_for(n, threads, [&](std::size_t i) {
            o[i] = sample_trilinear(v, g, glm::vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]));
          });
        }
        return out;
      },
      py::arg("volume"), py::arg("lo"), py::arg("hi"), py::arg("points"), py::arg("threads") = 0,
      "Trilinear values (texel centres, clamp to edge) of a (D, H, W) volume at (N, 3) points.");

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
        return py::make_tuple(dirs,
                              to_array(q.weights, {static_cast<py::ssize_t>(q.weights.size())}));
      },
      py::arg("n_theta"));

  m.def(
      "sky_sh",
      [](const py::object& sky, int order, int n_theta) {
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
          pts[i] =
              glm::vec3(points.data()[3 * i], points.data()[3 * i + 1], points.data()[3 * i + 2]);
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
          pts[i] =
              glm::vec3(points.data()[3 * i], points.data()[3 * i + 1], points.data()[3 * i + 2]);
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

namespace {

using IntArray = py::array_t<int, py::array::c_style | py::array::forcecast>;

std::vector<Box> boxes_of(const FloatArray& a, const char* name) {
  if (a.ndim() != 3 || a.shape(1) != 2 || a.shape(2) != 3)
    throw py::value_error(std::string(name) + " must have shape (M, 2, 3)");
  std::vector<Box> out(static_cast<std::size_t>(a.shape(0)));
  const float* d = a.data();
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i].lo = glm::vec3(d[6 * i], d[6 * i + 1], d[6 * i + 2]);
    out[i].hi = glm::vec3(d[6 * i + 3], d[6 * i + 4], d[6 * i + 5]);
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(out[i].lo[k]) || !std::isfinite(out[i].hi[k]) ||
          out[i].lo[k] > out[i].hi[k])
        throw py::value_error(std::string(name) + " must be finite with lo <= hi");
  }
  return out;
}

std::vector<glm::vec3> vec3s(const FloatArray& a, const char* name) {
  require_points(a, name);
  std::vector<glm::vec3> out(static_cast<std::size_t>(a.shape(0)));
  const float* d = a.data();
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = glm::vec3(d[3 * i], d[3 * i + 1], d[3 * i + 2]);
    if (!std::isfinite(out[i].x) || !std::isfinite(out[i].y) || !std::isfinite(out[i].z))
      throw py::value_error(std::string(name) + " must be finite");
  }
  return out;
}

std::vector<int> owners_of(const IntArray& a, std::size_t n, std::size_t boxes, const char* name) {
  if (a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n)
    throw py::value_error(std::string(name) + " must have shape (N,) matching the points");
  std::vector<int> out(a.data(), a.data() + n);
  for (int o : out)
    if (o < -1 || o >= static_cast<int>(boxes))
      throw py::value_error(std::string(name) + " must hold box indices (or -1)");
  return out;
}

glm::vec3 unit(V3 v, const char* name) {
  const glm::vec3 d = v3(v);
  const float len = glm::length(d);
  if (!std::isfinite(len) || !(len > 0.0f))
    throw py::value_error(std::string(name) + " must be a non-zero finite vector");
  return d / len;
}

Overlap overlap_of(const std::string& s) {
  if (s == "sum") return Overlap::Sum;
  if (s == "union") return Overlap::Union;
  throw py::value_error("overlap must be 'sum' or 'union', got '" + s + "'");
}

std::vector<int> columns_of(const IntArray& a, std::size_t n, std::size_t q, const char* name) {
  std::vector<int> out = owners_of(a, n, q, name);
  for (int o : out)
    if (o < 0) throw py::value_error(std::string(name) + " must hold caf column indices");
  return out;
}

std::vector<glm::vec2> sizes_of(const FloatArray& sizes, const FloatArray& rotation,
                                std::size_t n) {
  if (sizes.ndim() != 2 || sizes.shape(1) != 2 || static_cast<std::size_t>(sizes.shape(0)) != n)
    throw py::value_error("sizes must have shape (K, 2) matching centres");
  if (rotation.ndim() != 1 || static_cast<std::size_t>(rotation.shape(0)) != n)
    throw py::value_error("rotation must have shape (K,) matching centres");
  std::vector<glm::vec2> sz(n);
  for (std::size_t i = 0; i < n; ++i) {
    sz[i] = glm::vec2(sizes.data()[2 * i], sizes.data()[2 * i + 1]);
    if (!std::isfinite(sz[i].x) || !std::isfinite(sz[i].y) || !std::isfinite(rotation.data()[i]))
      throw py::value_error("sizes and rotation must be finite");
  }
  return sz;
}

struct ShadeInputs {
  std::vector<ShadeLight> lights;
  ShadeParams params;
  ShadeFrame frame;
  std::size_t q = 0;
};

ShadeInputs shade_inputs(const FloatArray& caf, const FloatArray& boxes,
                         const FloatArray& light_dirs, const FloatArray& light_radiance,
                         const ShadeParams& params) {
  ShadeInputs in;
  const std::vector<Box> b = boxes_of(boxes, "boxes");
  if (b.empty()) throw py::value_error("boxes must not be empty");
  const std::vector<glm::vec3> dirs = vec3s(light_dirs, "light directions");
  const std::vector<glm::vec3> rad = vec3s(light_radiance, "light radiance");
  if (rad.size() != dirs.size()) throw py::value_error("one radiance per light direction");
  if (caf.ndim() != 2 || static_cast<std::size_t>(caf.shape(0)) != dirs.size())
    throw py::value_error("caf must have shape (lights, Q)");
  in.q = static_cast<std::size_t>(caf.shape(1));
  for (py::ssize_t i = 0; i < caf.size(); ++i)
    if (!std::isfinite(caf.data()[i])) throw py::value_error("caf must be finite");
  in.lights.resize(dirs.size());
  for (std::size_t l = 0; l < dirs.size(); ++l) {
    const float len = glm::length(dirs[l]);
    if (!(len > 0.0f)) throw py::value_error("light directions must be non-zero");
    in.lights[l] = ShadeLight{dirs[l] / len, rad[l]};
  }
  in.params = params;
  in.params.validate();
  in.frame = shade_frame(b);
  return in;
}

}  // namespace

void bind_caf(py::module_& m) {
  m.def(
      "caf_path_lengths",
      [](const FloatArray& boxes, const FloatArray& points, const IntArray& owner, V3 sun,
         const std::string& overlap, bool include_self, int threads) {
        const std::vector<Box> b = boxes_of(boxes, "boxes");
        const std::vector<glm::vec3> p = vec3s(points, "points");
        const std::vector<int> o = owners_of(owner, p.size(), b.size(), "owner");
        const Overlap ov = overlap_of(overlap);
        const glm::vec3 s = unit(sun, "sun");
        py::array_t<double> out(static_cast<py::ssize_t>(p.size()));
        double* po = out.mutable_data();
        {
          py::gil_scoped_release release;
          const BoxIndex index(b);
          caf_path_lengths(index, p.data(), o.data(), p.size(), s, ov, include_self, po, threads);
        }
        return out;
      },
      py::arg("boxes"), py::arg("points"), py::arg("owner"), py::arg("sun"), py::arg("overlap"),
      py::arg("include_self"), py::arg("threads") = 0,
      "Light path length L through the boxes from each point towards the sun: (N,) float64.");

  m.def(
      "caf_values",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& lengths,
         double max_distance, const std::string& curve) {
        CafCurve c;
        if (curve == "linear")
          c = CafCurve::Linear;
        else if (curve == "exp")
          c = CafCurve::Exp;
        else
          throw py::value_error("curve must be 'linear' or 'exp', got '" + curve + "'");
        if (!(max_distance > 0.0)) throw py::value_error("max_distance must be > 0");
        auto out = new_array({static_cast<py::ssize_t>(lengths.size())});
        for (py::ssize_t i = 0; i < lengths.size(); ++i)
          out.mutable_data()[i] = caf_value(lengths.data()[i], max_distance, c);
        return out;
      },
      py::arg("lengths"), py::arg("max_distance"), py::arg("curve"),
      "CAF of path lengths: clamp(1 − L/D, 0, 1) (linear) or exp(−3L/D); D = inf gives 1.");

  m.def(
      "field_path_lengths",
      [](const py::list& variant_boxes, const py::list& variant_points,
         const py::list& variant_owners, const IntArray& variant, const FloatArray& offsets,
         const FloatArray& yaw, V3 sun, const std::string& overlap, bool include_self,
         bool between_clouds, int threads) {
        const std::size_t nv = variant_boxes.size();
        if (variant_points.size() != nv || variant_owners.size() != nv)
          throw py::value_error("variant boxes, points and owners must have the same length");
        std::vector<BoxIndex> indices;
        std::vector<std::vector<glm::vec3>> pts(nv);
        std::vector<std::vector<int>> own(nv);
        indices.reserve(nv);
        for (std::size_t v = 0; v < nv; ++v) {
          indices.emplace_back(boxes_of(variant_boxes[v].cast<FloatArray>(), "variant boxes"));
          pts[v] = vec3s(variant_points[v].cast<FloatArray>(), "variant points");
          own[v] = owners_of(variant_owners[v].cast<IntArray>(), pts[v].size(),
                             indices.back().size(), "variant owners");
        }
        require_points(offsets, "offsets");
        const auto ni = static_cast<std::size_t>(offsets.shape(0));
        if (variant.ndim() != 1 || static_cast<std::size_t>(variant.shape(0)) != ni ||
            yaw.ndim() != 1 || static_cast<std::size_t>(yaw.shape(0)) != ni)
          throw py::value_error("variant and yaw must have shape (NC,) matching offsets");
        std::vector<Instance> inst(ni);
        const std::vector<glm::vec3> off = vec3s(offsets, "offsets");
        std::size_t total = 0;
        for (std::size_t i = 0; i < ni; ++i) {
          const int v = variant.data()[i];
          if (v < 0 || static_cast<std::size_t>(v) >= nv)
            throw py::value_error("variant ids must index the variants");
          if (!std::isfinite(yaw.data()[i])) throw py::value_error("yaw must be finite");
          inst[i] = Instance{v, off[i], yaw.data()[i]};
          total += pts[static_cast<std::size_t>(v)].size();
        }
        const Overlap ov = overlap_of(overlap);
        const glm::vec3 s = unit(sun, "sun");
        py::array_t<double> out(static_cast<py::ssize_t>(total));
        double* po = out.mutable_data();
        {
          py::gil_scoped_release release;
          field_path_lengths(indices, pts, own, inst, s, ov, include_self, between_clouds, po,
                             threads);
        }
        return out;
      },
      py::arg("variant_boxes"), py::arg("variant_points"), py::arg("variant_owners"),
      py::arg("variant"), py::arg("offsets"), py::arg("yaw"), py::arg("sun"), py::arg("overlap"),
      py::arg("include_self"), py::arg("between_clouds"), py::arg("threads") = 0,
      "Path lengths of every instance's points (instance order, flat), optionally through the "
      "other instances' boxes too.");

  m.def(
      "billboard_shade",
      [](const FloatArray& points, const IntArray& index, const FloatArray& caf,
         const FloatArray& boxes, const FloatArray& light_dirs, const FloatArray& light_radiance,
         const ShadeParams& shade, int threads) {
        const ShadeInputs in = shade_inputs(caf, boxes, light_dirs, light_radiance, shade);
        const std::vector<glm::vec3> p = vec3s(points, "points");
        const std::vector<int> idx = columns_of(index, p.size(), in.q, "index");
        auto out = new_array({static_cast<py::ssize_t>(p.size()), 3});
        float* po = out.mutable_data();
        const float* pc = caf.data();
        {
          py::gil_scoped_release release;
          billboard_shade(p.data(), idx.data(), p.size(), pc, in.q, in.frame, in.lights, in.params,
                          po, threads);
        }
        return out;
      },
      py::arg("points"), py::arg("index"), py::arg("caf"), py::arg("boxes"), py::arg("light_dirs"),
      py::arg("light_radiance"), py::arg("shade"), py::arg("threads") = 0,
      "Colours (N, 3) = k_amb·ambient + H·Σ_ℓ caf[ℓ, index]·D_ℓ·radiance_ℓ at points; the "
      "cloud frame (centre, radius, heights) comes from the boxes.");

  m.def(
      "billboard_vertex_colours",
      [](const FloatArray& centres, const FloatArray& sizes, const FloatArray& rotation,
         const IntArray& index, const FloatArray& caf, const FloatArray& boxes,
         const FloatArray& light_dirs, const FloatArray& light_radiance, const ShadeParams& shade,
         V3 right, V3 up, int threads) {
        const ShadeInputs in = shade_inputs(caf, boxes, light_dirs, light_radiance, shade);
        const std::vector<glm::vec3> c = vec3s(centres, "centres");
        const std::vector<glm::vec2> sz = sizes_of(sizes, rotation, c.size());
        const std::vector<int> idx = columns_of(index, c.size(), in.q, "index");
        const auto n = static_cast<py::ssize_t>(c.size());
        auto out = new_array({n, 4, 3});
        auto corners = new_array({n, 4, 3});
        float *po = out.mutable_data(), *pk = corners.mutable_data();
        const float *pc = caf.data(), *pr = rotation.data();
        {
          py::gil_scoped_release release;
          billboard_vertex_colours(c.data(), sz.data(), pr, idx.data(), c.size(), pc, in.q,
                                   in.frame, in.lights, in.params, v3(right), v3(up), po, pk,
                                   threads);
        }
        return py::make_tuple(out, corners);
      },
      py::arg("centres"), py::arg("sizes"), py::arg("rotation"), py::arg("index"), py::arg("caf"),
      py::arg("boxes"), py::arg("light_dirs"), py::arg("light_radiance"), py::arg("shade"),
      py::arg("right"), py::arg("up"), py::arg("threads") = 0,
      "[TM]'s vertex shading: ((K, 4, 3) colours, (K, 4, 3) corners) of the camera-facing quads.");

  m.def(
      "billboard_corners",
      [](const FloatArray& centres, const FloatArray& sizes, const FloatArray& rotation, V3 right,
         V3 up) {
        const std::vector<glm::vec3> c = vec3s(centres, "centres");
        const std::vector<glm::vec2> sz = sizes_of(sizes, rotation, c.size());
        auto out = new_array({static_cast<py::ssize_t>(c.size()), 4, 3});
        billboard_corners(c.data(), sz.data(), rotation.data(), c.size(), v3(right), v3(up),
                          out.mutable_data());
        return out;
      },
      py::arg("centres"), py::arg("sizes"), py::arg("rotation"), py::arg("right"), py::arg("up"),
      "Camera-facing quad corners (K, 4, 3): v0 bottom-left, v1 bottom-right, v2 top-right, v3 "
      "top-left of the quad turned by each billboard's rotation about the view axis.");

  m.def(
      "yaw_cos_sin",
      [](double degrees) {
        double c, s;
        yaw_cos_sin(degrees, c, s);
        return py::make_tuple(c, s);
      },
      py::arg("degrees"), "(cos, sin) of an angle in degrees, exact at multiples of 90°.");
}

namespace {

template <class T>
T pick(const py::dict& d, const char* key, T fallback) {
  return d.contains(key) ? d[key].cast<T>() : fallback;
}

PhaseKind phase_kind(const std::string& s) {
  if (s == "rayleigh") return PhaseKind::Rayleigh;
  if (s == "isotropic") return PhaseKind::Isotropic;
  if (s == "hg") return PhaseKind::HenyeyGreenstein;
  throw py::value_error("phase must be 'rayleigh', 'isotropic' or 'hg', got '" + s + "'");
}

SplatKernel splat_kernel_kind(const std::string& s) {
  if (s == "gaussian") return SplatKernel::Gaussian;
  if (s == "hermite") return SplatKernel::Hermite;
  throw py::value_error("kernel must be 'gaussian' or 'hermite', got '" + s + "'");
}

// ParticleLightSettings from the dict Python builds out of a SpriteSettings.
ParticleLightSettings light_settings(const py::dict& d) {
  ParticleLightSettings s;
  s.resolution = pick<int>(d, "light_resolution", s.resolution);
  s.solid_angle = pick<float>(d, "solid_angle", s.solid_angle);
  s.phase = phase_kind(pick<std::string>(d, "phase", "rayleigh"));
  s.hg_g = pick<float>(d, "hg_g", s.hg_g);
  s.kernel = splat_kernel_kind(pick<std::string>(d, "kernel", "gaussian"));
  s.peak = pick<float>(d, "peak", s.peak);
  const std::string rb = pick<std::string>(d, "readback", "pixel");
  if (rb == "pixel")
    s.readback = Readback::Pixel;
  else if (rb == "bilinear")
    s.readback = Readback::Bilinear;
  else if (rb == "solid_angle")
    s.readback = Readback::SolidAngle;
  else
    throw py::value_error("readback must be 'pixel', 'bilinear' or 'solid_angle'");
  s.readback_solid_angle = pick<float>(d, "readback_solid_angle", s.readback_solid_angle);
  s.forward = pick<bool>(d, "forward", s.forward);
  s.clamp = pick<bool>(d, "clamp", s.clamp);
  s.quantize = pick<int>(d, "quantize", s.quantize);
  s.allow_gain = pick<bool>(d, "allow_gain", s.allow_gain);
  s.validate();
  return s;
}

std::vector<glm::vec3> unit_directions(const FloatArray& dirs) {
  if (dirs.ndim() != 2 || dirs.shape(1) != 3 || dirs.shape(0) < 1 || dirs.shape(0) > 1024)
    throw py::value_error("light directions must have shape (L, 3) with 1 <= L <= 1024");
  std::vector<glm::vec3> out(static_cast<std::size_t>(dirs.shape(0)));
  for (std::size_t l = 0; l < out.size(); ++l) {
    const glm::vec3 v(dirs.data()[3 * l], dirs.data()[3 * l + 1], dirs.data()[3 * l + 2]);
    const float len = glm::length(v);
    if (!std::isfinite(len) || !(len > 0.0f))
      throw py::value_error("light directions must be finite and non-zero");
    out[l] = glm::normalize(v);
  }
  return out;
}

}  // namespace

// The multiple forward scattering light pass of Harris 2002 (light/particles.hpp).
void bind_particle_light(py::module_& m) {
  m.def(
      "particle_light",
      [](const py::list& clouds, const FloatArray& directions, const py::dict& settings,
         bool return_buffers, int threads) {
        const ParticleLightSettings s = light_settings(settings);
        const std::vector<glm::vec3> suns = unit_directions(directions);
        std::vector<FloatArray> keep;  // the converted arrays stay alive while the core runs
        std::vector<ParticleView> views;
        for (std::size_t c = 0; c < clouds.size(); ++c) {
          const py::tuple t = clouds[c].cast<py::tuple>();
          if (t.size() != 4) throw py::value_error("each cloud is (centres, radii, tau, albedo)");
          for (int i = 0; i < 4; ++i) keep.push_back(t[i].cast<FloatArray>());
          const std::size_t b = keep.size() - 4;
          views.push_back(particle_view(keep[b], keep[b + 1], keep[b + 2], keep[b + 3]));
          try {
            check_energy(views.back(), s);
          } catch (const std::invalid_argument& e) {
            throw py::value_error(e.what());
          }
        }
        const auto lights = static_cast<py::ssize_t>(suns.size());
        const py::ssize_t nl = s.resolution;
        // Sizes before allocating: N·L light values and L·N_L² buffer floats per cloud.
        double values = 0.0;
        for (const ParticleView& v : views) values += static_cast<double>(v.n) * lights;
        if (values > double(py::ssize_t{1} << 28))
          throw py::value_error("particles × lights exceeds 2^28 light values: relight in parts");
        if (return_buffers &&
            static_cast<double>(clouds.size()) * lights * nl * nl > double(py::ssize_t{1} << 31))
          throw py::value_error("return_buffers would allocate more than 2^31 floats");
        py::list result;
        std::vector<float*> light_ptrs, buffer_ptrs;
        std::vector<py::array_t<float>> outs, bufs;
        for (const ParticleView& v : views) {
          outs.push_back(new_array({static_cast<py::ssize_t>(v.n), lights}));
          light_ptrs.push_back(outs.back().mutable_data());
          if (return_buffers) {
            bufs.push_back(new_array({lights, nl, nl}));
            buffer_ptrs.push_back(bufs.back().mutable_data());
          } else {
            buffer_ptrs.push_back(nullptr);
          }
        }
        {
          py::gil_scoped_release release;
          particle_light(views, suns, s, light_ptrs, buffer_ptrs, threads);
        }
        for (std::size_t c = 0; c < views.size(); ++c)
          result.append(py::make_tuple(outs[c], return_buffers ? py::object(bufs[c]) : py::none()));
        return result;
      },
      py::arg("clouds"), py::arg("directions"), py::arg("settings"),
      py::arg("return_buffers") = false, py::arg("threads") = 0,
      "Harris 2002 light pass for clouds × lights: [(light (N, L), buffers (L, N_L, N_L) | "
      "None)].");

  m.def(
      "particle_light_splats",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& tau,
         const FloatArray& albedo, const FloatArray& directions, const py::dict& settings) {
        const ParticleLightSettings s = light_settings(settings);
        const ParticleView v = particle_view(centres, radii, tau, albedo);
        try {
          check_energy(v, s);
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
        const std::vector<glm::vec3> suns = unit_directions(directions);
        const auto lights = static_cast<py::ssize_t>(suns.size());
        const auto n = static_cast<py::ssize_t>(v.n);
        // Per light and processing order: x, y, r_px, forward, alpha (float32), index, patch.
        auto geom = new_array({lights, n, 5});
        py::array_t<std::int32_t> index({lights, n}), patch({lights, n});
        auto frames = new_array({lights, 4, 3});
        float* g = geom.mutable_data();
        std::int32_t* idx = index.mutable_data();
        std::int32_t* pat = patch.mutable_data();
        float* fr = frames.mutable_data();
        float radius = 0.0f;
        for (py::ssize_t l = 0; l < lights; ++l) {
          const LightFrame f = light_frame(v, suns[static_cast<std::size_t>(l)]);
          radius = f.radius;
          const glm::vec3 rows[4] = {f.centre, f.forward, f.right, f.up};
          for (int r = 0; r < 4; ++r)
            for (int a = 0; a < 3; ++a) fr[(l * 4 + r) * 3 + a] = rows[r][a];
          const std::vector<LightSplat> splats = light_splats(v, f, s);
          for (py::ssize_t i = 0; i < n; ++i) {
            const LightSplat& q = splats[static_cast<std::size_t>(i)];
            float* row = g + (l * n + i) * 5;
            row[0] = q.x;
            row[1] = q.y;
            row[2] = q.r_px;
            row[3] = q.forward;
            row[4] = q.alpha;
            idx[l * n + i] = static_cast<std::int32_t>(q.index);
            pat[l * n + i] = q.patch;
          }
        }
        return py::make_tuple(geom, index, patch, frames, radius);
      },
      "The light pass's splats per light in processing order: (geometry (L, N, 5) = x, y, r_px, "
      "forward factor, alpha; index (L, N); patch (L, N); frames (L, 4, 3) = centre, f, r, u; "
      "R_b).");

  m.def(
      "particle_shadow",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& tau,
         const FloatArray& albedo, V3 direction, const FloatArray& buffer,
         const FloatArray& points) {
        const ParticleView v = particle_view(centres, radii, tau, albedo);
        const glm::vec3 d = v3(direction);
        if (!std::isfinite(glm::length(d)) || !(glm::length(d) > 0.0f))
          throw py::value_error("direction must be finite and non-zero");
        if (buffer.ndim() != 2 || buffer.shape(0) != buffer.shape(1) || buffer.shape(0) < 1)
          throw py::value_error("buffer must be a square (N_L, N_L) light buffer");
        require_points(points, "points");
        const LightFrame f = light_frame(v, glm::normalize(d));
        const auto count = static_cast<std::size_t>(points.shape(0));
        std::vector<glm::vec3> pts(count);
        for (std::size_t k = 0; k < count; ++k)
          pts[k] =
              glm::vec3(points.data()[3 * k], points.data()[3 * k + 1], points.data()[3 * k + 2]);
        auto out = new_array({points.shape(0)});
        particle_shadow(f, buffer.data(), static_cast<int>(buffer.shape(0)), pts.data(), count,
                        out.mutable_data());
        return out;
      },
      "Transmittance of the light through a particle cloud at world points (M, 3), from its "
      "final light buffer (the shadow map): (M,) float32, 1 outside the buffer or in front.");

  m.def(
      "splat_kernel",
      [](const std::string& kernel, float peak, const FloatArray& d) {
        const SplatKernel k = splat_kernel_kind(kernel);
        if (!std::isfinite(peak) || !(peak > 0.0f) || peak > 1.0f)
          throw py::value_error("peak must be in (0, 1]");
        auto out = new_array(shape_of(d));
        for (py::ssize_t i = 0; i < d.size(); ++i)
          out.mutable_data()[i] = splat_kernel(k, peak, d.data()[i]);
        return out;
      },
      "The splat kernel K(d) (0 for d >= 1) at distances d in units of the splat radius.");

  m.def(
      "approx_mie_params",
      [](float d) {
        const ApproxMie m = approx_mie_params(d);
        return py::make_tuple(m.g_hg, m.g_d, m.alpha, m.w_d);
      },
      py::arg("diameter"),
      "(g_HG, g_D, alpha, w_D) of the approximate Mie phase for droplets of `diameter` µm.");
  m.def(
      "approx_mie_phase",
      [](float d, const FloatArray& c, float scale) {
        const ApproxMie m = approx_mie_params(d);
        FloatArray out(c.size());
        for (py::ssize_t i = 0; i < c.size(); ++i)
          out.mutable_data()[i] = approx_mie(m, c.data()[i], scale);
        return out;
      },
      py::arg("diameter"), py::arg("cos_theta"), py::arg("scale") = 1.0f,
      "The approximate Mie phase (normalised by 1/4π) at cosines, lobes' g scaled by `scale`.");
  m.def(
      "approx_mie_mean_cosine",
      [](float d) { return approx_mie_mean_cosine(approx_mie_params(d)); }, py::arg("diameter"),
      "The approximate Mie phase's mean cosine.");
  m.def(
      "phase_4pi",
      [](const std::string& phase, float g, const FloatArray& c) {
        const PhaseKind k = phase_kind(phase);
        if (!std::isfinite(g) || !(g > -1.0f) || !(g < 1.0f))
          throw py::value_error("hg_g must be in (-1, 1)");
        auto out = new_array(shape_of(c));
        for (py::ssize_t i = 0; i < c.size(); ++i)
          out.mutable_data()[i] = phase_4pi(k, g, c.data()[i]);
        return out;
      },
      "Harris 2002 phase functions normalised to 4π at cosines c: rayleigh, isotropic or hg.");
}

}  // namespace cumuli::bind

// --- the physical mode's light step (light/physical.hpp) ------------------------------------
namespace cumuli::bind {

namespace {

struct MediumArgs {
  std::vector<CloudShape> shapes;
  std::vector<FloatArray> volumes;  // keeps the arrays alive
  Medium medium;
};

// clouds: [(centres, radii, rotations, model, kappa, phi, scale)], volumes: [(density, lo, hi,
// scale)], noise + fBm for the clouds.
void medium_of(MediumArgs& m, const py::list& clouds, const py::list& volumes, const Noise* noise,
               int octaves, float gain, float lacunarity, float frequency) {
  DensitySource src;
  src.noise = noise;
  src.fbm = FbmParams{octaves, gain, lacunarity, frequency};
  if (!clouds.empty()) {
    if (noise == nullptr) throw py::value_error("noise is required for clouds");
    try {
      src.fbm.validate();
    } catch (const std::invalid_argument& e) {
      throw py::value_error(e.what());
    }
  }
  m.shapes.reserve(clouds.size());
  for (const auto& h : clouds) {
    const py::tuple t = h.cast<py::tuple>();
    if (t.size() != 7 && t.size() != 8)
      throw py::value_error(
          "a cloud is (centres, radii, rotations, model, kappa, phi, scale[, noise_offset])");
    m.shapes.push_back(cloud_from_arrays(t[0].cast<FloatArray>(), t[1].cast<FloatArray>(),
                                         t[2].cast<FloatArray>(), t[3].cast<std::string>(),
                                         t[4].cast<float>(), t[5].cast<float>(),
                                         t.size() == 8 ? noise_offset_arg(t[7]) : glm::vec3(0.0f)));
  }
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    const float scale = clouds[k].cast<py::tuple>()[6].cast<float>();
    if (!(scale >= 0.0f) || !std::isfinite(scale))
      throw py::value_error("extinction scale must be >= 0");
    m.medium.clouds.push_back(CloudMedium{&m.shapes[k], src, scale});
  }
  for (const auto& h : volumes) {
    const py::tuple t = h.cast<py::tuple>();
    if (t.size() != 4) throw py::value_error("a volume is (density, lo, hi, scale)");
    m.volumes.push_back(t[0].cast<FloatArray>());
    const VolumeGrid g = grid_of(m.volumes.back(), 0, t[1].cast<V3>(), t[2].cast<V3>(), "volume");
    const float scale = t[3].cast<float>();
    if (!(scale >= 0.0f) || !std::isfinite(scale)) throw py::value_error("sigma_t must be >= 0");
    m.medium.volumes.push_back(VolumeMedium{m.volumes.back().data(), g, scale});
  }
}

SkyRays sky_rays_of(const std::string& method) {
  if (method == "march") return SkyRays::March;
  if (method == "lattice") return SkyRays::Lattice;
  throw py::value_error("method must be 'lattice' or 'march', got '" + method + "'");
}

SunFrame frame_of(const py::tuple& t) {
  if (t.size() != 6) throw py::value_error("frame must be (u, v, w, lo, hi, res)");
  SunFrame f;
  f.u = v3(t[0].cast<V3>());
  f.v = v3(t[1].cast<V3>());
  f.w = v3(t[2].cast<V3>());
  f.lo = v3(t[3].cast<V3>());
  f.hi = v3(t[4].cast<V3>());
  const auto res = t[5].cast<std::array<int, 3>>();
  for (int a = 0; a < 3; ++a) f.res[a] = res[a];
  try {
    f.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return f;
}

// A frame's per-column map `upstream` ((nv, nu) float32, held in `held`), or nullptr for None.
const float* frame_columns(const py::object& upstream, const SunFrame& f, FloatArray& held) {
  if (upstream.is_none()) return nullptr;
  held = upstream.cast<FloatArray>();
  if (held.ndim() != 2 || held.shape(0) != f.res[1] || held.shape(1) != f.res[0])
    throw py::value_error("upstream must be (nv, nu), one value per column of the frame");
  return held.data();
}

py::tuple frame_tuple(const SunFrame& f) {
  auto vec = [](glm::vec3 a) { return py::make_tuple(a.x, a.y, a.z); };
  return py::make_tuple(vec(f.u), vec(f.v), vec(f.w), vec(f.lo), vec(f.hi),
                        py::make_tuple(f.res[0], f.res[1], f.res[2]));
}

}  // namespace

void bind_physical_light(py::module_& m) {
  m.def(
      "light_frame",
      [](V3 lo, V3 hi, V3 to_sun, std::array<int, 3> res) {
        try {
          return frame_tuple(make_sun_frame(Box{v3(lo), v3(hi)}, v3(to_sun), res.data()));
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
      },
      "The sun's lattice enclosing a box: (u, v, w, lo, hi, res) with w the way light travels.");

  m.def(
      "light_space_depth",
      [](const py::list& clouds, const py::list& volumes, const Noise* noise, int octaves,
         float gain, float lacunarity, float frequency, const py::tuple& frame, float step,
         int threads, double depth_cut) {
        MediumArgs args;
        medium_of(args, clouds, volumes, noise, octaves, gain, lacunarity, frequency);
        const SunFrame f = frame_of(frame);
        if (!(step > 0.0f) || !std::isfinite(step)) throw py::value_error("step must be > 0");
        if (!(depth_cut > 0.0))
          throw py::value_error("depth_cut must be > 0 (inf: march every column to its end)");
        if (static_cast<double>(f.hi.z - f.lo.z) / step > (1 << 22))
          throw py::value_error("step is too small for the frame's depth");
        LargeVector<float> out;
        {
          py::gil_scoped_release release;
          out = light_space_depth(args.medium, f, step, threads, depth_cut);
        }
        return adopt_array(std::move(out), {f.res[2], f.res[1], f.res[0]});
      },
      py::arg("clouds"), py::arg("volumes"), py::arg("noise").none(true), py::arg("octaves"),
      py::arg("gain"), py::arg("lacunarity"), py::arg("frequency"), py::arg("frame"),
      py::arg("step"), py::arg("threads") = 0, py::arg("depth_cut") = INFINITY,
      "Optical depth from the sun-side face of a light frame to each node: (nw, nv, nu). Each\n"
      "drawable's march along a column ends after the segment where its depth exceeds depth_cut:\n"
      "nodes before keep their exact depth, nodes after hold a depth above the cut.");

  m.def(
      "medium_optical_depth",
      [](const py::list& clouds, const py::list& volumes, const Noise* noise, int octaves,
         float gain, float lacunarity, float frequency, const FloatArray& points, V3 direction,
         float step, int threads) {
        MediumArgs args;
        medium_of(args, clouds, volumes, noise, octaves, gain, lacunarity, frequency);
        require_points(points, "points");
        glm::vec3 d = v3(direction);
        if (!(glm::length(d) > 0.0f)) throw py::value_error("direction must be non-zero");
        d = glm::normalize(d);
        if (!(step > 0.0f) || !std::isfinite(step)) throw py::value_error("step must be > 0");
        const std::size_t n = static_cast<std::size_t>(points.shape(0));
        auto out = new_array({static_cast<py::ssize_t>(n)});
        const float* p = points.data();
        float* o = out.mutable_data();
        {
          py::gil_scoped_release release;
          parallel_for(n, threads, [&](std::size_t i) {
            o[i] =
                args.medium.optical_depth(glm::vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]), d, step);
          });
        }
        return out;
      },
      py::arg("clouds"), py::arg("volumes"), py::arg("noise").none(true), py::arg("octaves"),
      py::arg("gain"), py::arg("lacunarity"), py::arg("frequency"), py::arg("points"),
      py::arg("direction"), py::arg("step"), py::arg("threads") = 0,
      "Optical depth of every cloud and volume along points + t·direction, t >= 0: (N,).");

  m.def(
      "sample_frame",
      [](const FloatArray& values, const py::tuple& frame, const FloatArray& points, int threads,
         const py::object& upstream) {
        const SunFrame f = frame_of(frame);
        if (values.ndim() != 3 || values.shape(0) != f.res[2] || values.shape(1) != f.res[1] ||
            values.shape(2) != f.res[0])
          throw py::value_error("values must have the frame's shape (nw, nv, nu)");
        require_points(points, "points");
        FloatArray held;
        const float* columns = frame_columns(upstream, f, held);
        const py::ssize_t n = points.shape(0);
        auto out = new_array({n});
        float* o = out.mutable_data();
        const float *v = values.data(), *pts = points.data();
        {
          py::gil_scoped_release release;
          parallel_for(static_cast<std::size_t>(n), threads, [&](std::size_t i) {
            const float* p = pts + 3 * i;
            o[i] = sample_frame(v, f, glm::vec3(p[0], p[1], p[2]), columns);
          });
        }
        return out;
      },
      py::arg("values"), py::arg("frame"), py::arg("points"), py::arg("threads") = 0,
      py::arg("upstream") = py::none(),
      "Trilinear values of a light-frame lattice at (N, 3) world points, plus the bilinear value "
      "of `upstream`, a (nv, nu) map of one value per column, where given.");

  m.def(
      "lattice_transmittance",
      [](const FloatArray& depth, const py::tuple& frame, V3 lo, V3 cell,
         const std::array<int, 3>& dims, int threads, const py::object& upstream, float depth_scale,
         float carried, float carried_rate) {
        const SunFrame f = frame_of(frame);
        if (!(depth_scale >= 0.0f) || !std::isfinite(depth_scale))
          throw py::value_error("depth_scale must be finite and >= 0");
        if (!(carried >= 0.0f && carried <= 1.0f))
          throw py::value_error("carried must be in [0, 1]");
        if (!(carried_rate > 0.0f) || !std::isfinite(carried_rate))
          throw py::value_error("carried_rate must be finite and > 0");
        if (depth.ndim() != 3 || depth.shape(0) != f.res[2] || depth.shape(1) != f.res[1] ||
            depth.shape(2) != f.res[0])
          throw py::value_error("depth must have the frame's shape (nw, nv, nu)");
        for (int a = 0; a < 3; ++a) {
          if (dims[a] < 1 || dims[a] > 4096)
            throw py::value_error("dims must be three lattice sizes in [1, 4096]");
          if (!std::isfinite(lo[a]) || !(cell[a] > 0.0f) || !std::isfinite(cell[a]))
            throw py::value_error("lo must be finite and cell finite and > 0");
        }
        FloatArray held;
        const float* columns = frame_columns(upstream, f, held);
        const float* v = depth.data();
        LargeVector<float> out;
        {
          py::gil_scoped_release release;
          out = lattice_transmittance(v, f, v3(lo), v3(cell), dims.data(), threads, columns,
                                      depth_scale, CarriedSource{carried, carried_rate});
        }
        return adopt_array(std::move(out), {dims[2], dims[1], dims[0]});
      },
      py::arg("depth"), py::arg("frame"), py::arg("lo"), py::arg("cell"), py::arg("dims"),
      py::arg("threads") = 0, py::arg("upstream") = py::none(), py::arg("depth_scale") = 1.0f,
      py::arg("carried") = 0.0f, py::arg("carried_rate") = 1.0f,
      "e^-(depth_scale*tau) of a light-frame lattice of optical depths tau (plus `upstream`, a "
      "(nv, nu) map of one depth per column, where given) at the centres of a (W, H, D) lattice "
      "(lo + (index + 1/2)*cell per axis, float32), shape (D, H, W): the sun's transmittance "
      "on a drawable's world lattice. `carried` m > 0: the diffusion's sun source with a share m "
      "of the collided light carried on along the light, turning diffuse at the rate "
      "`carried_rate` a: (1 - m)*e^(-k*tau) + m*a/(a - k)*(e^(-k*tau) - e^(-a*tau)), "
      "k = depth_scale.");

  m.def(
      "sky_irradiance",
      [](const FloatArray& ext, V3 lo, V3 hi, const FloatArray& sky_coeffs, int order, int n_theta,
         float step, int threads, const std::string& method) {
        const VolumeGrid g = grid_of(ext, 0, lo, hi, "extinction");
        const SkyRays how = sky_rays_of(method);
        if (order < 1 || order > kMaxShOrder) throw py::value_error("sh_order must be in [1, 4]");
        if (n_theta < 1 || n_theta > 64) throw py::value_error("sh_samples must be in [1, 64]");
        if (sky_coeffs.size() != 3 * order * order)
          throw py::value_error("sky_coeffs must hold 3·order² values");
        if (!(step > 0.0f) || !std::isfinite(step)) throw py::value_error("step must be > 0");
        const float *e = ext.data(), *s = sky_coeffs.data();
        LargeVector<float> out;
        {
          py::gil_scoped_release release;
          out = sky_irradiance(e, g, s, order, n_theta, step, threads, how);
        }
        return adopt_array(std::move(out), {g.d, g.h, g.w, 3});
      },
      py::arg("extinction"), py::arg("lo"), py::arg("hi"), py::arg("sky_coeffs"), py::arg("order"),
      py::arg("n_theta"), py::arg("step"), py::arg("threads") = 0, py::arg("method") = "march",
      "Sky irradiance reaching each voxel unscattered (SH visibility × sky SH): (D, H, W, 3); "
      "method 'march' (a ray per voxel and product-quadrature direction, n_theta polar nodes, "
      "steps of `step` voxels) or 'lattice' (the 26 neighbour directions, τ exact by a "
      "recurrence over the lattice; voxels within 10 % of cubes, else 'march').");

  m.def(
      "sky_visibility",
      [](const FloatArray& ext, V3 lo, V3 hi, int order, int n_theta, float step, int threads,
         const std::string& method) {
        const VolumeGrid g = grid_of(ext, 0, lo, hi, "extinction");
        const SkyRays how = sky_rays_of(method);
        if (order < 1 || order > kMaxShOrder) throw py::value_error("sh_order must be in [1, 4]");
        if (n_theta < 1 || n_theta > 64) throw py::value_error("sh_samples must be in [1, 64]");
        if (!(step > 0.0f) || !std::isfinite(step)) throw py::value_error("step must be > 0");
        const float* e = ext.data();
        LargeVector<float> vis;
        {
          py::gil_scoped_release release;
          vis = sky_visibility(e, g, order, n_theta, step, threads, how);
        }
        return adopt_array(
            std::move(vis),
            {static_cast<py::ssize_t>(g.d), static_cast<py::ssize_t>(g.h),
             static_cast<py::ssize_t>(g.w), static_cast<py::ssize_t>(order * order)});
      },
      py::arg("extinction"), py::arg("lo"), py::arg("hi"), py::arg("order"), py::arg("n_theta"),
      py::arg("step"), py::arg("threads") = 0, py::arg("method") = "march",
      "The sky visibility's SH moments per voxel, (D, H, W, order²) float32 (each summed in "
      "double): sky_irradiance "
      "without the sky (sky_irradiance_from projects a sky onto them).");

  m.def(
      "physical_grid",
      [](const FloatArray& ext, const py::object& phi, const py::object& sky_e, double cell,
         double gain_depth, double sun_gain, double sky_gain, int threads) {
        if (ext.ndim() != 3) throw py::value_error("extinction must be a (D, H, W) array");
        const std::size_t voxels = static_cast<std::size_t>(ext.size());
        const auto lattice = [&](const py::object& a, const char* name, FloatArray& held,
                                 std::initializer_list<py::ssize_t> last) -> const float* {
          if (a.is_none()) return nullptr;
          held = a.cast<FloatArray>();
          bool ok = held.ndim() == 4;
          for (int k = 0; ok && k < 3; ++k) ok = held.shape(k) == ext.shape(k);
          if (ok) ok = std::find(last.begin(), last.end(), held.shape(3)) != last.end();
          if (!ok)
            throw py::value_error(
                std::string(name) +
                " must be a (D, H, W, channels) array on the extinction's lattice");
          return held.data();
        };
        FloatArray phi_a, sky_a;
        const float* f = lattice(phi, "phi", phi_a, {1, 4});
        const float* s = lattice(sky_e, "sky_e", sky_a, {3});
        const int channels = f != nullptr ? static_cast<int>(phi_a.shape(3)) : 0;
        if (f != nullptr && s != nullptr && channels != 4)
          throw py::value_error("with sky_e, phi must hold the sun's and the sky's 4 channels");
        for (const double g : {sun_gain, sky_gain})
          if (!(g > 0.0) || !std::isfinite(g))
            throw py::value_error("gains must be finite and > 0");
        if (!(gain_depth >= 0.0) || !std::isfinite(gain_depth))
          throw py::value_error("gain_depth must be finite and >= 0");
        if (!(cell > 0.0) || !std::isfinite(cell))
          throw py::value_error("cell must be finite and > 0");
        const float* e = ext.data();
        LargeVector<float> out;
        {
          py::gil_scoped_release release;
          out = physical_grid(e, voxels, f, channels, s, cell, gain_depth, sun_gain, sky_gain,
                              threads);
        }
        return adopt_array(std::move(out), {ext.shape(0), ext.shape(1), ext.shape(2), 4});
      },
      py::arg("extinction"), py::arg("phi"), py::arg("sky_e"), py::arg("cell"),
      py::arg("gain_depth"), py::arg("sun_gain"), py::arg("sky_gain"), py::arg("threads") = 0,
      "A drawable's physical light lattice (D, H, W, 4), float32: A = G_sun*phi_sun, RGB = "
      "G_sky*(sky_e + phi_sky) (sky_e alone without phi), G = 1 + (G_inf - 1)*(1 - "
      "exp(-max(extinction, 0)*cell/gain_depth)) (G_inf where gain_depth is 0).");

  m.def(
      "sky_irradiance_from",
      [](const FloatArray& visibility, const FloatArray& sky_coeffs, int threads) {
        if (visibility.ndim() != 4)
          throw py::value_error("visibility must be a (D, H, W, order²) array");
        const py::ssize_t nc = visibility.shape(3);
        int order = 0;
        for (int o = 1; o <= kMaxShOrder; ++o)
          if (o * o == nc) order = o;
        if (order == 0)
          throw py::value_error("visibility's last axis must be order² (1, 4, 9, 16)");
        if (sky_coeffs.size() != 3 * nc)
          throw py::value_error("sky_coeffs must hold 3·order² values");
        const std::size_t voxels = static_cast<std::size_t>(visibility.size() / nc);
        const float* v = visibility.data();
        const float* s = sky_coeffs.data();
        LargeVector<float> out;
        {
          py::gil_scoped_release release;
          out = sky_irradiance_from(v, voxels, s, order, threads);
        }
        return adopt_array(std::move(out),
                           {visibility.shape(0), visibility.shape(1), visibility.shape(2), 3});
      },
      py::arg("visibility"), py::arg("sky_coeffs"), py::arg("threads") = 0,
      "Sky irradiance (D, H, W, 3) from sky_visibility's moments and a sky's SH coefficients: "
      "the same values sky_irradiance gives.");

  m.def(
      "diffusion_light",
      [](const FloatArray& ext, V3 lo, V3 hi, const FloatArray& sun_t, V3 to_sun,
         const py::object& sky_e, float albedo, float mean_cosine, float tolerance, int threads,
         float forward, const std::string& solver) {
        const VolumeGrid g = grid_of(ext, 0, lo, hi, "extinction");
        if (sun_t.size() != static_cast<py::ssize_t>(g.voxels()))
          throw py::value_error("sun_t must have the extinction's shape");
        FloatArray sky;  // (a default FloatArray is an empty array, not a null handle)
        const bool has_sky = !sky_e.is_none();
        if (has_sky) {
          sky = sky_e.cast<FloatArray>();
          if (sky.size() != static_cast<py::ssize_t>(g.voxels()) * 3)
            throw py::value_error("sky_e must have shape (D, H, W, 3)");
        }
        if (!(albedo >= 0.0f && albedo <= 1.0f)) throw py::value_error("albedo must be in [0, 1]");
        if (!(mean_cosine > -1.0f && mean_cosine < 1.0f))
          throw py::value_error("mean_cosine must be in (-1, 1)");
        if (!(forward >= 0.0f && forward <= 4.0f))
          throw py::value_error("forward must be in [0, 4]");
        if (!(tolerance > 0.0f && tolerance < 1.0f))
          throw py::value_error("tolerance must be in (0, 1)");
        if (solver != "mic" && solver != "jacobi")
          throw py::value_error("solver must be 'mic' or 'jacobi', got '" + solver + "'");
        const DiffusionSolver kind =
            solver == "mic" ? DiffusionSolver::mic : DiffusionSolver::jacobi;
        DiffusionParams p;
        p.albedo = albedo;
        p.mean_cosine = mean_cosine;
        p.tolerance = tolerance;
        p.solver = kind;
        const int channels = has_sky ? 4 : 1;
        const float *e = ext.data(), *st = sun_t.data(), *se = has_sky ? sky.data() : nullptr;
        LargeVector<float> out;
        {
          py::gil_scoped_release release;
          LargeVector<float> q = diffusion_sources(e, g, st, v3(to_sun), se, albedo, threads);
          add_sun_flux_source(q, channels, e, g, st, v3(to_sun), albedo, mean_cosine, forward);
          out = diffusion_fluence(e, g, q.data(), channels, p, threads);
        }
        return adopt_array(std::move(out), {g.d, g.h, g.w, channels});
      },
      py::arg("extinction"), py::arg("lo"), py::arg("hi"), py::arg("sun_t"), py::arg("to_sun"),
      py::arg("sky_e").none(true), py::arg("albedo"), py::arg("mean_cosine"),
      py::arg("tolerance") = 1e-5f, py::arg("threads") = 0, py::arg("forward") = 0.0f,
      py::arg("solver") = "mic",
      "Collided fluence of the diffusion approximation: (D, H, W, 1 | 4) (sun per unit "
      "irradiance, then the sky's RGB); forward: the weight of the forward-scattered sun's "
      "flux source (0: an isotropic source); solver: the conjugate gradients' preconditioner, "
      "'mic' (modified incomplete Cholesky over the medium cells) or 'jacobi' (the diagonal, "
      "over the whole lattice).");
  m.def(
      "diffusion_anisotropy",
      [](const FloatArray& ext, V3 lo, V3 hi, const FloatArray& phi, float albedo,
         float mean_cosine, int threads, const py::object& sun_t, V3 to_sun, float forward) {
        const VolumeGrid g = grid_of(ext, 0, lo, hi, "extinction");
        if (phi.ndim() != 4 || phi.shape(0) != g.d || phi.shape(1) != g.h || phi.shape(2) != g.w ||
            phi.shape(3) < 1 || phi.shape(3) > 8)
          throw py::value_error("phi must have shape (D, H, W, C) over the extinction's lattice");
        if (!(albedo >= 0.0f && albedo <= 1.0f)) throw py::value_error("albedo must be in [0, 1]");
        if (!(mean_cosine > -1.0f && mean_cosine < 1.0f))
          throw py::value_error("mean_cosine must be in (-1, 1)");
        DiffusionParams p;
        p.albedo = albedo;
        p.mean_cosine = mean_cosine;
        const int channels = static_cast<int>(phi.shape(3));
        FloatArray sun;  // (a default FloatArray is an empty array, not a null handle)
        const bool has_sun = !sun_t.is_none();
        if (has_sun) {
          sun = sun_t.cast<FloatArray>();
          if (sun.size() != static_cast<py::ssize_t>(g.voxels()))
            throw py::value_error("sun_t must have the extinction's shape");
        }
        if (!(forward >= 0.0f && forward <= 4.0f))
          throw py::value_error("forward must be in [0, 4]");
        const glm::vec3 sd = v3(to_sun);
        if (has_sun && forward != 0.0f &&
            !(glm::length(sd) > 0.0f && std::isfinite(sd.x) && std::isfinite(sd.y) &&
              std::isfinite(sd.z)))
          throw py::value_error("to_sun must be a finite, non-zero vector");
        LargeVector<float> out;
        {
          py::gil_scoped_release release;
          out = diffusion_anisotropy(ext.data(), g, phi.data(), channels, p, threads,
                                     has_sun ? sun.data() : nullptr, sd, forward);
        }
        return adopt_array(std::move(out), {g.d, g.h, g.w, 3});
      },
      py::arg("extinction"), py::arg("lo"), py::arg("hi"), py::arg("phi"), py::arg("albedo"),
      py::arg("mean_cosine"), py::arg("threads") = 0, py::arg("sun_t").none(true) = py::none(),
      py::arg("to_sun") = V3{0.0f, 1.0f, 0.0f}, py::arg("forward") = 0.0f,
      "The anisotropy r = 3E/phi of channel 0 of a diffusion solution phi (D, H, W, C): "
      "(D, H, W, 3), E = -D grad phi the diffuse flux (Marshak's leak at the medium's faces), "
      "plus forward*3D*Q1, the forward-scattered flux of diffusion_light's sun source (with "
      "sun_t, the same sun_t, to_sun and forward as that call); |r| <= 3; the empty cells next "
      "to the medium hold their medium neighbours' mean.");
}

}  // namespace cumuli::bind
