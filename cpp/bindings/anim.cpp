// Bindings of the anim stage (python/cumuli/anim): the endless animation's similarity,
// transitions, walk and cross-dissolve (anim/endless.hpp). Long loops release the GIL.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "common.hpp"
#include "cumuli/anim/endless.hpp"

namespace cumuli::bind {

void bind_anim(py::module_& m) {
  m.def(
      "similarity_matrix",
      [](const FloatArray& vols, int threads) {
        if (vols.ndim() < 2) throw py::value_error("volumes must have shape (N, ...)");
        const int n = static_cast<int>(vols.shape(0));
        if (n < 1) throw py::value_error("volumes must hold at least one volume");
        const std::size_t voxels = static_cast<std::size_t>(vols.size()) / n;
        py::array_t<double> out({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(n)});
        double* o = out.mutable_data();
        const float* v = vols.data();
        {
          py::gil_scoped_release release;
          similarity_matrix(v, n, voxels, o, threads);
        }
        return out;
      },
      py::arg("volumes"), py::arg("threads") = 0,
      "D_kl = Σ (ρ_k − ρ_l)² for all pairs: (N, N) float64.");

  m.def(
      "transition_matrix",
      [](const DoubleArray& d, double sigma) {
        if (d.ndim() != 2 || d.shape(0) != d.shape(1) || d.shape(0) < 1)
          throw py::value_error("similarity must be a non-empty square (N, N) matrix");
        const int n = static_cast<int>(d.shape(0));
        return to_array_d(transition_matrix(d.data(), n, sigma), n);
      },
      py::arg("similarity"), py::arg("sigma"),
      "The paper's P_kl ∝ exp(−D_{k+1,l}/σ) (last row: exp(−D_{N−1,l−1}/σ)), rows summing to 1.");

  m.def("crossfade_weight", &crossfade_weight, py::arg("step"), py::arg("frames"));

  py::class_<EndlessWalk>(m, "EndlessWalk")
      .def(py::init([](const DoubleArray& d, double sigma, int crossfade, std::uint64_t seed,
                       int start) {
             if (d.ndim() != 2 || d.shape(0) != d.shape(1) || d.shape(0) < 1)
               throw py::value_error("similarity must be a non-empty square (N, N) matrix");
             return EndlessWalk(d.data(), static_cast<int>(d.shape(0)), sigma, crossfade, seed,
                                start);
           }),
           py::arg("similarity"), py::arg("sigma"), py::arg("crossfade"), py::arg("seed"),
           py::arg("start"))
      .def("next",
           [](EndlessWalk& w) {
             const AnimationFrame f = w.next();
             return py::make_tuple(f.source, f.target, f.weight, f.crossfade);
           })
      .def_property_readonly("current", &EndlessWalk::current)
      .def_property_readonly("matrix",
                             [](const EndlessWalk& w) { return to_array_d(w.matrix(), w.size()); })
      .def_property_readonly("live", [](const EndlessWalk& w) {
        py::array_t<bool> out(w.size());
        for (int i = 0; i < w.size(); ++i) out.mutable_data()[i] = w.live()[i] != 0;
        return out;
      });

  m.def(
      "blend_volumes",
      [](const FloatArray& a, const FloatArray& b, float w, int threads) {
        if (shape_of(a) != shape_of(b)) throw py::value_error("the two volumes must have the same shape");
        auto out = new_array(shape_of(a));
        const float* pa = a.data();
        const float* pb = b.data();
        float* po = out.mutable_data();
        const std::size_t n = static_cast<std::size_t>(a.size());
        {
          py::gil_scoped_release release;
          blend_volumes(pa, pb, w, po, n, threads);
        }
        return out;
      },
      py::arg("a"), py::arg("b"), py::arg("w"), py::arg("threads") = 0, "w·a + (1 − w)·b.");
}

}  // namespace cumuli::bind
