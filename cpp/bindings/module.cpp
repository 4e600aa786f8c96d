// The extension module cumuli._core: assembles the per-area binding files.
#include <pybind11/pybind11.h>

namespace py = pybind11;

namespace cumuli::bind {
void bind_noise(py::module_& m);
void bind_shapes(py::module_& m);
void bind_animation(py::module_& m);
void bind_light(py::module_& m);
void bind_march(py::module_& m);
}  // namespace cumuli::bind

PYBIND11_MODULE(_core, m) {
  m.doc() = "cumuli C++ core: noise, cloud generators, light precompute and a reference marcher";
  cumuli::bind::bind_noise(m);
  cumuli::bind::bind_shapes(m);
  cumuli::bind::bind_animation(m);
  cumuli::bind::bind_light(m);
  cumuli::bind::bind_march(m);
}
