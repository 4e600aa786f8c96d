// The extension module cumuli._core: assembles the binding files, one per Python stage
// (noise, model, light, render, anim; see ARCHITECTURE.md).
#include <pybind11/pybind11.h>

namespace py = pybind11;

namespace cumuli::bind {
void bind_noise(py::module_& m);
void bind_shapes(py::module_& m);
void bind_volumes(py::module_& m);
void bind_light(py::module_& m);
void bind_volume_light(py::module_& m);
void bind_physical_light(py::module_& m);
void bind_march(py::module_& m);
void bind_volume_march(py::module_& m);
void bind_composite(py::module_& m);
void bind_anim(py::module_& m);
}  // namespace cumuli::bind

PYBIND11_MODULE(_core, m) {
  m.doc() = "cumuli C++ core: noise, cloud generators, light precompute and reference renderers";
  cumuli::bind::bind_noise(m);
  cumuli::bind::bind_shapes(m);
  cumuli::bind::bind_volumes(m);
  cumuli::bind::bind_light(m);
  cumuli::bind::bind_volume_light(m);
  cumuli::bind::bind_physical_light(m);
  cumuli::bind::bind_march(m);
  cumuli::bind::bind_volume_march(m);
  cumuli::bind::bind_composite(m);
  cumuli::bind::bind_anim(m);
}
