// Bindings of the render stage's CPU twins (python/cumuli/rendering): the reference marcher of the
// 2018 paper (render/march.hpp, `render_cpu`) and the volume marcher (render/volume_march.hpp).
#include "cumuli/rendering/march.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "common.hpp"
#include "cumuli/rendering/composite.hpp"
#include "cumuli/rendering/volume_march.hpp"

namespace cumuli::bind {

namespace {

// Largest image the CPU marcher accepts (pixels), checked before allocating.
constexpr py::ssize_t kMaxPixels = py::ssize_t{1} << 26;
constexpr int kMaxEdge = 1 << 15;

glm::vec3 vec3_arg(const py::handle& value, const char* name) {
  FloatArray a;
  try {
    a = FloatArray::ensure(value);
  } catch (...) {
    a = FloatArray();
  }
  if (!a || a.ndim() != 1 || a.shape(0) != 3)
    throw py::value_error(std::string(name) + " must be a sequence of three numbers");
  const float* d = a.data();
  const glm::vec3 v(d[0], d[1], d[2]);
  if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
    throw py::value_error(std::string(name) + " must be finite");
  return v;
}

float finite(float v, const char* name) {
  if (!std::isfinite(v)) throw py::value_error(std::string(name) + " must be finite");
  return v;
}

py::object item(const py::dict& d, const char* key, std::size_t index) {
  if (!d.contains(key))
    throw py::value_error("clouds[" + std::to_string(index) + "] is missing '" + key + "'");
  return d[key];
}

// One cloud from a dict: centres, radii, rotations, model, kappa, phi, light [z, y, x],
// light_lo, light_hi.
RenderCloud cloud_from_dict(const py::handle& h, std::size_t index) {
  if (!py::isinstance<py::dict>(h))
    throw py::type_error("clouds[" + std::to_string(index) + "] must be a dict");
  const py::dict d = py::reinterpret_borrow<py::dict>(h);
  const std::string at = "clouds[" + std::to_string(index) + "].";
  RenderCloud rc;
  try {
    rc.shape = cloud_from_arrays(item(d, "centres", index).cast<FloatArray>(),
                                 item(d, "radii", index).cast<FloatArray>(),
                                 item(d, "rotations", index).cast<FloatArray>(),
                                 item(d, "model", index).cast<std::string>(),
                                 item(d, "kappa", index).cast<float>(),
                                 item(d, "phi", index).cast<float>());
  } catch (const std::invalid_argument& e) {
    throw py::value_error(at + e.what());
  }
  if (d.contains("physical") && !d["physical"].is_none()) {
    try {
      rc.physical = physical_grids_of(d["physical"]);
    } catch (const py::value_error& e) {
      throw py::value_error(at + e.what());
    }
    return rc;
  }
  const FloatArray light = item(d, "light", index).cast<FloatArray>();
  if (light.ndim() != 3 || light.shape(0) < 1 || light.shape(1) < 1 || light.shape(2) < 1)
    throw py::value_error(at + "light must be a non-empty (D, H, W) array indexed [z, y, x]");
  if (light.size() > (py::ssize_t{1} << 27))
    throw py::value_error(at + "light grid is too large");
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

MarchMode march_mode(const std::string& s) {
  if (s == "paper") return MarchMode::Paper;
  if (s == "union") return MarchMode::Union;
  throw py::value_error("march must be 'paper' or 'union', got '" + s + "'");
}

}  // namespace

void bind_march(py::module_& m) {
  m.def(
      "render_cpu",
      [](const py::handle& camera_position, const py::handle& camera_target,
         const py::handle& camera_up, float fov, int width, int height, const py::list& clouds,
         const py::handle& sun_direction, const py::handle& sun_radiance,
         const py::handle& sky_zenith, const py::handle& sky_horizon, const py::handle& sky_ground,
         float sky_exponent, float sun_disc_radius, float sun_disc_intensity, float absorption,
         float lod_a, float lod_delta, float ref_step, float step_min, float step_max,
         float fixed_step, float hg_g, int max_steps, int max_candidates, const std::string& march,
         int octaves, float gain, float lacunarity, float frequency, const Noise* noise,
         int threads, float density_constant, bool sort_candidates, bool with_sky,
         const py::object& physical, const py::object& ground) {
        if (width < 1 || height < 1 || width > kMaxEdge || height > kMaxEdge)
          throw py::value_error("width and height must be in [1, " + std::to_string(kMaxEdge) +
                                "], got " + std::to_string(width) + "x" + std::to_string(height));
        if (py::ssize_t{width} * height > kMaxPixels)
          throw py::value_error("image has more than " + std::to_string(kMaxPixels) + " pixels");
        if (threads < 0 || threads > 1024) throw py::value_error("threads must be in [0, 1024]");

        CameraParams cam;
        cam.position = vec3_arg(camera_position, "camera position");
        cam.target = vec3_arg(camera_target, "camera target");
        cam.up = vec3_arg(camera_up, "camera up");
        cam.fov = finite(fov, "fov");

        MarchSettings s;
        s.absorption = absorption;
        s.lod_a = lod_a;
        s.lod_delta = lod_delta;
        s.ref_step = ref_step;
        s.step_min = step_min;
        s.step_max = step_max;
        s.fixed_step = fixed_step;
        s.hg_g = hg_g;
        s.max_steps = max_steps;
        s.max_candidates = max_candidates;
        s.march = march_mode(march);
        s.sort_candidates = sort_candidates;
        s.fbm = FbmParams{octaves, gain, lacunarity, frequency};
        s.density_constant = density_constant;
        if (!physical.is_none()) {
          s.physical = true;
          s.phys = physical_of(physical.cast<py::dict>());
        }

        MarchScene scene;
        const glm::vec3 sd = vec3_arg(sun_direction, "sun direction");
        if (!(glm::dot(sd, sd) > 0.0f)) throw py::value_error("sun direction must not be zero");
        scene.sun.direction = glm::normalize(sd);
        scene.sun.radiance = vec3_arg(sun_radiance, "sun radiance");
        scene.sky.zenith = vec3_arg(sky_zenith, "sky zenith");
        scene.sky.horizon = vec3_arg(sky_horizon, "sky horizon");
        scene.sky.ground = vec3_arg(sky_ground, "sky ground");
        scene.sky.exponent = sky_exponent;
        scene.sky.sun_disc_radius = sun_disc_radius;
        scene.sky.sun_disc_intensity = sun_disc_intensity;
        scene.noise = noise;
        scene.with_sky = with_sky;
        scene.ground = ground_of(ground);
        scene.clouds.reserve(clouds.size());
        for (std::size_t i = 0; i < clouds.size(); ++i)
          scene.clouds.push_back(cloud_from_dict(clouds[i], i));

        try {
          s.validate();
          cam.validate();
          scene.validate(s);
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }

        auto out = new_array({height, width, 4});
        float* dst = out.mutable_data();
        {
          py::gil_scoped_release release;
          render_image(scene, s, cam, width, height, dst, threads);
        }
        return out;
      },
      py::arg("camera_position"), py::arg("camera_target"), py::arg("camera_up"), py::arg("fov"),
      py::arg("width"), py::arg("height"), py::arg("clouds"), py::arg("sun_direction"),
      py::arg("sun_radiance"), py::arg("sky_zenith"), py::arg("sky_horizon"),
      py::arg("sky_ground"), py::arg("sky_exponent"), py::arg("sun_disc_radius"),
      py::arg("sun_disc_intensity"), py::arg("absorption"), py::arg("lod_a"),
      py::arg("lod_delta"), py::arg("ref_step"), py::arg("step_min"), py::arg("step_max"),
      py::arg("fixed_step"), py::arg("hg_g"), py::arg("max_steps"), py::arg("max_candidates"),
      py::arg("march"), py::arg("octaves"), py::arg("gain"), py::arg("lacunarity"),
      py::arg("frequency"), py::arg("noise").none(true), py::arg("threads") = 0,
      py::arg("density_constant") = -1.0f, py::arg("sort_candidates") = true, py::arg("with_sky") = true,
      py::arg("physical") = py::none(), py::arg("ground") = py::none(),
      "CPU reference ray marcher (RENDER_CONTRACT): an (H, W, 4) float32 RGBA image, row 0 at "
      "the top. Each cloud is a dict with centres, radii, rotations, model, kappa, phi, light "
      "([z, y, x]) and light_lo / light_hi. density_constant >= 0 replaces fBm (tests); sort_candidates=False leaves candidates "
      "unsorted (candidate_sort='none'); with_sky=False gives the premultiplied layer (colour, 1 − T).");
}

void bind_volume_march(py::module_& m) {
  m.def(
      "render_volume_cpu",
      [](const FloatArray& density, const FloatArray& light, V3 lo, V3 hi, V3 position, V3 forward,
         V3 right, V3 up, float tan_half_fov, int width, int height, V3 sun_dir, V3 sun_radiance,
         const py::tuple& sky, float sigma_t, float albedo, float g, float step, int threads, bool with_sky,
         const py::object& physical, const py::object& physical_light) {
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
        p.with_sky = with_sky;
        PhysicalGrids grids;
        if (!physical.is_none()) {
          p.physical = true;
          p.phys = physical_of(physical.cast<py::dict>());
          grids = physical_grids_of(physical_light);
          p.grids = &grids;
        }
        const float *pd = density.data(), *pl = light.data();
        std::vector<float> img;
        {
          py::gil_scoped_release release;
          img = render_volume_cpu(pd, pl, grid, cam, p, threads);
        }
        return to_array(img, {height, width, 4});
      },
      py::arg("density"), py::arg("light"), py::arg("lo"), py::arg("hi"), py::arg("position"),
      py::arg("forward"), py::arg("right"), py::arg("up"), py::arg("tan_half_fov"),
      py::arg("width"), py::arg("height"), py::arg("sun_dir"), py::arg("sun_radiance"),
      py::arg("sky"), py::arg("sigma_t"), py::arg("albedo"), py::arg("g"), py::arg("step"),
      py::arg("threads"), py::arg("with_sky"), py::arg("physical") = py::none(),
      py::arg("physical_light") = py::none(),
      "CPU emission–absorption march of a lit density volume: (H, W, 4) float32, row 0 on top.");
}

void bind_composite(py::module_& m) {
  m.def(
      "composite_layers",
      [](const FloatArray& layers, const FloatArray& boxes, const py::handle& camera_position,
         const py::handle& camera_target, const py::handle& camera_up, float fov,
         const py::tuple& sky, const py::handle& sun_direction, const py::handle& sun_radiance,
         int threads, const py::object& ground) {
        if (layers.ndim() != 4 || layers.shape(3) != 4)
          throw py::value_error("layers must have shape (L, H, W, 4)");
        const py::ssize_t n = layers.shape(0), height = layers.shape(1), width = layers.shape(2);
        if (height < 1 || width < 1 || height > kMaxEdge || width > kMaxEdge)
          throw py::value_error("layers: image edges must be in [1, " + std::to_string(kMaxEdge) + "]");
        if (boxes.ndim() != 3 || boxes.shape(0) != n || boxes.shape(1) != 2 || boxes.shape(2) != 3)
          throw py::value_error("boxes must have shape (L, 2, 3), one (lo, hi) per layer");
        if (threads < 0 || threads > 1024) throw py::value_error("threads must be in [0, 1024]");
        CameraParams cam;
        cam.position = vec3_arg(camera_position, "camera position");
        cam.target = vec3_arg(camera_target, "camera target");
        cam.up = vec3_arg(camera_up, "camera up");
        cam.fov = finite(fov, "fov");
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
        try {
          cam.validate();
        } catch (const std::invalid_argument& e) {
          throw py::value_error(e.what());
        }
        auto out = new_array({height, width, 4});
        float* dst = out.mutable_data();
        {
          py::gil_scoped_release release;
          composite_layers(list, cam, static_cast<int>(width), static_cast<int>(height), sk, sun,
                           gp, dst, threads);
        }
        return out;
      },
      py::arg("layers"), py::arg("boxes"), py::arg("camera_position"), py::arg("camera_target"),
      py::arg("camera_up"), py::arg("fov"), py::arg("sky"), py::arg("sun_direction"),
      py::arg("sun_radiance"), py::arg("threads") = 0, py::arg("ground") = py::none(),
      "Composite premultiplied layers (L, H, W, 4) over the sky, front to back per pixel by the "
      "ray's entry into each layer's box (L, 2, 3): an (H, W, 4) float32 image, row 0 on top.");
}

}  // namespace cumuli::bind
