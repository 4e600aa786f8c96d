// The extension module cumuli._core: assembles the binding files, one per Python stage
// (noise, model, light, render, anim; see ARCHITECTURE.md).
#include <pybind11/pybind11.h>

#include "cumuli/large_buffer.hpp"
#include "cumuli/parallel.hpp"

namespace py = pybind11;

namespace {
// The Python exception a signal handler raised during a loop (KeyboardInterrupt for Ctrl-C),
// kept until the loop has stopped and the exception translator re-raises it.
thread_local PyObject* pending_type = nullptr;
thread_local PyObject* pending_value = nullptr;
thread_local PyObject* pending_traceback = nullptr;

// This thread's progress callback (done, total), set by cumuli._progress; owned reference.
thread_local PyObject* progress_callback = nullptr;

// The core's loop hook: runs Python's signal handlers (main thread only; elsewhere a no-op) and
// says to stop when one raised; otherwise reports progress to this thread's callback.
bool python_interrupt(std::size_t done, std::size_t total) {
  py::gil_scoped_acquire gil;
  if (PyErr_CheckSignals() != 0) {
    PyErr_Fetch(&pending_type, &pending_value, &pending_traceback);
    return true;
  }
  if (progress_callback != nullptr) {
    PyObject* result = PyObject_CallFunction(progress_callback, "nn", static_cast<Py_ssize_t>(done),
                                             static_cast<Py_ssize_t>(total));
    if (result == nullptr) {
      PyErr_Clear();  // a progress bar must not break the computation
    } else {
      Py_DECREF(result);
    }
  }
  return false;
}
}  // namespace

namespace cumuli::bind {
void bind_noise_params(py::module_& m);
void bind_model_params(py::module_& m);
void bind_light_params(py::module_& m);
void bind_render_params(py::module_& m);
void bind_sprite_params(py::module_& m);
void bind_noise(py::module_& m);
void bind_shapes(py::module_& m);
void bind_deck(py::module_& m);
void bind_volumes(py::module_& m);
void bind_light(py::module_& m);
void bind_volume_light(py::module_& m);
void bind_physical_light(py::module_& m);
void bind_march(py::module_& m);
void bind_camera_candidates(py::module_& m);
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
  // Ctrl-C (and any signal whose Python handler raises) stops long loops between chunks.
  cumuli::interrupt_hook().store(&python_interrupt);
  m.def(
      "set_progress",
      [](py::object callback) {
        py::object previous = progress_callback != nullptr
                                  ? py::reinterpret_steal<py::object>(progress_callback)
                                  : py::object(py::none());
        progress_callback = callback.is_none() ? nullptr : callback.inc_ref().ptr();
        return previous;
      },
      py::arg("callback"),
      "Set this thread's progress callback (done, total) of long C++ loops (None: none); "
      "returns the previous one.");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const cumuli::Interrupted&) {
      if (pending_type != nullptr) {
        PyErr_Restore(pending_type, pending_value, pending_traceback);
        pending_type = pending_value = pending_traceback = nullptr;
      } else {
        PyErr_SetNone(PyExc_KeyboardInterrupt);
      }
    }
  });
  m.def(
      "buffer_cache_stats",
      [] {
        const cumuli::BufferCacheStats s = cumuli::buffer_cache_stats();
        py::dict d;
        d["idle_blocks"] = s.idle_blocks;
        d["idle_bytes"] = s.idle_bytes;
        d["limit_bytes"] = s.limit_bytes;
        d["hits"] = s.hits;
        d["misses"] = s.misses;
        return d;
      },
      "The light step's idle-block cache: idle_blocks and idle_bytes it holds, its limit_bytes, "
      "and the hits (blocks reused) and misses (blocks made afresh) since the process started.");
  m.def(
      "set_buffer_cache_limit",
      [](long long bytes) {
        if (bytes < 0) throw py::value_error("the buffer cache limit must be >= 0 bytes");
        return cumuli::set_buffer_cache_limit(static_cast<std::size_t>(bytes));
      },
      py::arg("bytes"),
      "Set the most bytes the idle-block cache keeps (0: none), giving back what is over it; "
      "returns the previous limit.");
  m.def("release_buffer_cache", &cumuli::release_buffer_cache,
        "Give every idle block of the cache back to the system; returns the bytes given back.");
  // The parameter structs first: the functions' signatures name these classes.
  cumuli::bind::bind_noise_params(m);
  cumuli::bind::bind_model_params(m);
  cumuli::bind::bind_light_params(m);
  cumuli::bind::bind_render_params(m);
  cumuli::bind::bind_sprite_params(m);
  cumuli::bind::bind_noise(m);
  cumuli::bind::bind_shapes(m);
  cumuli::bind::bind_deck(m);
  cumuli::bind::bind_volumes(m);
  cumuli::bind::bind_particles(m);
  cumuli::bind::bind_particle_light(m);
  cumuli::bind::bind_sprites(m);
  cumuli::bind::bind_billboards(m);
  cumuli::bind::bind_impostors(m);
  cumuli::bind::bind_light(m);
  cumuli::bind::bind_volume_light(m);
  cumuli::bind::bind_physical_light(m);
  cumuli::bind::bind_march(m);
  cumuli::bind::bind_camera_candidates(m);
  cumuli::bind::bind_volume_march(m);
  cumuli::bind::bind_composite(m);
  cumuli::bind::bind_anim(m);
  cumuli::bind::bind_seedbox(m);
  cumuli::bind::bind_sprite_atlas(m);
  cumuli::bind::bind_caf(m);
  cumuli::bind::bind_weather(m);
}
