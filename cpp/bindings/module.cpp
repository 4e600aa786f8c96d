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
void bind_march(py::module_& m);
void bind_volume_march(py::module_& m);
void bind_composite(py::module_& m);
void bind_particles(py::module_& m);
void bind_particle_light(py::module_& m);
void bind_sprites(py::module_& m);
void bind_billboards(py::module_& m);
void bind_impostors(py::module_& m);
void bind_anim(py::module_& m);
void bind_seedbox(py::module_& m);
void bind_sprite_atlas(py::module_& m);
void bind_caf(py::module_& m);
void bind_weather(py::module_& m);
}  // namespace cumuli::bind

PYBIND11_MODULE(_core, m) {
  m.doc() = "cumuli C++ core: noise, cloud generators, light precompute and reference renderers";
  cumuli::bind::bind_noise(m);
  cumuli::bind::bind_shapes(m);
  cumuli::bind::bind_volumes(m);
  cumuli::bind::bind_particles(m);
  cumuli::bind::bind_particle_light(m);
  cumuli::bind::bind_sprites(m);
  cumuli::bind::bind_billboards(m);
  cumuli::bind::bind_impostors(m);
  cumuli::bind::bind_light(m);
  cumuli::bind::bind_volume_light(m);
  cumuli::bind::bind_march(m);
  cumuli::bind::bind_volume_march(m);
  cumuli::bind::bind_composite(m);
  cumuli::bind::bind_anim(m);
  cumuli::bind::bind_seedbox(m);
  cumuli::bind::bind_sprite_atlas(m);
  cumuli::bind::bind_caf(m);
  cumuli::bind::bind_weather(m);
}
