// Helpers shared by the binding files: numpy ↔ C++ conversions and argument checks.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/light/volume.hpp"
#include "cumuli/model/cloud.hpp"
#include "cumuli/model/particles.hpp"
#include "cumuli/rendering/ground.hpp"
#include "cumuli/rendering/physical.hpp"
#include "cumuli/rendering/volume.hpp"

namespace cumuli::bind {

namespace py = pybind11;

// float32, C-contiguous; other float dtypes are converted on the way in.
using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

// Throws ValueError unless `a` has shape (N, 3).
inline void require_points(const FloatArray& a, const char* name) {
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(name) + " must have shape (N, 3)");
}

// A new float32 array of the given shape, owned by numpy.
inline py::array_t<float> new_array(const std::vector<py::ssize_t>& shape) {
  return py::array_t<float>(shape);
}

// Build a CloudShape from (N,3) centres, (N,3) radii, (N,3,3) rotations and density settings;
// `noise_offset` (x, y, z): where its fBm is read from, p − offset (finite).
CloudShape cloud_from_arrays(const FloatArray& centres, const FloatArray& radii,
                             const FloatArray& rotations, const std::string& model, float kappa,
                             float phi, glm::vec3 noise_offset = glm::vec3(0.0f));
// The optional noise offset of a cloud given as a tuple or dict entry (None: zero).
glm::vec3 noise_offset_arg(const py::handle& value);

// --- particle clouds (Harris 2002) ------------------------------------------------------------

// A ParticleView over numpy arrays (kept alive by the caller): centres (N, 3), radii, tau and
// albedo (N,) float32. Shapes are checked here (ValueError), values by ParticleView::validate.
ParticleView particle_view(const FloatArray& centres, const FloatArray& radii,
                           const FloatArray& tau, const FloatArray& albedo);

// --- volumes (endless animation, volume light, volume marcher) ---------------------------------

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using V3 = std::array<float, 3>;

inline glm::vec3 v3(const V3& a) { return glm::vec3(a[0], a[1], a[2]); }

inline std::vector<py::ssize_t> shape_of(const py::array& a) {
  return std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim());
}

// (N, D, H, W) volumes (`lead` leading axes, `trailing` trailing ones) → their grid.
VolumeGrid grid_of(const FloatArray& vols, int lead, const V3& lo, const V3& hi, const char* name,
                   int trailing = 0);

// A float32 / float64 array holding a copy of `v`.
py::array_t<float> to_array(const std::vector<float>& v, const std::vector<py::ssize_t>& shape);
py::array_t<double> to_array_d(const std::vector<double>& v, py::ssize_t n);

// An array over `v`'s own storage, no copy (the array keeps the vector alive): for the large
// results of the light step, whose copy and fresh pages cost as much as some of its stages.
template <class T, class Alloc>
py::array_t<T> adopt_array(std::vector<T, Alloc>&& v, const std::vector<py::ssize_t>& shape) {
  py::ssize_t count = 1;
  for (const py::ssize_t n : shape) count *= n;
  if (count != static_cast<py::ssize_t>(v.size()))
    throw std::logic_error("adopt_array: the shape does not hold the vector's values");
  if (v.empty()) return py::array_t<T>(shape);
  auto holder = std::make_unique<std::vector<T, Alloc>>(std::move(v));
  T* data = holder->data();
  py::capsule owner(holder.get(), [](void* p) { delete static_cast<std::vector<T, Alloc>*>(p); });
  holder.release();  // the capsule owns it now
  return py::array_t<T>(shape, data, owner);
}

// The sky as Python passes it: a SkyParams, or the tuple (zenith, horizon, ground, exponent,
// disc radius, disc intensity).
SkyParams sky_of(const py::handle& h);

// The ground as Python passes it: None, or a dict with height, albedo, sky_irradiance and
// optionally shadow ((nz, nx) float32) with extent (x0, z0, x1, z1).
GroundParams ground_of(const py::object& g);
// A drawable's physical light: (frame, depth (nw, nv, nu), grid_lo, grid_hi, rgba (D, H, W, 4)).
// With `keep`, the lattices are viewed, not copied: `keep` receives the arrays viewed, which the
// caller holds (with the GIL) for as long as the grids are used.
PhysicalGrids physical_grids_of(const py::object& t, std::vector<py::object>* keep = nullptr);

// --- bound parameter structs: field helpers -----------------------------------------------------

// A finite 3-vector from a sequence of three numbers (ValueError naming `name` otherwise).
glm::vec3 vec3_arg(const py::handle& value, const char* name);
// `v`, or a ValueError naming `name` when it is not finite.
float finite(float v, const char* name);

// A glm::vec3 / dvec3 field as a property: reads (x, y, z), takes three finite numbers.
template <class C, class V>
void vec3_property(py::class_<C>& cls, const char* name, V C::* field, const char* label) {
  cls.def_property(
      name,
      [field](const C& c) {
        const V& v = c.*field;
        return py::make_tuple(v.x, v.y, v.z);
      },
      [field, label](C& c, const py::handle& value) {
        if constexpr (std::is_same_v<V, glm::dvec3>) {
          std::array<double, 3> a{};
          try {
            a = value.cast<std::array<double, 3>>();
          } catch (const py::cast_error&) {
            throw py::value_error(std::string(label) + " must be a sequence of three numbers");
          }
          for (const double x : a)
            if (!std::isfinite(x)) throw py::value_error(std::string(label) + " must be finite");
          c.*field = V(a[0], a[1], a[2]);
        } else {
          c.*field = vec3_arg(value, label);
        }
      });
}

// An enumeration's values with their Python names.
template <class E>
using Names = std::vector<std::pair<const char*, E>>;

// The value named `s`, else a ValueError naming `label` and listing the names.
template <class E>
E enum_of(const std::string& s, const Names<E>& names, const char* label) {
  for (const auto& [n, e] : names)
    if (s == n) return e;
  std::string all;
  for (std::size_t i = 0; i < names.size(); ++i)
    all += (i == 0 ? "'" : (i + 1 == names.size() ? " or '" : ", '")) +
           std::string(names[i].first) + "'";
  throw py::value_error(std::string(label) + " must be " + all + ", got '" + s + "'");
}

// An enumeration field as a property read and set by name.
template <class C, class E>
void enum_property(py::class_<C>& cls, const char* name, E C::* field, Names<E> names) {
  cls.def_property(
      name,
      [field, names](const C& c) {
        for (const auto& [n, e] : names)
          if (c.*field == e) return std::string(n);
        return std::string("?");
      },
      [field, names, name](C& c, const std::string& s) { c.*field = enum_of(s, names, name); });
}

}  // namespace cumuli::bind
