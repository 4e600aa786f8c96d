// Bindings for the endless-animation core (animation.hpp), volume light (volume_light.hpp) and
// the CPU volume marcher (volume_march.hpp). Shapes are checked here before anything is
// allocated; long loops release the GIL.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "common.hpp"
#include "cumuli/animation.hpp"
#include "cumuli/noise.hpp"
#include "cumuli/volume_light.hpp"
#include "cumuli/volume_march.hpp"

namespace cumuli::bind {

namespace {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using V3 = std::array<float, 3>;

glm::vec3 v3(const V3& a) { return glm::vec3(a[0], a[1], a[2]); }

std::vector<py::ssize_t> shape_of(const py::array& a) {
  return std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim());
}

// (N, D, H, W) volumes → their grid.
VolumeGrid grid_of(const FloatArray& vols, int lead, const V3& lo, const V3& hi, const char* name,
                   int trailing = 0) {
  if (vols.ndim() != lead + 3 + trailing)
    throw py::value_error(std::string(name) + " has the wrong number of dimensions");
  VolumeGrid g;
  g.d = static_cast<int>(vols.shape(lead));
  g.h = static_cast<int>(vols.shape(lead + 1));
  g.w = static_cast<int>(vols.shape(lead + 2));
  g.box = Box{v3(lo), v3(hi)};
  try {
    g.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(std::string(name) + ": " + e.what());
  }
  return g;
}

py::array_t<float> to_array(const std::vector<float>& v, const std::vector<py::ssize_t>& shape) {
  auto out = new_array(shape);
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

py::array_t<double> to_array_d(const std::vector<double>& v, py::ssize_t n) {
  py::array_t<double> out({n, n});
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

EvolutionParams evolution(int frames, std::array<int, 3> res, float growth, V3 drift, float jitter,
                          V3 wind, float density_scale, float padding, std::uint64_t seed) {
  EvolutionParams p;
  p.frames = frames;
  p.res_x = res[0];
  p.res_y = res[1];
  p.res_z = res[2];
  p.growth = growth;
  p.drift = v3(drift);
  p.jitter = jitter;
  p.wind = v3(wind);
  p.density_scale = density_scale;
  p.padding = padding;
  p.seed = seed;
  return p;
}

SkyParams sky_of(const py::tuple& t) {
  if (t.size() != 6) throw py::value_error("sky must be (zenith, horizon, ground, exponent, disc radius, disc intensity)");
  SkyParams s;
  s.zenith = v3(t[0].cast<V3>());
  s.horizon = v3(t[1].cast<V3>());
  s.ground = v3(t[2].cast<V3>());
  s.exponent = t[3].cast<float>();
  s.sun_disc_radius = t[4].cast<float>();
  s.sun_disc_intensity = t[5].cast<float>();
  return s;
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

void bind_animation(py::module_& m) {
  m.def(
      "evolving_cloud_box",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& rotations,
         const std::string& model, float kappa, float phi, int frames, std::array<int, 3> res,
         float growth, V3 drift, float jitter, V3 wind, float density_scale, float padding,
         std::uint64_t seed) {
        const CloudShape cloud = cloud_from_arrays(centres, radii, rotations, model, kappa, phi);
        const Box b = evolving_cloud_box(
            cloud, evolution(frames, res, growth, drift, jitter, wind, density_scale, padding, seed));
        return py::make_tuple(V3{b.lo.x, b.lo.y, b.lo.z}, V3{b.hi.x, b.hi.y, b.hi.z});
      },
      "World box holding the evolving cloud at every frame (padded): ((x,y,z) lo, (x,y,z) hi).");

  m.def(
      "evolving_cloud_volumes",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& rotations,
         const std::string& model, float kappa, float phi, const Noise* noise, float constant,
         int octaves, float gain, float lacunarity, float frequency, int frames,
         std::array<int, 3> res, float growth, V3 drift, float jitter, V3 wind,
         float density_scale, float padding, std::uint64_t seed, V3 box_lo, V3 box_hi,
         int threads) {
        const CloudShape cloud = cloud_from_arrays(centres, radii, rotations, model, kappa, phi);
        DensitySource src;
        src.noise = noise;
        src.fbm = FbmParams{octaves, gain, lacunarity, frequency};
        src.fbm.validate();
        src.constant = constant;
        if (constant < 0.0f && noise == nullptr)
          throw py::value_error("give a noise or a constant density >= 0");
        const EvolutionParams p =
            evolution(frames, res, growth, drift, jitter, wind, density_scale, padding, seed);
        std::vector<float> v;
        {
          py::gil_scoped_release release;
          v = evolving_cloud_volumes(cloud, src, p, Box{v3(box_lo), v3(box_hi)}, threads);
        }
        return to_array(v, {frames, res[2], res[1], res[0]});
      },
      "Voxelise an evolving cloud: (frames, D, H, W) float32 densities.");

  m.def(
      "similarity_matrix",
      [](const FloatArray& vols, int threads) {
        if (vols.ndim() < 2) throw py::value_error("volumes must have shape (N, ...)");
        const int n = static_cast<int>(vols.shape(0));
        if (n < 1) throw py::value_error("volumes must hold at least one volume");
        const std::size_t voxels = static_cast<std::size_t>(vols.size()) / n;
        py::array_t<double> out({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(n)});
        double* o = out.mutable_data();
        const float* v = vols.data();
        {
          py::gil_scoped_release release;
          similarity_matrix(v, n, voxels, o, threads);
        }
        return out;
      },
      py::arg("volumes"), py::arg("threads") = 0,
      "D_kl = Σ (ρ_k − ρ_l)² for all pairs: (N, N) float64.");

  m.def(
      "transition_matrix",
      [](const DoubleArray& d, double sigma) {
        if (d.ndim() != 2 || d.shape(0) != d.shape(1) || d.shape(0) < 1)
          throw py::value_error("similarity must be a non-empty square (N, N) matrix");
        const int n = static_cast<int>(d.shape(0));
        return to_array_d(transition_matrix(d.data(), n, sigma), n);
      },
      py::arg("similarity"), py::arg("sigma"),
      "The paper's P_kl ∝ exp(−D_{k+1,l}/σ) (last row: exp(−D_{N−1,l−1}/σ)), rows summing to 1.");

  m.def("crossfade_weight", &crossfade_weight, py::arg("step"), py::arg("frames"));

  py::class_<EndlessWalk>(m, "EndlessWalk")
      .def(py::init([](const DoubleArray& d, double sigma, int crossfade, std::uint64_t seed,
                       int start) {
             if (d.ndim() != 2 || d.shape(0) != d.shape(1) || d.shape(0) < 1)
               throw py::value_error("similarity must be a non-empty square (N, N) matrix");
             return EndlessWalk(d.data(), static_cast<int>(d.shape(0)), sigma, crossfade, seed,
                                start);
           }),
           py::arg("similarity"), py::arg("sigma"), py::arg("crossfade"), py::arg("seed"),
           py::arg("start"))
      .def("next",
           [](EndlessWalk& w) {
             const AnimationFrame f = w.next();
             return py::make_tuple(f.source, f.target, f.weight, f.crossfade);
           })
      .def_property_readonly("current", &EndlessWalk::current)
      .def_property_readonly("matrix",
                             [](const EndlessWalk& w) { return to_array_d(w.matrix(), w.size()); })
      .def_property_readonly("live", [](const EndlessWalk& w) {
        py::array_t<bool> out(w.size());
        for (int i = 0; i < w.size(); ++i) out.mutable_data()[i] = w.live()[i] != 0;
        return out;
      });

  m.def(
      "blend_volumes",
      [](const FloatArray& a, const FloatArray& b, float w, int threads) {
        if (shape_of(a) != shape_of(b)) throw py::value_error("the two volumes must have the same shape");
        auto out = new_array(shape_of(a));
        const float* pa = a.data();
        const float* pb = b.data();
        float* po = out.mutable_data();
        const std::size_t n = static_cast<std::size_t>(a.size());
        {
          py::gil_scoped_release release;
          blend_volumes(pa, pb, w, po, n, threads);
        }
        return out;
      },
      py::arg("a"), py::arg("b"), py::arg("w"), py::arg("threads") = 0, "w·a + (1 − w)·b.");

  m.def(
      "sun_optical_depth",
      [](const FloatArray& vols, V3 lo, V3 hi, V3 to_sun, float step, int threads) {
        const VolumeGrid g = grid_of(vols, 1, lo, hi, "volumes");
        const int n = static_cast<int>(vols.shape(0));
        const float* v = vols.data();
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = sun_optical_depth(v, n, g, v3(to_sun), step, threads);
        }
        return to_array(out, shape_of(vols));
      },
      "Optical depth towards the sun per voxel: (N, D, H, W).");

  m.def(
      "sh_optical_depth",
      [](const FloatArray& vols, V3 lo, V3 hi, int order, int n_theta, float step, int threads) {
        const VolumeGrid g = grid_of(vols, 1, lo, hi, "volumes");
        const int n = static_cast<int>(vols.shape(0));
        const float* v = vols.data();
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = sh_optical_depth(v, n, g, order, n_theta, step, threads);
        }
        auto shape = shape_of(vols);
        shape.push_back(order * order);
        return to_array(out, shape);
      },
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
      "render_volume_cpu",
      [](const FloatArray& density, const FloatArray& light, V3 lo, V3 hi, V3 position, V3 forward,
         V3 right, V3 up, float tan_half_fov, int width, int height, V3 sun_dir, V3 sun_radiance,
         const py::tuple& sky, float sigma_t, float albedo, float g, float step, int threads) {
        const VolumeGrid grid = grid_of(density, 0, lo, hi, "volume");
        const VolumeGrid lg = grid_of(light, 0, lo, hi, "light", 1);
        if (lg.w != grid.w || lg.h != grid.h || lg.d != grid.d || light.shape(3) != 4)
          throw py::value_error("light must have shape (D, H, W, 4) matching the volume");
        VolumeCameraRays cam{v3(position), v3(forward), v3(right), v3(up), tan_half_fov};
        VolumeRenderParams p;
        p.width = width;
        p.height = height;
        p.sun.direction = v3(sun_dir);
        p.sun.radiance = v3(sun_radiance);
        p.sky = sky_of(sky);
        p.sigma_t = sigma_t;
        p.albedo = albedo;
        p.g = g;
        p.step = step;
        const float *pd = density.data(), *pl = light.data();
        std::vector<float> img;
        {
          py::gil_scoped_release release;
          img = render_volume_cpu(pd, pl, grid, cam, p, threads);
        }
        return to_array(img, {height, width, 4});
      },
      "CPU emission–absorption march of a lit density volume: (H, W, 4) float32, row 0 on top.");

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
      [](const FloatArray& vols, V3 lo, V3 hi, const FloatArray& points, float step, int threads) {
        const VolumeGrid g = grid_of(vols, 1, lo, hi, "volumes");
        require_points(points, "points");
        std::vector<glm::vec3> pts(static_cast<std::size_t>(points.shape(0)));
        for (std::size_t i = 0; i < pts.size(); ++i)
          pts[i] = glm::vec3(points.data()[3 * i], points.data()[3 * i + 1], points.data()[3 * i + 2]);
        const int n = static_cast<int>(vols.shape(0));
        const float* v = vols.data();
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = point_optical_depth(v, n, g, pts, step, threads);
        }
        auto shape = shape_of(vols);
        shape.push_back(static_cast<py::ssize_t>(pts.size()));
        return to_array(out, shape);
      },
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
