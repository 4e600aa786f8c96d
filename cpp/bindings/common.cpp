#include "common.hpp"

#include <cmath>
#include <stdexcept>

namespace cumuli::bind {

glm::vec3 noise_offset_arg(const py::handle& value) {
  if (value.is_none()) return glm::vec3(0.0f);
  return vec3_arg(value, "noise_offset");
}

CloudShape cloud_from_arrays(const FloatArray& centres, const FloatArray& radii,
                             const FloatArray& rotations, const std::string& model, float kappa,
                             float phi, glm::vec3 noise_offset) {
  require_points(centres, "centres");
  require_points(radii, "radii");
  const py::ssize_t n = centres.shape(0);
  if (radii.shape(0) != n) throw py::value_error("radii must have the same length as centres");
  if (rotations.ndim() != 3 || rotations.shape(0) != n || rotations.shape(1) != 3 ||
      rotations.shape(2) != 3)
    throw py::value_error("rotations must have shape (N, 3, 3)");
  CloudShape cloud;
  if (model == "spheroid") {
    cloud.density.model = DensityModel::Spheroid;
  } else if (model == "metaball") {
    cloud.density.model = DensityModel::Metaball;
  } else {
    throw py::value_error("density model must be 'spheroid' or 'metaball', got '" + model + "'");
  }
  cloud.density.kappa = kappa;
  cloud.density.phi = phi;
  if (!(std::isfinite(noise_offset.x) && std::isfinite(noise_offset.y) &&
        std::isfinite(noise_offset.z)))
    throw py::value_error("noise_offset must be finite");
  cloud.noise_offset = noise_offset;
  cloud.primitives.resize(static_cast<std::size_t>(n));
  const float* c = centres.data();
  const float* r = radii.data();
  const float* m = rotations.data();
  for (py::ssize_t i = 0; i < n; ++i) {
    Ellipsoid& e = cloud.primitives[static_cast<std::size_t>(i)];
    e.centre = glm::vec3(c[3 * i], c[3 * i + 1], c[3 * i + 2]);
    e.radii = glm::vec3(r[3 * i], r[3 * i + 1], r[3 * i + 2]);
    // numpy row-major R[row][col]; glm is column-major: rotation[col][row].
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) e.rotation[col][row] = m[9 * i + 3 * row + col];
  }
  cloud.validate();
  cloud.density.mean_r2 = cloud.mean_squared_radius();
  return cloud;
}

ParticleView particle_view(const FloatArray& centres, const FloatArray& radii,
                           const FloatArray& tau, const FloatArray& albedo) {
  require_points(centres, "centres");
  const py::ssize_t n = centres.shape(0);
  const auto check = [n](const FloatArray& a, const char* name) {
    if (a.ndim() != 1 || a.shape(0) != n)
      throw py::value_error(std::string(name) + " must have shape (N,) matching centres");
  };
  check(radii, "radii");
  check(tau, "tau");
  check(albedo, "albedo");
  ParticleView v{centres.data(), radii.data(), tau.data(), albedo.data(),
                 static_cast<std::size_t>(n)};
  try {
    v.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return v;
}

VolumeGrid grid_of(const FloatArray& vols, int lead, const V3& lo, const V3& hi, const char* name,
                   int trailing) {
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

SkyParams sky_of(const py::handle& h) {
  if (py::isinstance<SkyParams>(h)) return h.cast<SkyParams>();
  const py::tuple t = h.cast<py::tuple>();
  if (t.size() != 6)
    throw py::value_error(
        "sky must be (zenith, horizon, ground, exponent, disc radius, disc intensity)");
  SkyParams s;
  s.zenith = v3(t[0].cast<V3>());
  s.horizon = v3(t[1].cast<V3>());
  s.ground = v3(t[2].cast<V3>());
  s.exponent = t[3].cast<float>();
  s.sun_disc_radius = t[4].cast<float>();
  s.sun_disc_intensity = t[5].cast<float>();
  return s;
}

namespace {
template <class T>
T get(const py::dict& d, const char* key, const char* what) {
  if (!d.contains(key)) throw py::value_error(std::string(what) + " is missing '" + key + "'");
  return d[key].cast<T>();
}
}  // namespace

GroundParams ground_of(const py::object& obj) {
  GroundParams g;
  if (obj.is_none()) return g;
  const py::dict d = obj.cast<py::dict>();
  g.enabled = true;
  g.height = get<float>(d, "height", "ground");
  g.albedo = v3(get<V3>(d, "albedo", "ground"));
  g.sky_irradiance = v3(get<V3>(d, "sky_irradiance", "ground"));
  if (d.contains("shadow") && !d["shadow"].is_none()) {
    const FloatArray sh = d["shadow"].cast<FloatArray>();
    if (sh.ndim() != 2 || sh.shape(0) < 1 || sh.shape(1) < 1)
      throw py::value_error("ground shadow must be a non-empty (nz, nx) array");
    g.nz = static_cast<int>(sh.shape(0));
    g.nx = static_cast<int>(sh.shape(1));
    g.shadow.assign(sh.data(), sh.data() + sh.size());
    const auto e = get<std::array<float, 4>>(d, "extent", "ground");
    g.x0 = e[0];
    g.z0 = e[1];
    g.x1 = e[2];
    g.z1 = e[3];
  }
  try {
    g.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return g;
}

PhysicalGrids physical_grids_of(const py::object& obj, std::vector<py::object>* keep) {
  const py::tuple t = obj.cast<py::tuple>();
  if (t.size() != 5 && t.size() != 6)
    throw py::value_error(
        "physical light must be (frame, depth, grid_lo, grid_hi, rgba[, upstream])");
  PhysicalGrids g;
  const py::tuple f = t[0].cast<py::tuple>();
  if (f.size() != 6) throw py::value_error("frame must be (u, v, w, lo, hi, res)");
  g.frame.u = v3(f[0].cast<V3>());
  g.frame.v = v3(f[1].cast<V3>());
  g.frame.w = v3(f[2].cast<V3>());
  g.frame.lo = v3(f[3].cast<V3>());
  g.frame.hi = v3(f[4].cast<V3>());
  const auto res = f[5].cast<std::array<int, 3>>();
  for (int a = 0; a < 3; ++a) g.frame.res[a] = res[a];
  const FloatArray depth = t[1].cast<FloatArray>();
  const FloatArray rgba = t[4].cast<FloatArray>();
  g.grid = grid_of(rgba, 0, t[2].cast<V3>(), t[3].cast<V3>(), "physical light", 1);
  if (rgba.shape(3) != 4) throw py::value_error("physical light lattice must be (D, H, W, 4)");
  // The other media's depth upstream of each column, (nv, nu), or None.
  const bool has_columns = t.size() == 6 && !t[5].is_none();
  FloatArray columns;
  if (has_columns) {
    columns = t[5].cast<FloatArray>();
    if (columns.ndim() != 2) throw py::value_error("upstream depth must be (nv, nu)");
  }
  if (keep != nullptr) {
    // Viewed in place: `keep` holds the arrays (as cast, copies included) for the caller.
    keep->push_back(depth);
    keep->push_back(rgba);
    g.set_views(depth.data(), static_cast<std::size_t>(depth.size()), rgba.data(),
                static_cast<std::size_t>(rgba.size()));
    if (has_columns) {
      keep->push_back(columns);
      g.set_columns_view(columns.data(), static_cast<std::size_t>(columns.size()));
    }
  } else {
    g.depth.assign(depth.data(), depth.data() + depth.size());
    g.rgba.assign(rgba.data(), rgba.data() + rgba.size());
    if (has_columns) g.columns.assign(columns.data(), columns.data() + columns.size());
  }
  try {
    g.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  return g;
}

}  // namespace cumuli::bind
