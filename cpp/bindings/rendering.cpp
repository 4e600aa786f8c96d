// Bindings of the rendering stage (python/cumuli/rendering): the CPU twins — the 2018 paper's
// reference marcher (rendering/marcher.hpp, `render_cpu`), the volume marcher
// (rendering/volume.hpp), the shared sprite rasteriser (rendering/sprites.hpp) — the compositor
// (rendering/compositor.hpp) and the impostor maths of Harris 2002 (rendering/impostors.hpp).
#include "cumuli/candidates.hpp"
#include "cumuli/rendering/marcher.hpp"
#include "cumuli/rendering/occupancy.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "common.hpp"
#include "cumuli/rendering/air.hpp"
#include "cumuli/rendering/billboards.hpp"
#include "cumuli/rendering/compositor.hpp"
#include "cumuli/rendering/edges.hpp"
#include "cumuli/rendering/impostors.hpp"
#include "cumuli/rendering/solids.hpp"
#include "cumuli/rendering/sprites.hpp"
#include "cumuli/rendering/volume.hpp"

namespace cumuli::bind {

namespace {

// Largest image the CPU marcher accepts (pixels), checked before allocating.
constexpr py::ssize_t kMaxPixels = py::ssize_t{1} << 26;
constexpr int kMaxEdge = 1 << 15;

py::object item(const py::dict& d, const char* key, std::size_t index) {
  if (!d.contains(key))
    throw py::value_error("clouds[" + std::to_string(index) + "] is missing '" + key + "'");
  return d[key];
}

// One cloud from a dict: centres, radii, rotations, model, kappa, phi, optional noise_offset,
// light [z, y, x], light_lo, light_hi (or physical).
RenderCloud cloud_from_dict(const py::handle& h, std::size_t index, std::vector<py::object>& keep) {
  if (!py::isinstance<py::dict>(h))
    throw py::type_error("clouds[" + std::to_string(index) + "] must be a dict");
  const py::dict d = py::reinterpret_borrow<py::dict>(h);
  const std::string at = "clouds[" + std::to_string(index) + "].";
  RenderCloud rc;
  try {
    rc.shape = cloud_from_arrays(
        item(d, "centres", index).cast<FloatArray>(), item(d, "radii", index).cast<FloatArray>(),
        item(d, "rotations", index).cast<FloatArray>(), item(d, "model", index).cast<std::string>(),
        item(d, "kappa", index).cast<float>(), item(d, "phi", index).cast<float>(),
        d.contains("noise_offset") ? noise_offset_arg(d["noise_offset"]) : glm::vec3(0.0f));
  } catch (const std::invalid_argument& e) {
    throw py::value_error(at + e.what());
  }
  if (d.contains("physical") && !d["physical"].is_none()) {
    try {
      rc.physical = physical_grids_of(d["physical"], &keep);
    } catch (const py::value_error& e) {
      throw py::value_error(at + e.what());
    }
    return rc;
  }
  const FloatArray light = item(d, "light", index).cast<FloatArray>();
  if (light.ndim() != 3 || light.shape(0) < 1 || light.shape(1) < 1 || light.shape(2) < 1)
    throw py::value_error(at + "light must be a non-empty (D, H, W) array indexed [z, y, x]");
  if (light.size() > (py::ssize_t{1} << 27)) throw py::value_error(at + "light grid is too large");
  rc.light.nz = static_cast<int>(light.shape(0));
  rc.light.ny = static_cast<int>(light.shape(1));
  rc.light.nx = static_cast<int>(light.shape(2));
  rc.light.values.assign(light.data(), light.data() + light.size());
  rc.light.box.lo = vec3_arg(item(d, "light_lo", index), (at + "light_lo").c_str());
  rc.light.box.hi = vec3_arg(item(d, "light_hi", index), (at + "light_hi").c_str());
  try {
    rc.light.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(at + e.what());
  }
  return rc;
}

// Solids as (n, 4) float32 rows (centre xyz, radius), or None: what the marchers clip at.
std::vector<SolidSphere> solid_spheres(const py::object& obj) {
  std::vector<SolidSphere> out;
  if (obj.is_none()) return out;
  const FloatArray a = obj.cast<FloatArray>();
  if (a.ndim() != 2 || a.shape(1) != 4)
    throw py::value_error("solids must have shape (n, 4): centre x, y, z and radius");
  if (a.shape(0) > kMaxSolids) throw py::value_error("at most 16 solids");
  for (py::ssize_t k = 0; k < a.shape(0); ++k) {
    const float* r = a.data() + 4 * k;
    SolidSphere sp;
    sp.centre = glm::vec3(r[0], r[1], r[2]);
    sp.radius = r[3];
    try {
      sp.validate();
    } catch (const std::invalid_argument& e) {
      throw py::value_error("solids[" + std::to_string(k) + "]: " + e.what());
    }
    out.push_back(sp);
  }
  return out;
}

CameraParams camera_params(const py::handle& position, const py::handle& target,
                           const py::handle& up, float fov);

CameraParams camera_params(const py::handle& position, const py::handle& target,
                           const py::handle& up, float fov) {
  CameraParams cam;
  cam.position = vec3_arg(position, "camera position");
  cam.target = vec3_arg(target, "camera target");
  cam.up = vec3_arg(up, "camera up");
  cam.fov = finite(fov, "fov");
  try {
    cam.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return cam;
}

// The sun as the renderers take it: finite, direction non-zero and normalised here.
SunParams sun_of(const SunParams& sun) {
  SunParams out = sun;
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(sun.direction[k]) || !std::isfinite(sun.radiance[k]))
      throw py::value_error("sun direction and radiance must be finite");
  if (!(glm::dot(sun.direction, sun.direction) > 0.0f))
    throw py::value_error("sun direction must not be zero");
  out.direction = glm::normalize(sun.direction);
  return out;
}

// An optional (height, width) boolean or integer array `given` as bytes, 1 where nonzero (a
// pixel mask of the image); empty when `given` is None. `name` is the argument in the errors.
py::array_t<std::uint8_t, py::array::c_style> pixel_mask(const py::object& given_obj,
                                                         py::ssize_t height, py::ssize_t width,
                                                         const char* name) {
  if (given_obj.is_none()) return {};
  const py::array given = py::array::ensure(given_obj);
  if (!given || given.ndim() != 2 || given.shape(0) != height || given.shape(1) != width)
    throw py::value_error(std::string(name) + " must be an (H, W) array of the image's size");
  const char kind = given.dtype().kind();
  if (kind != 'b' && kind != 'u' && kind != 'i')
    throw py::type_error(std::string(name) + " must be a boolean or integer array");
  return py::array_t<std::uint8_t, py::array::c_style>(
      py::module_::import("numpy").attr("not_equal")(given, 0));
}

// The `out` array of finish_physical: a writable C-contiguous float32 (height, width, 4) array,
// `image` itself or memory apart from it (a partial overlap would read rows already written).
py::array finish_target(const py::object& given, const FloatArray& image, py::ssize_t height,
                        py::ssize_t width) {
  if (!py::isinstance<py::array>(given)) throw py::type_error("out must be a numpy array or None");
  const auto out = py::reinterpret_borrow<py::array>(given);
  if (!out.dtype().is(py::dtype::of<float>())) throw py::type_error("out must be float32");
  if (out.ndim() != 3 || out.shape(0) != height || out.shape(1) != width || out.shape(2) != 4)
    throw py::value_error("out must have the image's shape (H, W, 4)");
  if (!(out.flags() & py::array::c_style)) throw py::value_error("out must be C-contiguous");
  if (!out.writeable()) throw py::value_error("out must be writable");
  const auto* o = static_cast<const char*>(out.data());
  const auto* i = reinterpret_cast<const char*>(image.data());
  const auto bytes = static_cast<std::size_t>(out.nbytes());
  if (o != i && o < i + bytes && i < o + bytes)
    throw py::value_error("out must be the image itself or not overlap it");
  return out;
}

// An optional (N, 2) integer array `given` of (row, column) pixels as int32 pairs; empty when
// `given` is None. The range is checked where the image's size is known (render_pixels).
py::array_t<std::int32_t, py::array::c_style | py::array::forcecast> pixel_pairs(
    const py::object& given_obj) {
  if (given_obj.is_none()) return {};
  const py::array given = py::array::ensure(given_obj);
  if (!given || given.ndim() != 2 || given.shape(1) != 2)
    throw py::value_error("pixels must be an (N, 2) array of (row, column)");
  const char kind = given.dtype().kind();
  if (kind != 'u' && kind != 'i') throw py::type_error("pixels must be an integer array");
  const py::object numpy = py::module_::import("numpy");
  const py::array wide = numpy.attr("asarray")(given, "int64");
  const auto view = wide.unchecked<std::int64_t, 2>();
  for (py::ssize_t k = 0; k < view.shape(0); ++k)
    for (int j = 0; j < 2; ++j)
      if (view(k, j) < 0 || view(k, j) > INT32_MAX)
        throw py::value_error("pixels must lie in the image: (row, column) in [0, H) x [0, W)");
  return py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>(wide);
}

}  // namespace

const Names<MarchMode> kMarchModes = {{"paper", MarchMode::Paper}, {"union", MarchMode::Union}};
const Names<PhaseKind> kPhases = {{"rayleigh", PhaseKind::Rayleigh},
                                  {"isotropic", PhaseKind::Isotropic},
                                  {"hg", PhaseKind::HenyeyGreenstein}};
const Names<SpriteSort> kSorts = {{"distance", SpriteSort::Distance}, {"depth", SpriteSort::Depth}};
const Names<SplatKernel> kKernels = {{"gaussian", SplatKernel::Gaussian},
                                     {"hermite", SplatKernel::Hermite}};

// This stage's parameter structs as classes (module.cpp binds them before the functions that
// take them): fields as attributes, vectors as tuples, enumerations by name.
void bind_render_params(py::module_& m) {
  py::class_<SunParams> sun(m, "SunParams", "The sun: direction (towards it) and radiance.");
  sun.def(py::init<>());
  vec3_property(sun, "direction", &SunParams::direction, "sun direction");
  vec3_property(sun, "radiance", &SunParams::radiance, "sun radiance");

  py::class_<SkyParams> sky(m, "SkyParams",
                            "The gradient sky and the sun disc (RENDER_CONTRACT \"Sky\").");
  sky.def(py::init<>())
      .def_readwrite("exponent", &SkyParams::exponent)
      .def_readwrite("sun_disc_radius", &SkyParams::sun_disc_radius)
      .def_readwrite("sun_disc_intensity", &SkyParams::sun_disc_intensity);
  vec3_property(sky, "zenith", &SkyParams::zenith, "sky zenith");
  vec3_property(sky, "horizon", &SkyParams::horizon, "sky horizon");
  vec3_property(sky, "ground", &SkyParams::ground, "sky ground");

  py::class_<CameraParams> cam(m, "CameraParams",
                               "A look-at camera: position, target, up, vertical fov (degrees).");
  cam.def(py::init<>())
      .def_property(
          "fov", [](const CameraParams& c) { return c.fov; },
          [](CameraParams& c, float v) { c.fov = finite(v, "fov"); })
      .def("validate", &CameraParams::validate);
  vec3_property(cam, "position", &CameraParams::position, "camera position");
  vec3_property(cam, "target", &CameraParams::target, "camera target");
  vec3_property(cam, "up", &CameraParams::up, "camera up");

  py::class_<Viewport>(m, "Viewport", "A camera and the image it takes (width × height).")
      .def(py::init([](const CameraParams& camera, int width, int height) {
             return Viewport{camera, width, height};
           }),
           py::arg("camera"), py::arg("width"), py::arg("height"))
      .def_readwrite("camera", &Viewport::camera)
      .def_readwrite("width", &Viewport::width)
      .def_readwrite("height", &Viewport::height)
      .def("validate", &Viewport::validate);

  m.attr("ORDER_PHASE_SIZE") = kOrderPhaseSize;
  m.attr("MAX_OCTAVES") = kMaxOctaves;
  py::class_<PhysicalParams>(m, "PhysicalParams",
                             "The physical lighting mode's shading (RENDER_CONTRACT "
                             "\"Physical lighting\").")
      .def(py::init<>())
      .def_readwrite("extinction_scale", &PhysicalParams::extinction_scale)
      .def_readwrite("albedo", &PhysicalParams::albedo)
      .def_readwrite("dual_hg", &PhysicalParams::dual_hg)
      .def_readwrite("g1", &PhysicalParams::g1)
      .def_readwrite("g2", &PhysicalParams::g2)
      .def_readwrite("blend", &PhysicalParams::blend)
      .def_readwrite("mie", &PhysicalParams::mie)
      .def_property(
          "droplet_diameter", [](const PhysicalParams& p) { return p.droplet_diameter; },
          [](PhysicalParams& p, float d) {
            p.mie_params = approx_mie_params(d);
            p.droplet_diameter = d;
          })
      .def_property_readonly("mie_params",
                             [](const PhysicalParams& p) {
                               const ApproxMie& m = p.mie_params;
                               return py::make_tuple(m.g_hg, m.g_d, m.alpha, m.w_d);
                             })
      .def("phase", &PhysicalParams::phase, py::arg("cos_theta"), py::arg("scale") = 1.0f)
      .def_readwrite("octaves", &PhysicalParams::octaves)
      .def_readwrite("oct_a", &PhysicalParams::oct_a)
      .def_readwrite("oct_b", &PhysicalParams::oct_b)
      .def_readwrite("oct_c", &PhysicalParams::oct_c)
      .def_readwrite("oct_poisson", &PhysicalParams::oct_poisson)
      .def_property(
          "order_phase",
          [](const PhysicalParams& p) {
            FloatArray out(static_cast<py::ssize_t>(p.order_phase.size()));
            std::copy(p.order_phase.begin(), p.order_phase.end(), out.mutable_data());
            return out;
          },
          [](PhysicalParams& p, const FloatArray& values) {
            if (values.ndim() != 1) throw py::value_error("order_phase must be one-dimensional");
            p.order_phase.assign(values.data(), values.data() + values.size());
          },
          "Orders 1… of the drawn octaves' phase, (octaves - 1) rows of ORDER_PHASE_SIZE "
          "values at sin(θ/2) = k/(ORDER_PHASE_SIZE - 1), flattened; empty: phase(bⁱ·g).")
      .def_readwrite("oct_first", &PhysicalParams::oct_first)
      .def_readwrite("view_scale", &PhysicalParams::view_scale)
      .def_readwrite("view_diffuse", &PhysicalParams::view_diffuse)
      .def(
          "octave_sum",
          [](const PhysicalParams& p, float cos_theta, const FloatArray& tau) {
            p.validate();
            const OctaveTerms terms(p, cos_theta);
            FloatArray out(tau.size());
            for (py::ssize_t i = 0; i < tau.size(); ++i)
              out.mutable_data()[i] = terms.sum(tau.data()[i]);
            return out;
          },
          py::arg("cos_theta"), py::arg("tau"),
          "The drawn orders' sum Σ aⁱ·phase(bⁱg, cos_theta)·Pᵢ(τ) at optical depths `tau` "
          "(the marchers' per-sample octave term).")
      .def_readwrite("jitter_seed", &PhysicalParams::jitter_seed)
      .def_readwrite("min_transmittance", &PhysicalParams::min_transmittance)
      .def_readwrite("coarsen_below", &PhysicalParams::coarsen_below)
      .def("validate", &PhysicalParams::validate);
  m.attr("COARSEN_EVERY") = kCoarsenEvery;
  m.attr("MAX_COARSEN") = kMaxCoarsen;

  py::class_<MarchSettings> ms(m, "MarchSettings",
                               "The 2018 marcher's settings (RENDER_CONTRACT), filled from "
                               "RenderSettings by cumuli.rendering.params.march_params.");
  ms.def(py::init<>())
      .def_readwrite("absorption", &MarchSettings::absorption)
      .def_readwrite("lod_a", &MarchSettings::lod_a)
      .def_readwrite("lod_delta", &MarchSettings::lod_delta)
      .def_readwrite("ref_step", &MarchSettings::ref_step)
      .def_readwrite("step_min", &MarchSettings::step_min)
      .def_readwrite("step_max", &MarchSettings::step_max)
      .def_readwrite("fixed_step", &MarchSettings::fixed_step)
      .def_readwrite("hg_g", &MarchSettings::hg_g)
      .def_readwrite("max_steps", &MarchSettings::max_steps)
      .def_readwrite("max_candidates", &MarchSettings::max_candidates)
      .def_readwrite("sort_candidates", &MarchSettings::sort_candidates)
      .def_readwrite("fbm", &MarchSettings::fbm)
      .def_readwrite("density_constant", &MarchSettings::density_constant)
      .def_readwrite("physical", &MarchSettings::physical)
      .def_readwrite("phys", &MarchSettings::phys)
      .def_readwrite("min_transmittance", &MarchSettings::min_transmittance)
      .def_readwrite("skip_empty", &MarchSettings::skip_empty)
      .def_readwrite("jitter", &MarchSettings::jitter)
      .def("validate", &MarchSettings::validate);
  enum_property(ms, "march", &MarchSettings::march, kMarchModes);

  py::class_<VolumeCameraRays> vc(m, "VolumeCamera",
                                  "The volume marcher's camera: position, unit basis and "
                                  "tan(vertical fov / 2).");
  vc.def(py::init<>()).def_readwrite("tan_half_fov", &VolumeCameraRays::tan_half_fov);
  vec3_property(vc, "position", &VolumeCameraRays::position, "camera position");
  vec3_property(vc, "forward", &VolumeCameraRays::forward, "camera forward");
  vec3_property(vc, "right", &VolumeCameraRays::right, "camera right");
  vec3_property(vc, "up", &VolumeCameraRays::up, "camera up");

  py::class_<VolumeRenderParams>(m, "VolumeRenderParams",
                                 "The volume marcher's image, sun, sky and medium.")
      .def(py::init<>())
      .def_readwrite("width", &VolumeRenderParams::width)
      .def_readwrite("height", &VolumeRenderParams::height)
      .def_readwrite("sun", &VolumeRenderParams::sun)
      .def_readwrite("sky", &VolumeRenderParams::sky)
      .def_readwrite("with_sky", &VolumeRenderParams::with_sky)
      .def_readwrite("sigma_t", &VolumeRenderParams::sigma_t)
      .def_readwrite("albedo", &VolumeRenderParams::albedo)
      .def_readwrite("g", &VolumeRenderParams::g)
      .def_readwrite("step", &VolumeRenderParams::step)
      .def_readwrite("physical", &VolumeRenderParams::physical)
      .def_readwrite("phys", &VolumeRenderParams::phys)
      .def_readwrite("cubic", &VolumeRenderParams::cubic)
      .def_readwrite("detail", &VolumeRenderParams::detail)
      .def_readwrite("detail_inv_max", &VolumeRenderParams::detail_inv_max)
      .def_readwrite("detail_fbm", &VolumeRenderParams::detail_fbm);
}

// This stage's parameter structs as classes (module.cpp binds them before the functions that
// take them): fields as attributes, vectors as tuples, enumerations by name.
void bind_sprite_params(py::module_& m) {
  py::class_<ParticleSpriteSettings> ps(m, "ParticleSpriteSettings",
                                        "The Harris particles' eye pass: solid angle γ, phase, "
                                        "ambient, sort and culling.");
  ps.def(py::init<>())
      .def_readwrite("solid_angle", &ParticleSpriteSettings::solid_angle)
      .def_readwrite("hg_g", &ParticleSpriteSettings::hg_g)
      .def_readwrite("cull", &ParticleSpriteSettings::cull);
  vec3_property(ps, "ambient", &ParticleSpriteSettings::ambient, "ambient");
  enum_property(ps, "phase", &ParticleSpriteSettings::phase, kPhases);
  enum_property(ps, "sort", &ParticleSpriteSettings::sort, kSorts);

  py::class_<SpriteRasterSettings> rs(m, "SpriteRasterSettings",
                                      "The sprite rasteriser's splat kernel and peak opacity.");
  rs.def(py::init<>()).def_readwrite("peak", &SpriteRasterSettings::peak);
  enum_property(rs, "kernel", &SpriteRasterSettings::kernel, kKernels);
}

namespace {

// The edge pass's (range, sub, rays, max_rays, max_sub_edge), or none for None.
std::optional<EdgePass> edge_pass_of(const py::object& edges) {
  if (edges.is_none()) return std::nullopt;
  using Spec = std::tuple<float, int, std::vector<std::pair<int, int>>, long long, int>;
  Spec t;
  try {
    t = edges.cast<Spec>();
  } catch (const py::cast_error&) {
    throw py::type_error(
        "edges must be a tuple (range, sub, rays, max_rays, max_sub_edge), rays (row, column) "
        "pairs");
  }
  EdgePass pass;
  pass.range = std::get<0>(t);
  pass.sub = std::get<1>(t);
  pass.rays = std::get<2>(t);
  if (std::get<3>(t) < 0) throw py::value_error("max_rays must be >= 0");
  pass.max_rays = static_cast<std::size_t>(std::get<3>(t));
  pass.max_sub_edge = std::get<4>(t);
  try {
    pass.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return pass;
}

// _core.render_cpu and render_cpu_edged: the march of a whole image, of a list of pixels, or of
// a whole image with the physical mode's edge pass (`edges` not None).
py::object march_call(const Viewport& view, const py::list& clouds, const SunParams& sun,
                      const SkyParams& sky, const MarchSettings& settings, const Noise* noise,
                      int threads, bool with_sky, const py::object& solids,
                      const py::object& ground, bool return_stats, const py::object& pixels,
                      const py::object& edges) {
  try {
    view.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  const int width = view.width, height = view.height;
  if (threads < 0 || threads > 1024) throw py::value_error("threads must be in [0, 1024]");
  const MarchSettings& s = settings;
  if (s.phys.jitter_seed < 0 || s.phys.jitter_seed > 1023)
    throw py::value_error("jitter_seed must be in [0, 1023]");

  MarchScene scene;
  scene.sun = sun_of(sun);
  scene.sky = sky;
  scene.noise = noise;
  scene.with_sky = with_sky;
  scene.solids = solid_spheres(solids);
  scene.ground = ground_of(ground);
  scene.clouds.reserve(clouds.size());
  std::vector<py::object> keep;  // the physical lattices the clouds view, held to the end
  for (std::size_t i = 0; i < clouds.size(); ++i)
    scene.clouds.push_back(cloud_from_dict(clouds[i], i, keep));

  try {
    s.validate();
    scene.validate(s);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }

  // The pixels to march, or all of them.
  const auto listed = pixel_pairs(pixels);
  const bool whole = pixels.is_none();
  const std::optional<EdgePass> pass = edge_pass_of(edges);
  const std::size_t count = whole
                                ? static_cast<std::size_t>(width) * static_cast<std::size_t>(height)
                                : static_cast<std::size_t>(listed.shape(0));
  auto out =
      whole ? new_array({height, width, 4}) : new_array({static_cast<py::ssize_t>(count), 4});
  float* dst = out.mutable_data();
  py::array_t<std::uint32_t> map;
  MarchStats stats;
  if (return_stats) {
    map = whole ? py::array_t<std::uint32_t>(
                      {static_cast<py::ssize_t>(height), static_cast<py::ssize_t>(width)})
                : py::array_t<std::uint32_t>(static_cast<py::ssize_t>(count));
  }
  std::uint32_t* map_dst = return_stats ? map.mutable_data() : nullptr;
  MarchStats* stats_dst = return_stats ? &stats : nullptr;
  py::array_t<bool> mask;
  bool edged = false;
  if (pass) mask = py::array_t<bool>({height, width});
  try {
    py::gil_scoped_release release;
    if (pass) {
      edged = render_image_with_edges(scene, s, view.camera, width, height, dst, threads, *pass,
                                      reinterpret_cast<std::uint8_t*>(mask.mutable_data()),
                                      stats_dst, map_dst);
    } else if (whole) {
      render_image(scene, s, view.camera, width, height, dst, threads, stats_dst, map_dst);
    } else {
      render_pixels(scene, s, view.camera, width, height, listed.data(), count, dst, threads,
                    stats_dst, map_dst);
    }
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  py::object outline = edged ? py::object(mask) : py::object(py::none());
  if (!return_stats) return pass ? py::object(py::make_tuple(out, outline)) : py::object(out);
  py::dict d;
  d["fbm_evaluations"] = stats.fbm_evaluations;
  d["steps"] = stats.steps;
  d["skipped"] = stats.skipped;
  d["fbm_map"] = map;
  if (pass) return py::make_tuple(out, outline, d);
  return py::make_tuple(out, d);
}

}  // namespace

void bind_march(py::module_& m) {
  m.def(
      "render_cpu",
      [](const Viewport& view, const py::list& clouds, const SunParams& sun, const SkyParams& sky,
         const MarchSettings& settings, const Noise* noise, int threads, bool with_sky,
         const py::object& solids, const py::object& ground, bool return_stats,
         const py::object& pixels) {
        return march_call(view, clouds, sun, sky, settings, noise, threads, with_sky, solids,
                          ground, return_stats, pixels, py::none());
      },
      py::arg("view"), py::arg("clouds"), py::arg("sun"), py::arg("sky"), py::arg("settings"),
      py::arg("noise").none(true), py::arg("threads") = 0, py::arg("with_sky") = true,
      py::arg("solids") = py::none(), py::arg("ground") = py::none(),
      py::arg("return_stats") = false, py::arg("pixels") = py::none(),
      "CPU reference ray marcher (RENDER_CONTRACT): an (H, W, 4) float32 RGBA image of the "
      "Viewport, row 0 at the top. Each cloud is a dict with centres, radii, rotations, model, "
      "kappa, phi, light ([z, y, x]) and light_lo / light_hi (or physical). settings: a "
      "MarchSettings (density_constant >= 0 replaces fBm, for tests; physical selects the "
      "physical mode with its PhysicalParams). with_sky=False gives the premultiplied layer "
      "(colour, 1 − T); solids (n, 4) (centre, radius) stop every ray at the nearest solid; "
      "return_stats=True returns (image, {fbm_evaluations, steps, skipped, fbm_map}); pixels, an "
      "(N, 2) integer array of (row, column), marches only those pixels of the image and returns "
      "their (N, 4) values in that order (fbm_map then (N,)).");

  m.def(
      "render_cpu_edged",
      [](const Viewport& view, const py::list& clouds, const SunParams& sun, const SkyParams& sky,
         const MarchSettings& settings, const Noise* noise, int threads, const py::object& ground,
         bool return_stats, const py::object& edges) {
        if (edges.is_none()) throw py::type_error("edges must be a tuple, not None");
        return march_call(view, clouds, sun, sky, settings, noise, threads, true, py::none(),
                          ground, return_stats, py::none(), edges);
      },
      py::arg("view"), py::arg("clouds"), py::arg("sun"), py::arg("sky"), py::arg("settings"),
      py::arg("noise").none(true), py::arg("threads") = 0, py::arg("ground") = py::none(),
      py::arg("return_stats") = false, py::arg("edges") = py::none(),
      "render_cpu over the sky (no solids) with the physical mode's edge pass in the same call "
      "(cumuli.rendering.edges): edges, a tuple (range, sub, rays, max_rays, max_sub_edge). "
      "Returns (image, mask or None) and, with return_stats, (image, mask or None, stats), the "
      "outline's work counted in its pixels.");

  m.def(
      "occupancy_grid",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& rotations,
         const std::string& model, int resolution) {
        if (resolution < 1 || resolution > 256)
          throw py::value_error("resolution must be in [1, 256], got " +
                                std::to_string(resolution));
        const CloudShape cloud = cloud_from_arrays(centres, radii, rotations, model, 0.5f, 1.0f);
        OccupancyGrid g;
        {
          py::gil_scoped_release release;
          g = build_occupancy(cloud, resolution);
        }
        const py::ssize_t r = resolution;
        py::array_t<std::uint8_t> cells({r, r, r});
        std::copy(g.cells.begin(), g.cells.end(), cells.mutable_data());
        return py::make_tuple(cells, py::make_tuple(g.box.lo.x, g.box.lo.y, g.box.lo.z),
                              py::make_tuple(g.box.hi.x, g.box.hi.y, g.box.hi.z));
      },
      py::arg("centres"), py::arg("radii"), py::arg("rotations"), py::arg("model"),
      py::arg("resolution") = kOccupancyRes,
      "A cloud's occupancy grid for empty-space skipping (RENDER_CONTRACT): (cells [z, y, x] "
      "uint8, 1 where density may be > 0, 0 where it is certainly 0; lo; hi), over the cloud's "
      "candidate box.");
}

void bind_camera_candidates(py::module_& m) {
  m.def(
      "camera_candidates",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& rotations,
         const std::string& model, std::tuple<float, float, float> origin, const FloatArray& dirs,
         int capacity) {
        require_points(dirs, "dirs");
        if (capacity < 1 || capacity > 4096)
          throw py::value_error("capacity must be in [1, 4096], got " + std::to_string(capacity));
        const CloudShape cloud = cloud_from_arrays(centres, radii, rotations, model, 0.5f, 1.0f);
        const glm::vec3 o(std::get<0>(origin), std::get<1>(origin), std::get<2>(origin));
        const py::ssize_t n = dirs.shape(0);
        py::array_t<float> fan({n, static_cast<py::ssize_t>(capacity), py::ssize_t{3}});
        py::array_t<float> each({n, static_cast<py::ssize_t>(capacity), py::ssize_t{3}});
        std::fill_n(fan.mutable_data(), fan.size(), -1.0f);
        std::fill_n(each.mutable_data(), each.size(), -1.0f);
        const float* d = dirs.data();
        {
          py::gil_scoped_release release;
          const CandidateFan f(cloud, o);
          std::vector<Candidate> a(static_cast<std::size_t>(capacity)), b(a.size());
          for (py::ssize_t i = 0; i < n; ++i) {
            const glm::vec3 dir(d[3 * i], d[3 * i + 1], d[3 * i + 2]);
            const int na = f.collect(dir, 0.0f, INFINITY, a.data(), capacity);
            const int nb = collect_candidates(cloud, o, dir, 0.0f, INFINITY, b.data(), capacity);
            float* fa = fan.mutable_data(i);
            float* fb = each.mutable_data(i);
            for (int k = 0; k < na; ++k)
              std::tie(fa[3 * k], fa[3 * k + 1], fa[3 * k + 2]) =
                  std::make_tuple(static_cast<float>(a[k].primitive), a[k].t_in, a[k].t_out);
            for (int k = 0; k < nb; ++k)
              std::tie(fb[3 * k], fb[3 * k + 1], fb[3 * k + 2]) =
                  std::make_tuple(static_cast<float>(b[k].primitive), b[k].t_in, b[k].t_out);
          }
        }
        return py::make_tuple(fan, each);
      },
      py::arg("centres"), py::arg("radii"), py::arg("rotations"), py::arg("model"),
      py::arg("origin"), py::arg("dirs"), py::arg("capacity") = 64,
      "The candidates (primitive, t_in, t_out; −1 past the last) of rays from one origin, by "
      "the camera's fan (culled by cones, the marchers' path) and by testing every primitive: "
      "(fan, each), each (n, capacity, 3) float32. For tests: the two must agree bit for bit.");
  m.def(
      "screen_candidates",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& rotations,
         const std::string& model, const Viewport& view, int capacity) {
        view.validate();
        if (capacity < 1 || capacity > 4096)
          throw py::value_error("capacity must be in [1, 4096], got " + std::to_string(capacity));
        if (static_cast<long long>(view.width) * view.height * capacity > (1LL << 26))
          throw py::value_error("width x height x capacity must be at most 2^26");
        const CloudShape cloud = cloud_from_arrays(centres, radii, rotations, model, 0.5f, 1.0f);
        const py::ssize_t h = view.height, w = view.width, c = capacity;
        py::array_t<float> binned({h, w, c, py::ssize_t{3}});
        py::array_t<float> each({h, w, c, py::ssize_t{3}});
        py::array_t<std::int32_t> tested({h, w});
        std::fill_n(binned.mutable_data(), binned.size(), -1.0f);
        std::fill_n(each.mutable_data(), each.size(), -1.0f);
        {
          py::gil_scoped_release release;
          const CameraRays rays(view.camera, view.width, view.height);
          const ScreenTiles tiles(rays);
          CandidateFan fan(cloud, rays.origin);
          fan.bin(tiles.cones());
          std::vector<Candidate> a(static_cast<std::size_t>(capacity)), b(a.size());
          auto put = [](float* dst, const std::vector<Candidate>& src, int n) {
            for (int k = 0; k < n; ++k)
              std::tie(dst[3 * k], dst[3 * k + 1], dst[3 * k + 2]) =
                  std::make_tuple(static_cast<float>(src[k].primitive), src[k].t_in, src[k].t_out);
          };
          for (int r = 0; r < view.height; ++r) {
            for (int col = 0; col < view.width; ++col) {
              const glm::vec3 dir = rays.direction(r, col);
              const int tile = tiles.tile_of(r, col);
              put(binned.mutable_data(r, col), a,
                  fan.collect(dir, tile, 0.0f, INFINITY, a.data(), capacity));
              put(each.mutable_data(r, col), b,
                  collect_candidates(cloud, rays.origin, dir, 0.0f, INFINITY, b.data(), capacity));
              tested.mutable_at(r, col) = fan.bin_size(tile);
            }
          }
        }
        return py::make_tuple(binned, each, tested);
      },
      py::arg("centres"), py::arg("radii"), py::arg("rotations"), py::arg("model"),
      py::arg("viewport"), py::arg("capacity") = 64,
      "The candidates (primitive, t_in, t_out; −1 past the last) of every pixel's camera ray, by "
      "the marchers' fan binned by screen tile and by testing every primitive, and the number of "
      "primitives each pixel's bin holds: (binned, each, tested), binned and each (H, W, "
      "capacity, 3) float32, tested (H, W) int32. For tests: binned and each must agree bit for "
      "bit.");
}

void bind_volume_march(py::module_& m) {
  m.def(
      "render_volume_cpu",
      [](const FloatArray& density, const FloatArray& light, V3 lo, V3 hi,
         const VolumeCameraRays& camera, const VolumeRenderParams& params, int threads,
         const py::object& solids, const py::object& physical_light, const py::object& noise) {
        const VolumeGrid grid = grid_of(density, 0, lo, hi, "volume");
        const VolumeGrid lg = grid_of(light, 0, lo, hi, "light", 1);
        if (lg.w != grid.w || lg.h != grid.h || lg.d != grid.d || light.shape(3) != 4)
          throw py::value_error("light must have shape (D, H, W, 4) matching the volume");
        VolumeRenderParams p = params;
        p.noise = noise.is_none() ? nullptr : noise.cast<const Noise*>();
        p.solids = solid_spheres(solids);
        PhysicalGrids grids;
        p.grids = nullptr;
        if (p.physical) {
          try {
            p.phys.validate();
          } catch (const std::invalid_argument& e) {
            throw py::value_error(e.what());
          }
          grids = physical_grids_of(physical_light);
          p.grids = &grids;
        }
        const float *pd = density.data(), *pl = light.data();
        std::vector<float> img;
        {
          py::gil_scoped_release release;
          img = render_volume_cpu(pd, pl, grid, camera, p, threads);
        }
        return to_array(img, {p.height, p.width, 4});
      },
      py::arg("density"), py::arg("light"), py::arg("lo"), py::arg("hi"), py::arg("camera"),
      py::arg("params"), py::arg("threads"), py::arg("solids") = py::none(),
      py::arg("physical_light") = py::none(), py::arg("noise") = py::none(),
      "CPU emission–absorption march of a lit density volume: (H, W, 4) float32, row 0 on top. "
      "camera: a VolumeCamera; params: VolumeRenderParams (image, sun, sky, medium; physical "
      "with its PhysicalParams and physical_light); solids (n, 4) stop every ray at the nearest "
      "solid; noise: the fBm lattice of the physical mode's detail (params.detail > 0).");
}

void bind_composite(py::module_& m) {
  m.def(
      "composite_layers",
      [](const FloatArray& layers, const FloatArray& boxes, const CameraParams& camera,
         const py::object& sky, const py::handle& sun_direction, const py::handle& sun_radiance,
         int threads, const py::object& solid, const py::object& ground,
         const py::object& view_scales) {
        if (layers.ndim() != 4 || layers.shape(3) != 4)
          throw py::value_error("layers must have shape (L, H, W, 4)");
        const py::ssize_t n = layers.shape(0), height = layers.shape(1), width = layers.shape(2);
        if (height < 1 || width < 1 || height > kMaxEdge || width > kMaxEdge)
          throw py::value_error("layers: image edges must be in [1, " + std::to_string(kMaxEdge) +
                                "]");
        if (boxes.ndim() != 3 || boxes.shape(0) != n || boxes.shape(1) != 2 || boxes.shape(2) != 3)
          throw py::value_error("boxes must have shape (L, 2, 3), one (lo, hi) per layer");
        if (threads < 0 || threads > 1024) throw py::value_error("threads must be in [0, 1024]");
        const CameraParams& cam = camera;
        SunParams sun;
        const glm::vec3 sd = vec3_arg(sun_direction, "sun direction");
        if (!(glm::dot(sd, sd) > 0.0f)) throw py::value_error("sun direction must not be zero");
        sun.direction = glm::normalize(sd);
        sun.radiance = vec3_arg(sun_radiance, "sun radiance");
        const SkyParams sk = sky_of(sky);
        const GroundParams gp = ground_of(ground);
        std::vector<Layer> list(static_cast<std::size_t>(n));
        const float* b = boxes.data();
        for (py::ssize_t k = 0; k < n; ++k) {
          list[static_cast<std::size_t>(k)].rgba = layers.data() + k * height * width * 4;
          list[static_cast<std::size_t>(k)].box =
              Box{glm::vec3(b[6 * k], b[6 * k + 1], b[6 * k + 2]),
                  glm::vec3(b[6 * k + 3], b[6 * k + 4], b[6 * k + 5])};
        }
        if (!view_scales.is_none()) {
          const auto v = view_scales.cast<FloatArray>();
          if (v.ndim() != 1 || v.shape(0) != n)
            throw py::value_error("view_scales must have shape (L,), one per layer");
          for (py::ssize_t k = 0; k < n; ++k) {
            if (!(v.data()[k] > 0.0f && v.data()[k] <= 1.0f))
              throw py::value_error("view_scales must be in (0, 1]");
            list[static_cast<std::size_t>(k)].view_scale = v.data()[k];
          }
        }
        try {
          cam.validate();
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
        FloatArray solid_image;
        const float* solid_ptr = nullptr;
        if (!solid.is_none()) {
          solid_image = solid.cast<FloatArray>();
          if (solid_image.ndim() != 3 || solid_image.shape(0) != height ||
              solid_image.shape(1) != width || solid_image.shape(2) != 4)
            throw py::value_error("solid must have shape (H, W, 4) like the layers");
          solid_ptr = solid_image.data();
        }
        auto out = new_array({height, width, 4});
        float* dst = out.mutable_data();
        {
          py::gil_scoped_release release;
          composite_layers(list, cam, static_cast<int>(width), static_cast<int>(height), sk, sun,
                           gp, dst, threads, solid_ptr);
        }
        return out;
      },
      py::arg("layers"), py::arg("boxes"), py::arg("camera"), py::arg("sky"),
      py::arg("sun_direction"), py::arg("sun_radiance"), py::arg("threads") = 0,
      py::arg("solid") = py::none(), py::arg("ground") = py::none(),
      py::arg("view_scales") = py::none(),
      "Composite premultiplied layers (L, H, W, 4) over the sky, front to back per pixel by the "
      "ray's entry into each layer's box (L, 2, 3): an (H, W, 4) float32 image, row 0 on top. "
      "solid (H, W, 4): rgb and view depth of opaque solids (+inf where none), which hide the "
      "layers entered behind them. view_scales (L,) in (0, 1]: what lies behind layer k shows "
      "through (1 − A_k)^v_k of it (the physical mode's δ-M view of a medium; None: all 1).");

  m.def(
      "coverage_edges",
      [](const FloatArray& alpha, float range, int threads) {
        if (alpha.ndim() != 2 || alpha.shape(0) < 1 || alpha.shape(1) < 1)
          throw py::value_error("alpha must be a non-empty (H, W) array");
        if (alpha.shape(0) > kMaxEdge || alpha.shape(1) > kMaxEdge)
          throw py::value_error("alpha's edges must be at most " + std::to_string(kMaxEdge));
        if (!std::isfinite(range)) throw py::value_error("range must be finite");
        if (threads < 0 || threads > 1024) throw py::value_error("threads must be in [0, 1024]");
        const py::ssize_t height = alpha.shape(0), width = alpha.shape(1);
        py::array_t<bool> out({height, width});
        {
          py::gil_scoped_release release;
          coverage_edges(alpha.data(), static_cast<int>(width), static_cast<int>(height), range,
                         reinterpret_cast<std::uint8_t*>(out.mutable_data()), threads);
        }
        return out;
      },
      py::arg("alpha"), py::arg("range"), py::arg("threads") = 0,
      "The (H, W) bool mask of the pixels whose 3x3 neighbourhood (edges clamped) of the (H, W) "
      "coverage alpha spans more than range: the physical mode's outline (the edge pass).");

  m.def(
      "finish_physical",
      [](const FloatArray& image, const CameraParams& camera, const SkyParams& sky,
         const SunParams& sun_params, const py::object& ground, const FloatArray& boxes,
         const std::tuple<float, float, float>& air_terms, const PhysicalParams& phase,
         bool resolve, int threads, const py::object& unfiltered, const py::object& out_arg) {
        if (image.ndim() != 3 || image.shape(2) != 4)
          throw py::value_error("image must have shape (H, W, 4)");
        const py::ssize_t height = image.shape(0), width = image.shape(1);
        if (height < 1 || width < 1 || height > kMaxEdge || width > kMaxEdge)
          throw py::value_error("image edges must be in [1, " + std::to_string(kMaxEdge) + "]");
        if (boxes.ndim() != 3 || boxes.shape(1) != 2 || boxes.shape(2) != 3)
          throw py::value_error("boxes must have shape (n, 2, 3), one (lo, hi) per drawable");
        if (threads < 0 || threads > 1024) throw py::value_error("threads must be in [0, 1024]");
        const SunParams sun = sun_of(sun_params);
        const GroundParams gp = ground_of(ground);
        std::vector<Box> list(static_cast<std::size_t>(boxes.shape(0)));
        const float* b = boxes.data();
        for (std::size_t k = 0; k < list.size(); ++k)
          list[k] = Box{glm::vec3(b[6 * k], b[6 * k + 1], b[6 * k + 2]),
                        glm::vec3(b[6 * k + 3], b[6 * k + 4], b[6 * k + 5])};
        AirParams air;
        std::tie(air.extinction, air.height, air.haze) = air_terms;
        air.phase = phase;
        air.resolve = resolve;
        try {
          camera.validate();
          air.validate();
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
        // Pixels the tent skips (nonzero where skipped), or none.
        const auto skipped = pixel_mask(unfiltered, height, width, "unfiltered");
        const std::uint8_t* keep = unfiltered.is_none() ? nullptr : skipped.data();
        py::array out = out_arg.is_none() ? py::array(new_array({height, width, 4}))
                                          : finish_target(out_arg, image, height, width);
        float* dst = static_cast<float*>(out.mutable_data());
        {
          py::gil_scoped_release release;
          finish_physical(image.data(), dst, static_cast<int>(width), static_cast<int>(height),
                          camera, sky, sun, gp, list, air, threads, keep);
        }
        return out;
      },
      py::arg("image"), py::arg("camera"), py::arg("sky"), py::arg("sun"), py::arg("ground"),
      py::arg("boxes"), py::arg("air"), py::arg("phase"), py::arg("resolve"),
      py::arg("threads") = 0, py::arg("unfiltered") = py::none(), py::arg("out") = py::none(),
      "The physical mode's finishing passes on a finished (H, W, 4) image (a new array): the air "
      "(air = (air_extinction, air_height, haze): aerial perspective, and the aureole with "
      "phase's phase function; boxes (n, 2, 3): the drawables' layer boxes for the clouds' "
      "depth), then the 3x3 tent resolve when resolve is true, except at the pixels where "
      "unfiltered (H, W) is nonzero (the edge pass's supersampled pixels). out: a writable "
      "C-contiguous float32 (H, W, 4) array to write into and return instead of a new one; it may "
      "be image itself (finished in place), but must not overlap it otherwise.");

  m.def(
      "draw_solids",
      [](const FloatArray& spheres, const FloatArray& colours, const FloatArray& ambient,
         const py::handle& camera_position, const py::handle& camera_target,
         const py::handle& camera_up, float fov, int width, int height,
         const py::handle& sun_direction, const py::handle& sun_radiance, int threads) {
        std::vector<SolidSphere> solids = solid_spheres(spheres);
        const auto n = static_cast<py::ssize_t>(solids.size());
        for (const auto* a : {&colours, &ambient})
          if (a->ndim() != 2 || a->shape(0) != n || a->shape(1) != 3)
            throw py::value_error("colours and ambient must have shape (n, 3)");
        for (py::ssize_t k = 0; k < n; ++k) {
          const float* c = colours.data() + 3 * k;
          const float* a = ambient.data() + 3 * k;
          solids[static_cast<std::size_t>(k)].colour = glm::vec3(c[0], c[1], c[2]);
          solids[static_cast<std::size_t>(k)].ambient = glm::vec3(a[0], a[1], a[2]);
        }
        if (width < 1 || height < 1 || width > kMaxEdge || height > kMaxEdge ||
            py::ssize_t{width} * height > kMaxPixels)
          throw py::value_error("width and height must be in [1, 32768] (at most 2^26 pixels)");
        if (threads < 0 || threads > 1024) throw py::value_error("threads must be in [0, 1024]");
        const CameraParams cam = camera_params(camera_position, camera_target, camera_up, fov);
        SunParams sun;
        const glm::vec3 sd = vec3_arg(sun_direction, "sun direction");
        if (!(glm::dot(sd, sd) > 0.0f)) throw py::value_error("sun direction must not be zero");
        sun.direction = glm::normalize(sd);
        sun.radiance = vec3_arg(sun_radiance, "sun radiance");
        try {
          for (const auto& sp : solids) sp.validate();
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
        auto out = new_array({height, width, 4});
        float* dst = out.mutable_data();
        {
          py::gil_scoped_release release;
          draw_solids(solids, cam, width, height, sun, dst, threads);
        }
        return out;
      },
      py::arg("spheres"), py::arg("colours"), py::arg("ambient"), py::arg("camera_position"),
      py::arg("camera_target"), py::arg("camera_up"), py::arg("fov"), py::arg("width"),
      py::arg("height"), py::arg("sun_direction"), py::arg("sun_radiance"), py::arg("threads") = 0,
      "The solid image of opaque spheres (n, 4): (H, W, 4) rgb (Lambert + ambient) and the view "
      "depth of the nearest solid (+inf where none), row 0 on top.");

  m.def(
      "composite_split",
      [](const FloatArray& layers, const FloatArray& solids, int threads) {
        if (layers.ndim() != 4 || layers.shape(3) != 4 || layers.shape(0) < 1)
          throw py::value_error("layers must have shape (m + 1, H, W, 4)");
        const py::ssize_t m = layers.shape(0) - 1, h = layers.shape(1), w = layers.shape(2);
        if (solids.ndim() != 4 || solids.shape(0) != m || solids.shape(1) != h ||
            solids.shape(2) != w || solids.shape(3) != 4)
          throw py::value_error("solids must have shape (m, H, W, 4), one fewer than layers");
        if (h < 1 || w < 1) throw py::value_error("layers must not be empty");
        std::vector<const float*> lp, sp;
        for (py::ssize_t k = 0; k <= m; ++k) lp.push_back(layers.data() + k * h * w * 4);
        for (py::ssize_t k = 0; k < m; ++k) sp.push_back(solids.data() + k * h * w * 4);
        auto out = new_array({h, w, 4});
        float* dst = out.mutable_data();
        {
          py::gil_scoped_release release;
          composite_split(lp, sp, static_cast<int>(w), static_cast<int>(h), dst, threads);
        }
        return out;
      },
      py::arg("layers"), py::arg("solids"), py::arg("threads") = 0,
      "Harris 2002's split composite: layers farthest first, a solid image between each pair "
      "(depth test among solids, none for layers): one premultiplied (H, W, 4) layer.");
}

namespace {

// The camera as Python passes it: position, forward, right, up (float32 basis of
// cumuli.Camera.basis), tan_half, width, height, near.
SpriteCamera sprite_camera(const py::dict& d) {
  SpriteCamera c;
  c.position = vec3_arg(d["position"], "camera position");
  c.forward = vec3_arg(d["forward"], "camera forward");
  c.right = vec3_arg(d["right"], "camera right");
  c.up = vec3_arg(d["up"], "camera up");
  c.tan_half = d["tan_half"].cast<float>();
  c.width = d["width"].cast<int>();
  c.height = d["height"].cast<int>();
  c.near = d["near"].cast<float>();
  try {
    c.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  if (py::ssize_t{c.width} * c.height > kMaxPixels)
    throw py::value_error("image has more than " + std::to_string(kMaxPixels) + " pixels");
  return c;
}

using IntArray = py::array_t<std::int32_t, py::array::c_style | py::array::forcecast>;

std::vector<Sprite> sprites_of(const FloatArray& centres, const FloatArray& half_sizes,
                               const FloatArray& rotation, const FloatArray& colours,
                               const FloatArray& alpha, const IntArray& texture) {
  require_points(centres, "centres");
  const py::ssize_t n = centres.shape(0);
  if (half_sizes.ndim() != 2 || half_sizes.shape(0) != n || half_sizes.shape(1) != 2)
    throw py::value_error("half_sizes must have shape (N, 2)");
  if (colours.ndim() != 3 || colours.shape(0) != n || colours.shape(1) != 4 ||
      colours.shape(2) != 3)
    throw py::value_error("colours must have shape (N, 4, 3)");
  for (const auto* a : {&rotation, &alpha})
    if (a->ndim() != 1 || a->shape(0) != n)
      throw py::value_error("rotation and alpha must have shape (N,)");
  if (texture.ndim() != 1 || texture.shape(0) != n)
    throw py::value_error("texture must have shape (N,)");
  std::vector<Sprite> out(static_cast<std::size_t>(n));
  const float *c = centres.data(), *h = half_sizes.data(), *col = colours.data();
  for (py::ssize_t k = 0; k < n; ++k) {
    Sprite& s = out[static_cast<std::size_t>(k)];
    s.centre = glm::vec3(c[3 * k], c[3 * k + 1], c[3 * k + 2]);
    s.half_size = glm::vec2(h[2 * k], h[2 * k + 1]);
    s.rotation = rotation.data()[k];
    for (int v = 0; v < 4; ++v)
      s.colour[v] =
          glm::vec3(col[12 * k + 3 * v], col[12 * k + 3 * v + 1], col[12 * k + 3 * v + 2]);
    s.alpha = alpha.data()[k];
    s.texture = texture.data()[k];
  }
  return out;
}

// Impostor quads: images (a list of (h, w, 4) float32, or None for geometry only), planes (n, 14)
// = centre, forward, right, up, half_w, half_h, clamp (n,) booleans.
std::vector<ImpostorQuad> impostor_quads(const py::object& images, const FloatArray& planes,
                                         const py::handle& clamp) {
  if (planes.ndim() != 2 || planes.shape(1) != 14)
    throw py::value_error("planes must have shape (n, 14)");
  const py::ssize_t n = planes.shape(0);
  const auto flags = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(clamp);
  if (!flags || flags.ndim() != 1 || flags.shape(0) != n)
    throw py::value_error("clamp must be n booleans");
  std::vector<ImpostorQuad> quads(static_cast<std::size_t>(n));
  const bool geometry_only = images.is_none();
  py::list list;
  if (!geometry_only) {
    list = images.cast<py::list>();
    if (static_cast<py::ssize_t>(list.size()) != n)
      throw py::value_error("one image per impostor plane is needed");
  }
  for (py::ssize_t k = 0; k < n; ++k) {
    ImpostorQuad& q = quads[static_cast<std::size_t>(k)];
    const float* p = planes.data() + 14 * k;
    q.centre = glm::vec3(p[0], p[1], p[2]);
    q.forward = glm::vec3(p[3], p[4], p[5]);
    q.right = glm::vec3(p[6], p[7], p[8]);
    q.up = glm::vec3(p[9], p[10], p[11]);
    q.half_w = p[12];
    q.half_h = p[13];
    q.clamp = flags.data()[k];
    q.width = q.height = 1;
    if (!geometry_only) {
      const py::handle img = list[static_cast<std::size_t>(k)];
      if (!py::isinstance<FloatArray>(img))
        throw py::type_error("impostor images must be C-contiguous float32 arrays");
      const auto a = py::reinterpret_borrow<FloatArray>(img);
      if (a.ndim() != 3 || a.shape(2) != 4 || a.shape(0) < 1 || a.shape(1) < 1)
        throw py::value_error("impostor images must have shape (h, w, 4)");
      q.rgba = a.data();
      q.height = static_cast<int>(a.shape(0));
      q.width = static_cast<int>(a.shape(1));
      try {
        q.validate();
      } catch (const std::invalid_argument& e) {
        throw py::value_error("impostor " + std::to_string(k) + ": " + e.what());
      }
    }
  }
  return quads;
}

// --- billboard shading (Torchelsen spec §4.2) ---------------------------------------------------

std::vector<glm::vec3> rows3(const FloatArray& a, const char* name) {
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(name) + " must have shape (N, 3)");
  std::vector<glm::vec3> out(static_cast<std::size_t>(a.shape(0)));
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = glm::vec3(a.data()[3 * i], a.data()[3 * i + 1], a.data()[3 * i + 2]);
    if (!std::isfinite(out[i].x) || !std::isfinite(out[i].y) || !std::isfinite(out[i].z))
      throw py::value_error(std::string(name) + " must be finite");
  }
  return out;
}

// Lights and shading parameters from a dict: light_dirs (L, 3), light_radiance (L, 3),
// d_min, d_max, k_dir, directional, ambient, k_amb, height_levels [(f, h), ...].
std::pair<std::vector<ShadeLight>, ShadeParams> shade_of(const py::dict& d) {
  const std::vector<glm::vec3> dirs = rows3(d["light_dirs"].cast<FloatArray>(), "light_dirs");
  const std::vector<glm::vec3> rad =
      rows3(d["light_radiance"].cast<FloatArray>(), "light_radiance");
  if (dirs.size() != rad.size()) throw py::value_error("one radiance per light direction");
  std::vector<ShadeLight> lights(dirs.size());
  for (std::size_t l = 0; l < dirs.size(); ++l) {
    // Normalised as light.cpp's shade_inputs does, so the colours match billboard_vertex_colours.
    const float len = glm::length(dirs[l]);
    if (!(len > 0.0f)) throw py::value_error("light directions must be non-zero");
    lights[l] = ShadeLight{dirs[l] / len, rad[l]};
  }
  ShadeParams p;
  p.d_min = d["d_min"].cast<float>();
  p.d_max = d["d_max"].cast<float>();
  p.k_dir = d["k_dir"].cast<float>();
  const std::string dir = d["directional"].cast<std::string>();
  if (dir == "linear")
    p.directional = Directional::Linear;
  else if (dir == "smoothstep")
    p.directional = Directional::Smoothstep;
  else
    throw py::value_error("directional must be 'linear' or 'smoothstep'");
  const auto amb = d["ambient"].cast<std::array<float, 3>>();
  p.ambient = glm::vec3(amb[0], amb[1], amb[2]);
  p.k_amb = d["k_amb"].cast<float>();
  for (const auto& h : d["height_levels"].cast<std::vector<std::array<float, 2>>>())
    p.height_levels.emplace_back(h[0], h[1]);
  try {
    p.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return {lights, p};
}

// Keeps the numpy arrays a BillboardVariant borrows alive.
struct VariantArrays {
  FloatArray centres, sizes, rotation;
  IntArray texture, box;
};

glm::dvec3 dvec(const std::array<double, 3>& a) { return glm::dvec3(a[0], a[1], a[2]); }
py::tuple dtuple(glm::dvec3 v) { return py::make_tuple(v.x, v.y, v.z); }

}  // namespace

// The shared sprite pipeline's CPU twin (render/sprite_raster.hpp): sprites and Harris particles.
void bind_sprites(py::module_& m) {
  m.def(
      "rasterise_sprites",
      [](const FloatArray& centres, const FloatArray& half_sizes, const FloatArray& rotation,
         const FloatArray& colours, const FloatArray& alpha, const IntArray& texture,
         const py::dict& camera, const SpriteRasterSettings& settings, const py::object& atlas,
         int threads, const py::object& shading, const py::object& depth) {
        const std::vector<Sprite> sprites =
            sprites_of(centres, half_sizes, rotation, colours, alpha, texture);
        // Fragment shading (billboards, spec §4.2): per sprite frame (N, 4), yrange (N, 2),
        // caf (N, L), plus the lights and parameters of shade_of.
        SpriteShading sh;
        FloatArray sh_frame, sh_yrange, sh_caf;
        const SpriteShading* sh_ptr = nullptr;
        if (!shading.is_none()) {
          const py::dict d = shading.cast<py::dict>();
          std::tie(sh.lights, sh.params) = shade_of(d);
          sh_frame = d["frame"].cast<FloatArray>();
          sh_yrange = d["yrange"].cast<FloatArray>();
          sh_caf = d["caf"].cast<FloatArray>();
          const auto n = static_cast<py::ssize_t>(sprites.size());
          const auto nl = static_cast<py::ssize_t>(sh.lights.size());
          if (sh_frame.ndim() != 2 || sh_frame.shape(0) != n || sh_frame.shape(1) != 4 ||
              sh_yrange.ndim() != 2 || sh_yrange.shape(0) != n || sh_yrange.shape(1) != 2 ||
              sh_caf.ndim() != 2 || sh_caf.shape(0) != n || sh_caf.shape(1) != nl)
            throw py::value_error("shading needs frame (N, 4), yrange (N, 2) and caf (N, L)");
          sh.frame = reinterpret_cast<const glm::vec4*>(sh_frame.data());
          sh.yrange = reinterpret_cast<const glm::vec2*>(sh_yrange.data());
          sh.caf = sh_caf.data();
          sh_ptr = &sh;
        }
        const SpriteCamera cam = sprite_camera(camera);
        FloatArray depth_array;
        const float* depth_ptr = nullptr;
        if (!depth.is_none()) {
          depth_array = depth.cast<FloatArray>();
          if (depth_array.ndim() != 2 || depth_array.shape(0) != cam.height ||
              depth_array.shape(1) != cam.width)
            throw py::value_error("depth must have shape (H, W) like the image");
          depth_ptr = depth_array.data();
        }
        const SpriteRasterSettings& st = settings;
        FloatArray atlas_array;
        SpriteAtlas at;
        const SpriteAtlas* atlas_ptr = nullptr;
        if (!atlas.is_none()) {
          const py::tuple atlas_grid = atlas.cast<py::tuple>();
          if (atlas_grid.size() != 2)
            throw py::value_error("atlas must be None or (rgba (H, W, 4), (nx, ny))");
          atlas_array = atlas_grid[0].cast<FloatArray>();
          const auto grid = atlas_grid[1].cast<std::array<int, 2>>();
          if (atlas_array.ndim() != 3 || atlas_array.shape(2) != 4)
            throw py::value_error("atlas must have shape (H, W, 4)");
          at.rgba = atlas_array.data();
          at.height = static_cast<int>(atlas_array.shape(0));
          at.width = static_cast<int>(atlas_array.shape(1));
          at.nx = grid[0];
          at.ny = grid[1];
          atlas_ptr = &at;
        }
        auto out = new_array({cam.height, cam.width, 4});
        float* dst = out.mutable_data();
        {
          py::gil_scoped_release release;
          rasterise_sprites(sprites, cam, st, atlas_ptr, dst, threads, sh_ptr, depth_ptr);
        }
        return out;
      },
      py::arg("centres"), py::arg("half_sizes"), py::arg("rotation"), py::arg("colours"),
      py::arg("alpha"), py::arg("texture"), py::arg("camera"), py::arg("settings"),
      py::arg("atlas").none(true), py::arg("threads") = 0, py::arg("shading") = py::none(),
      py::arg("depth") = py::none(),
      "Rasterise view-plane-parallel sprites back to front into a premultiplied (H, W, 4) layer; "
      "settings: a SpriteRasterSettings (kernel, peak); atlas: None or (rgba (H, W, 4), (nx, ny)); "
      "shading: per-pixel billboard shading; depth (H, W): a sprite covers only pixels where its "
      "view depth is smaller.");

  m.def(
      "project_sprites",
      [](const FloatArray& centres, const FloatArray& half_sizes, const FloatArray& rotation,
         const py::dict& camera) {
        require_points(centres, "centres");
        const py::ssize_t n = centres.shape(0);
        auto zeros_c = new_array({n, 4, 3});
        std::fill(zeros_c.mutable_data(), zeros_c.mutable_data() + zeros_c.size(), 0.0f);
        py::array_t<float> ones(n);
        std::fill(ones.mutable_data(), ones.mutable_data() + n, 1.0f);
        IntArray tex(n);
        std::fill(tex.mutable_data(), tex.mutable_data() + n, -1);
        const std::vector<Sprite> sprites =
            sprites_of(centres, half_sizes, rotation, zeros_c, ones, tex);
        const SpriteCamera cam = sprite_camera(camera);
        auto out = new_array({n, 6});
        float* o = out.mutable_data();
        for (py::ssize_t k = 0; k < n; ++k) {
          const ScreenSprite q = project_sprite(sprites[static_cast<std::size_t>(k)], cam);
          const float row[6] = {q.jc, q.ic, q.hx, q.hy, q.depth, q.visible ? 1.0f : 0.0f};
          std::copy(row, row + 6, o + 6 * k);
        }
        return out;
      },
      "Screen projection of sprites: (N, 6) = j_c, i_c, hx, hy (pixels), depth Z, visible.");

  m.def(
      "particle_sprites",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& tau,
         const FloatArray& albedo, const FloatArray& light, const FloatArray& directions,
         const FloatArray& radiances, const py::dict& camera,
         const ParticleSpriteSettings& settings) {
        const ParticleView v = particle_view(centres, radii, tau, albedo);
        const auto n = static_cast<py::ssize_t>(v.n);
        if (directions.ndim() != 2 || directions.shape(1) != 3 || radiances.ndim() != 2 ||
            radiances.shape(1) != 3 || radiances.shape(0) != directions.shape(0))
          throw py::value_error("light directions and radiances must have shape (L, 3)");
        const py::ssize_t nl = directions.shape(0);
        if (light.ndim() != 2 || light.shape(0) != n || light.shape(1) != nl)
          throw py::value_error("light must have shape (N, L) matching the particles and lights");
        std::vector<SpriteLight> lights(static_cast<std::size_t>(nl));
        for (py::ssize_t l = 0; l < nl; ++l) {
          const float* d = directions.data() + 3 * l;
          const float* r = radiances.data() + 3 * l;
          const glm::vec3 dir(d[0], d[1], d[2]);
          if (!(glm::length(dir) > 0.0f) || !std::isfinite(glm::length(dir)))
            throw py::value_error("light directions must be finite and non-zero");
          lights[static_cast<std::size_t>(l)] = {glm::normalize(dir), glm::vec3(r[0], r[1], r[2])};
        }
        const ParticleSpriteSettings& s = settings;
        const SpriteCamera cam = sprite_camera(camera);
        ParticleSpriteList list;
        {
          py::gil_scoped_release release;
          list = particle_sprites(v, light.data(), lights, cam, s);
        }
        const auto m_ = static_cast<py::ssize_t>(list.index.size());
        py::array_t<std::int64_t> index(m_);
        auto colour = new_array({m_, 3});
        auto alpha = new_array({m_});
        auto key = new_array({m_});
        for (py::ssize_t i = 0; i < m_; ++i) {
          index.mutable_data()[i] = list.index[static_cast<std::size_t>(i)];
          key.mutable_data()[i] = list.key[static_cast<std::size_t>(i)];
          for (int a = 0; a < 3; ++a)
            colour.mutable_data()[3 * i + a] = list.colour[static_cast<std::size_t>(i)][a];
          alpha.mutable_data()[i] = list.alpha[static_cast<std::size_t>(i)];
        }
        return py::make_tuple(index, colour, alpha, key);
      },
      py::arg("centres"), py::arg("radii"), py::arg("tau"), py::arg("albedo"), py::arg("light"),
      py::arg("directions"), py::arg("radiances"), py::arg("camera"), py::arg("settings"),
      "Eye pass sprites of a particle cloud (settings: a ParticleSpriteSettings): (index back to "
      "front, colours (M, 3), alpha (M,), "
      "sort keys (M,)).");

  m.def(
      "sphere_outside_frustum",
      [](V3 centre, float radius, const py::dict& camera) {
        return sphere_outside_frustum(v3(centre), radius, sprite_camera(camera));
      },
      "Whether a sphere lies wholly outside the camera frustum (conservative).");
}

// Impostor mathematics of Harris 2002 §3 (render/impostor.hpp).
void bind_impostors(py::module_& m) {
  m.def(
      "tight_impostor_view",
      [](std::array<double, 3> eye, std::array<double, 3> centre, double radius) {
        const ImpostorView v = tight_impostor_view(dvec(eye), dvec(centre), radius);
        py::dict d;
        d["distance"] = v.distance;
        d["half_angle"] = v.half_angle;
        d["fov"] = v.fov_degrees;
        d["half_size"] = v.half_size;
        d["forward"] = dtuple(v.forward);
        d["right"] = dtuple(v.right);
        d["up"] = dtuple(v.up);
        d["near_point"] = dtuple(v.near_point);
        d["far_point"] = dtuple(v.far_point);
        return d;
      },
      "The tight impostor camera of a bounding sphere seen from an eye (dict).");
  m.def(
      "impostor_translation_error",
      [](std::array<double, 3> n, std::array<double, 3> f, std::array<double, 3> e) {
        return translation_error(dvec(n), dvec(f), dvec(e));
      },
      "α_trans (radians): the angle at the eye between the near and far points.");
  m.def(
      "impostor_backwards",
      [](std::array<double, 3> n, std::array<double, 3> f, std::array<double, 3> e) {
        return impostor_backwards(dvec(n), dvec(f), dvec(e));
      },
      "Whether the eye is nearer the far point than the near point.");
  m.def("impostor_focal_length_px", &focal_length_px, "f_px = (H/2)/tan(fov/2).");
  m.def("impostor_required_resolution", &required_resolution, "res_req = res_scale·f_px·2R/d.");
  m.def("impostor_resolution", &impostor_resolution,
        "min(max_res, max(min_res, pow2ceil(res_req))).");
  m.def("impostor_resolution_skyworks", &impostor_resolution_skyworks,
        "SkyWorks' impostor resolution rule.");
  m.def("impostor_near_corner_radius", &near_corner_radius, "near·√(1 + th²(1 + aspect²)).");
  m.def("impostor_half_diagonal_fov", &half_diagonal_fov, "atan(th·√(1 + aspect²)), radians.");
  m.def(
      "needs_screen_impostor",
      [](std::array<double, 3> eye, std::array<double, 3> centre, double radius, double th,
         double aspect, double near) {
        return needs_screen_impostor(dvec(eye), dvec(centre), radius, th, aspect, near);
      },
      "Whether the sphere must be drawn through a screen impostor from the eye.");
  m.def("screen_impostor_size", &screen_impostor_size, "⌈size/factor⌉.");

  m.def(
      "display_impostors",
      [](const py::list& images, const FloatArray& planes, const py::handle& clamp,
         const py::handle& camera_position, const py::handle& camera_target,
         const py::handle& camera_up, float fov, int width, int height, int threads) {
        const std::vector<ImpostorQuad> quads = impostor_quads(images, planes, clamp);
        if (width < 1 || height < 1 || width > kMaxEdge || height > kMaxEdge ||
            py::ssize_t{width} * height > kMaxPixels)
          throw py::value_error("width and height must be in [1, 32768] (at most 2^26 pixels)");
        if (threads < 0 || threads > 1024) throw py::value_error("threads must be in [0, 1024]");
        const CameraParams cam = camera_params(camera_position, camera_target, camera_up, fov);
        auto out = new_array({height, width, 4});
        float* dst = out.mutable_data();
        {
          py::gil_scoped_release release;
          display_impostors(quads, cam, width, height, dst, threads);
        }
        return out;
      },
      py::arg("images"), py::arg("planes"), py::arg("clamp"), py::arg("camera_position"),
      py::arg("camera_target"), py::arg("camera_up"), py::arg("fov"), py::arg("width"),
      py::arg("height"), py::arg("threads") = 0,
      "Impostors drawn back to front (exact bilinear): images (h, w, 4) "
      "premultiplied, planes (n, 14) = centre, forward, right, up, half_w, half_h; clamp (n,) "
      "bool. An (H, W, 4) premultiplied layer, row 0 on top.");

  m.def(
      "impostor_rects",
      [](const FloatArray& planes, const py::handle& clamp, const py::handle& camera_position,
         const py::handle& camera_target, const py::handle& camera_up, float fov, int width,
         int height) {
        const py::ssize_t n = planes.ndim() == 2 ? planes.shape(0) : 0;
        static const float one_texel[4] = {0.0f, 0.0f, 0.0f, 0.0f};
        std::vector<ImpostorQuad> quads = impostor_quads(py::none(), planes, clamp);
        const CameraParams cam = camera_params(camera_position, camera_target, camera_up, fov);
        if (width < 1 || height < 1 || width > kMaxEdge || height > kMaxEdge)
          throw py::value_error("width and height must be in [1, 32768]");
        const CameraRays rays(cam, width, height);
        py::array_t<std::int32_t> out({n, py::ssize_t{4}});
        for (py::ssize_t k = 0; k < n; ++k) {
          quads[static_cast<std::size_t>(k)].rgba = one_texel;
          const PixelRect r = impostor_rect(quads[static_cast<std::size_t>(k)], rays);
          std::int32_t* o = out.mutable_data() + 4 * k;
          o[0] = r.j0;
          o[1] = r.j1;
          o[2] = r.i0;
          o[3] = r.i1;
        }
        return out;
      },
      "Conservative pixel rectangles (n, 4) = j0, j1, i0, i1 (inclusive) of impostor quads.");
}

// Billboard clouds as sprites (Torchelsen & Musse 2005; rendering/billboards.hpp).
void bind_billboards(py::module_& m) {
  m.def(
      "billboard_sprites",
      [](const py::list& variants, const IntArray& variant, const FloatArray& offsets,
         const FloatArray& yaw, const FloatArray& alpha,
         const py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>& caf_first,
         const FloatArray& caf, const py::dict& shade, const py::dict& camera, const py::dict& draw,
         int threads) {
        const auto [lights, params] = shade_of(shade);
        const SpriteCamera cam = sprite_camera(camera);
        std::vector<VariantArrays> keep(variants.size());
        std::vector<BillboardVariant> vs(variants.size());
        for (std::size_t v = 0; v < vs.size(); ++v) {
          const py::dict d = variants[v].cast<py::dict>();
          VariantArrays& a = keep[v];
          a.centres = d["centres"].cast<FloatArray>();
          a.sizes = d["sizes"].cast<FloatArray>();
          a.rotation = d["rotation"].cast<FloatArray>();
          a.texture = d["texture"].cast<IntArray>();
          a.box = d["box"].cast<IntArray>();
          const FloatArray boxes = d["boxes"].cast<FloatArray>();
          require_points(a.centres, "variant centres");
          const py::ssize_t k = a.centres.shape(0);
          if (a.sizes.ndim() != 2 || a.sizes.shape(0) != k || a.sizes.shape(1) != 2 ||
              a.rotation.ndim() != 1 || a.rotation.shape(0) != k || a.texture.ndim() != 1 ||
              a.texture.shape(0) != k || a.box.ndim() != 1 || a.box.shape(0) != k)
            throw py::value_error("variant arrays must have K rows");
          if (boxes.ndim() != 3 || boxes.shape(0) < 1 || boxes.shape(1) != 2 || boxes.shape(2) != 3)
            throw py::value_error("variant boxes must have shape (M, 2, 3)");
          std::vector<Box> b(static_cast<std::size_t>(boxes.shape(0)));
          for (std::size_t i = 0; i < b.size(); ++i) {
            const float* r = boxes.data() + 6 * i;
            b[i].lo = glm::vec3(r[0], r[1], r[2]);
            b[i].hi = glm::vec3(r[3], r[4], r[5]);
          }
          BillboardVariant& bv = vs[v];
          bv.centres = reinterpret_cast<const glm::vec3*>(a.centres.data());
          bv.sizes = reinterpret_cast<const glm::vec2*>(a.sizes.data());
          bv.rotation = a.rotation.data();
          bv.texture = a.texture.data();
          bv.box = a.box.data();
          bv.billboards = static_cast<std::size_t>(k);
          bv.boxes = b.size();
          bv.frame = shade_frame(b);
          const auto sc = d["sphere_centre"].cast<std::array<float, 3>>();
          bv.sphere_centre = glm::vec3(sc[0], sc[1], sc[2]);
          bv.sphere_radius = d["sphere_radius"].cast<float>();
          bv.opacity = d["opacity"].cast<float>();
          bv.texture_base = d["texture_base"].cast<std::int32_t>();
        }
        require_points(offsets, "offsets");
        const py::ssize_t ni = offsets.shape(0);
        for (const py::array* a :
             {static_cast<const py::array*>(&variant), static_cast<const py::array*>(&yaw),
              static_cast<const py::array*>(&alpha), static_cast<const py::array*>(&caf_first)})
          if (a->ndim() != 1 || a->shape(0) != ni)
            throw py::value_error("variant, yaw, alpha and caf_first must have shape (N,)");
        if (caf.ndim() != 2 || caf.shape(0) != static_cast<py::ssize_t>(lights.size()))
          throw py::value_error("caf must have shape (lights, columns)");
        std::vector<BillboardInstance> inst(static_cast<std::size_t>(ni));
        for (py::ssize_t i = 0; i < ni; ++i) {
          BillboardInstance& in = inst[static_cast<std::size_t>(i)];
          in.variant = variant.data()[i];
          const float* o = offsets.data() + 3 * i;
          in.offset = glm::vec3(o[0], o[1], o[2]);
          in.yaw = yaw.data()[i];
          in.alpha = alpha.data()[i];
          if (caf_first.data()[i] < 0) throw py::value_error("caf_first must be >= 0");
          in.caf_first = static_cast<std::size_t>(caf_first.data()[i]);
        }
        BillboardDrawSettings st;
        st.caf_per_box = draw["caf_per_box"].cast<bool>();
        st.global_sort = draw["global_sort"].cast<bool>();
        const std::string sort = draw["sort"].cast<std::string>();
        if (sort == "distance")
          st.sort = SpriteSort::Distance;
        else if (sort == "depth")
          st.sort = SpriteSort::Depth;
        else
          throw py::value_error("sort must be 'distance' or 'depth'");
        st.cull = draw["cull"].cast<bool>();
        if (!draw["fade_near"].is_none()) {
          const auto z = draw["fade_near"].cast<std::array<float, 2>>();
          st.fade_near = true;
          st.near_start = z[0];
          st.near_end = z[1];
        }
        if (!draw["fade_far"].is_none()) {
          st.fade_far = true;
          st.range = draw["fade_far"].cast<float>();
        }
        st.fragment = draw["fragment"].cast<bool>();
        BillboardSpriteList list;
        {
          py::gil_scoped_release release;
          try {
            list = billboard_sprites(vs, inst, caf.data(), static_cast<std::size_t>(caf.shape(1)),
                                     lights, params, cam, st, threads);
          } catch (const std::invalid_argument& e) {
            py::gil_scoped_acquire acquire;
            throw py::value_error(e.what());
          }
        }
        const auto n = static_cast<py::ssize_t>(list.centre.size());
        const auto nl = static_cast<py::ssize_t>(lights.size());
        auto as_floats = [](const float* p, std::vector<py::ssize_t> shape) {
          py::array_t<float> a(shape);
          std::copy(p, p + a.size(), a.mutable_data());
          return a;
        };
        py::dict out;
        out["centres"] = as_floats(reinterpret_cast<const float*>(list.centre.data()), {n, 3});
        out["half_sizes"] = as_floats(reinterpret_cast<const float*>(list.half.data()), {n, 2});
        out["rotation"] = as_floats(list.rotation.data(), {n});
        out["alpha"] = as_floats(list.alpha.data(), {n});
        out["colours"] = as_floats(list.colour.data(), {n, 4, 3});
        py::array_t<std::int32_t> tex(n), inst_out(n), bb(n);
        for (py::ssize_t i = 0; i < n; ++i) {
          tex.mutable_data()[i] = list.texture[static_cast<std::size_t>(i)];
          inst_out.mutable_data()[i] =
              static_cast<std::int32_t>(list.instance[static_cast<std::size_t>(i)]);
          bb.mutable_data()[i] =
              static_cast<std::int32_t>(list.billboard[static_cast<std::size_t>(i)]);
        }
        out["texture"] = tex;
        out["instance"] = inst_out;
        out["billboard"] = bb;
        if (st.fragment) {
          out["frame"] = as_floats(reinterpret_cast<const float*>(list.frame.data()), {n, 4});
          out["yrange"] = as_floats(reinterpret_cast<const float*>(list.yrange.data()), {n, 2});
          out["caf"] = as_floats(list.caf.data(), {n, nl});
        }
        return out;
      },
      py::arg("variants"), py::arg("variant"), py::arg("offsets"), py::arg("yaw"), py::arg("alpha"),
      py::arg("caf_first"), py::arg("caf"), py::arg("shade"), py::arg("camera"), py::arg("draw"),
      py::arg("threads") = 0,
      "The sprites of billboard clouds for a camera: culled, faded, sorted back to front and "
      "shaded (vertex colours, or per-sprite fragment-shading data): a dict of arrays.");
}

}  // namespace cumuli::bind
