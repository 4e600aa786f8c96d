// Bindings of the light stage (python/cumuli/light): the NDT light-grid precompute (light/ndt.hpp,
// Algorithm 2, eqs. 3–7) and the endless animation's volume light (light/volume_light.hpp: sun
// and sky optical depths, SH exponential, multiple scattering). Long loops release the GIL.
#include "cumuli/light/ndt.hpp"

#include <array>
#include <stdexcept>
#include <string>

#include <pybind11/stl.h>

#include "common.hpp"
#include "cumuli/light/physical.hpp"
#include "cumuli/light/volume_light.hpp"
#include "cumuli/parallel.hpp"

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

namespace {

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
    if (t.size() != 7) throw py::value_error("a cloud is (centres, radii, rotations, model, kappa, phi, scale)");
    m.shapes.push_back(cloud_from_arrays(t[0].cast<FloatArray>(), t[1].cast<FloatArray>(),
                                         t[2].cast<FloatArray>(), t[3].cast<std::string>(),
                                         t[4].cast<float>(), t[5].cast<float>()));
  }
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    const float scale = clouds[k].cast<py::tuple>()[6].cast<float>();
    if (!(scale >= 0.0f) || !std::isfinite(scale)) throw py::value_error("extinction scale must be >= 0");
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

LightFrame frame_of(const py::tuple& t) {
  if (t.size() != 6) throw py::value_error("frame must be (u, v, w, lo, hi, res)");
  LightFrame f;
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

py::tuple frame_tuple(const LightFrame& f) {
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
          return frame_tuple(make_light_frame(Box{v3(lo), v3(hi)}, v3(to_sun), res.data()));
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
      },
      "The sun's lattice enclosing a box: (u, v, w, lo, hi, res) with w the way light travels.");

  m.def(
      "light_space_depth",
      [](const py::list& clouds, const py::list& volumes, const Noise* noise, int octaves,
         float gain, float lacunarity, float frequency, const py::tuple& frame, float step,
         int threads) {
        MediumArgs args;
        medium_of(args, clouds, volumes, noise, octaves, gain, lacunarity, frequency);
        const LightFrame f = frame_of(frame);
        if (!(step > 0.0f) || !std::isfinite(step)) throw py::value_error("step must be > 0");
        if (static_cast<double>(f.hi.z - f.lo.z) / step > (1 << 22))
          throw py::value_error("step is too small for the frame's depth");
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = light_space_depth(args.medium, f, step, threads);
        }
        return to_array(out, {f.res[2], f.res[1], f.res[0]});
      },
      py::arg("clouds"), py::arg("volumes"), py::arg("noise").none(true), py::arg("octaves"),
      py::arg("gain"), py::arg("lacunarity"), py::arg("frequency"), py::arg("frame"),
      py::arg("step"), py::arg("threads") = 0,
      "Optical depth from the sun-side face of a light frame to each node: (nw, nv, nu).");

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
            o[i] = args.medium.optical_depth(glm::vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]), d, step);
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
      [](const FloatArray& values, const py::tuple& frame, const FloatArray& points) {
        const LightFrame f = frame_of(frame);
        if (values.ndim() != 3 || values.shape(0) != f.res[2] || values.shape(1) != f.res[1] ||
            values.shape(2) != f.res[0])
          throw py::value_error("values must have the frame's shape (nw, nv, nu)");
        require_points(points, "points");
        const py::ssize_t n = points.shape(0);
        auto out = new_array({n});
        for (py::ssize_t i = 0; i < n; ++i) {
          const float* p = points.data() + 3 * i;
          out.mutable_data()[i] = sample_frame(values.data(), f, glm::vec3(p[0], p[1], p[2]));
        }
        return out;
      },
      "Trilinear values of a light-frame lattice at (N, 3) world points.");

  m.def(
      "sky_irradiance",
      [](const FloatArray& ext, V3 lo, V3 hi, const FloatArray& sky_coeffs, int order,
         int n_theta, float step, int threads) {
        const VolumeGrid g = grid_of(ext, 0, lo, hi, "extinction");
        if (order < 1 || order > kMaxShOrder) throw py::value_error("sh_order must be in [1, 4]");
        if (n_theta < 1 || n_theta > 64) throw py::value_error("sh_samples must be in [1, 64]");
        if (sky_coeffs.size() != 3 * order * order)
          throw py::value_error("sky_coeffs must hold 3·order² values");
        if (!(step > 0.0f) || !std::isfinite(step)) throw py::value_error("step must be > 0");
        const float *e = ext.data(), *s = sky_coeffs.data();
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = sky_irradiance(e, g, s, order, n_theta, step, threads);
        }
        return to_array(out, {g.d, g.h, g.w, 3});
      },
      py::arg("extinction"), py::arg("lo"), py::arg("hi"), py::arg("sky_coeffs"),
      py::arg("order"), py::arg("n_theta"), py::arg("step"), py::arg("threads") = 0,
      "Sky irradiance reaching each voxel unscattered (SH visibility × sky SH): (D, H, W, 3).");

  m.def(
      "diffusion_light",
      [](const FloatArray& ext, V3 lo, V3 hi, const FloatArray& sun_t, V3 to_sun,
         const py::object& sky_e, float albedo, float mean_cosine, int max_iterations,
         float tolerance, int threads) {
        const VolumeGrid g = grid_of(ext, 0, lo, hi, "extinction");
        if (sun_t.size() != static_cast<py::ssize_t>(g.voxels()))
          throw py::value_error("sun_t must have the extinction's shape");
        FloatArray sky;
        if (!sky_e.is_none()) {
          sky = sky_e.cast<FloatArray>();
          if (sky.size() != static_cast<py::ssize_t>(g.voxels()) * 3)
            throw py::value_error("sky_e must have shape (D, H, W, 3)");
        }
        if (!(albedo >= 0.0f && albedo <= 1.0f)) throw py::value_error("albedo must be in [0, 1]");
        if (!(mean_cosine > -1.0f && mean_cosine < 1.0f))
          throw py::value_error("mean_cosine must be in (-1, 1)");
        if (max_iterations < 1 || max_iterations > 100000)
          throw py::value_error("max_iterations must be in [1, 100000]");
        DiffusionParams p{albedo, mean_cosine, max_iterations, tolerance};
        const int channels = sky ? 4 : 1;
        const float *e = ext.data(), *st = sun_t.data(), *se = sky ? sky.data() : nullptr;
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          const std::vector<float> q = diffusion_sources(e, g, st, v3(to_sun), se, albedo);
          out = diffusion_fluence(e, g, q.data(), channels, p, threads);
        }
        return to_array(out, {g.d, g.h, g.w, channels});
      },
      py::arg("extinction"), py::arg("lo"), py::arg("hi"), py::arg("sun_t"), py::arg("to_sun"),
      py::arg("sky_e").none(true), py::arg("albedo"), py::arg("mean_cosine"),
      py::arg("max_iterations") = 2000, py::arg("tolerance") = 1e-5f, py::arg("threads") = 0,
      "Collided fluence of the diffusion approximation: (D, H, W, 1 | 4) (sun per unit "
      "irradiance, then the sky's RGB).");
}

}  // namespace cumuli::bind
