// Helpers shared by the binding files: numpy ↔ C++ conversions and argument checks.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "cumuli/cloud.hpp"

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

// Build a CloudShape from (N,3) centres, (N,3) radii, (N,3,3) rotations and density settings.
CloudShape cloud_from_arrays(const FloatArray& centres, const FloatArray& radii,
                             const FloatArray& rotations, const std::string& model, float kappa,
                             float phi);

}  // namespace cumuli::bind
