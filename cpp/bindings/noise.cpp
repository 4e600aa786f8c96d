// Bindings for cumuli/noise.hpp.
#include "cumuli/noise.hpp"

#include <limits>
#include <stdexcept>
#include <string>

#include "common.hpp"
#include "cumuli/simd.hpp"

namespace cumuli::bind {

namespace {

// fBm of (N, 3) points into a new (N,) array, without the GIL; `scan` as Noise::fbm_many's.
py::array_t<float> fbm_array(const Noise& n, const FloatArray& points, const FbmParams& params,
                             int threads, Noise::PointScan* scan) {
  require_points(points, "points");
  const std::size_t count = static_cast<std::size_t>(points.shape(0));
  auto out = new_array({static_cast<py::ssize_t>(count)});
  const float* src = points.data();
  float* dst = out.mutable_data();
  {
    py::gil_scoped_release release;
    n.fbm_many(src, count, dst, params, threads, scan);
  }
  return out;
}

FbmParams make_params(int octaves, float gain, float lacunarity, float frequency) {
  FbmParams p{octaves, gain, lacunarity, frequency};
  p.validate();
  return p;
}

// A setting chosen by name: "auto" calls `reset`, any other name `set(parse(name))`; a bad name
// is a Python ValueError.
template <class Parse, class Set>
void set_by_name(const std::string& name, void (*reset)(), Parse parse, Set set) {
  try {
    if (name == "auto") {
      reset();
    } else {
      set(parse(name));
    }
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
}

}  // namespace

// This stage's parameter structs as classes (module.cpp binds them before the functions that
// take them): fields as attributes, vectors as tuples, enumerations by name.
void bind_noise_params(py::module_& m) {
  py::class_<FbmParams>(m, "FbmParams",
                        "fBm of eq. (1): octaves n, gain w, lacunarity s, "
                        "frequency f (lattice texels per world unit).")
      .def(py::init([](int octaves, float gain, float lacunarity, float frequency) {
             return FbmParams{octaves, gain, lacunarity, frequency};
           }),
           py::arg("octaves") = 5, py::arg("gain") = 0.5f, py::arg("lacunarity") = 2.0f,
           py::arg("frequency") = 1.0f)
      .def_readwrite("octaves", &FbmParams::octaves)
      .def_readwrite("gain", &FbmParams::gain)
      .def_readwrite("lacunarity", &FbmParams::lacunarity)
      .def_readwrite("frequency", &FbmParams::frequency)
      .def("validate", &FbmParams::validate);
}

void bind_noise(py::module_& m) {
  // SIMD level of the bulk loops (cumuli/simd.hpp); the Python layer is cumuli.noise.simd_*.
  m.def(
      "simd_level", [] { return std::string(simd_name(simd_level())); },
      "The SIMD level the core's fBm uses now: 'scalar', 'avx2' or 'avx512'.");
  m.def(
      "set_simd_level",
      [](const std::string& name) {
        set_by_name(name, reset_simd_level, parse_simd_level, set_simd_level);
      },
      py::arg("level"), "Use this SIMD level ('auto': back to CUMULI_SIMD or the widest).");
  m.def(
      "simd_levels",
      [] {
        py::list out;
        for (const SimdLevel l : {SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512})
          if (simd_supported(l)) out.append(simd_name(l));
        return out;
      },
      "The SIMD levels this CPU and build support, narrowest first.");
  m.def(
      "simd_fetch", [] { return std::string(simd_fetch_name(simd_fetch())); },
      "How the wide fBm kernels read the lattice now: 'gather', 'loads' or 'cells'.");
  m.def(
      "simd_fetch_preferred", [] { return std::string(simd_fetch_name(simd_fetch_preferred())); },
      "The fetch this CPU runs fastest where measured: 'cells' on AMD, 'gather' elsewhere.");
  m.def(
      "set_simd_fetch",
      [](const std::string& name) {
        set_by_name(name, reset_simd_fetch, parse_simd_fetch, set_simd_fetch);
      },
      py::arg("fetch"), "Use this lattice fetch ('auto': back to CUMULI_SIMD_FETCH or the CPU's).");
  py::class_<Noise>(m, "Noise")
      .def(py::init<std::uint64_t, int, int>(), py::arg("seed"), py::arg("size") = 64,
           py::arg("version") = static_cast<int>(Noise::kDefaultVersion))
      .def_property_readonly("size", &Noise::size)
      .def_property_readonly("version", &Noise::version)
      .def_property_readonly("key", &Noise::key, "Version 2's 32-bit hash key of the seed.")
      .def_property_readonly("has_cells", &Noise::has_cells)
      .def_property_readonly("seed", &Noise::seed)
      .def_property_readonly(
          "lattice",
          [](py::object self) {
            const Noise& n = self.cast<const Noise&>();
            const py::ssize_t s = n.size();
            // A read-only view that keeps the Noise alive.
            py::array_t<float> view({s, s, s}, n.lattice().data(), self);
            py::detail::array_proxy(view.ptr())->flags &=
                ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
            return view;
          },
          "The size³ uniform lattice, [z, y, x], read-only view.")
      .def(
          "fbm",
          [](const Noise& n, const FloatArray& points, int octaves, float gain, float lacunarity,
             float frequency, int threads) {
            return fbm_array(n, points, make_params(octaves, gain, lacunarity, frequency), threads,
                             nullptr);
          },
          py::arg("points"), py::arg("octaves") = 5, py::arg("gain") = 0.5f,
          py::arg("lacunarity") = 2.0f, py::arg("frequency") = 1.0f, py::arg("threads") = 0)
      .def(
          "fbm_scan",
          [](const Noise& n, const FloatArray& points, int octaves, float gain, float lacunarity,
             float frequency, int threads) {
            Noise::PointScan scan;
            auto out = fbm_array(n, points, make_params(octaves, gain, lacunarity, frequency),
                                 threads, &scan);
            const double biggest = scan.finite ? static_cast<double>(scan.max_abs)
                                               : std::numeric_limits<double>::quiet_NaN();
            return py::make_tuple(out, biggest);
          },
          py::arg("points"), py::arg("octaves") = 5, py::arg("gain") = 0.5f,
          py::arg("lacunarity") = 2.0f, py::arg("frequency") = 1.0f, py::arg("threads") = 0,
          "fbm and, read in the same pass, the largest |coordinate| (NaN if one is not finite).")
      .def(
          "lattice_at",
          [](const Noise& n, const FloatArray& coords) {
            require_points(coords, "coords");
            const py::ssize_t count = coords.shape(0);
            auto out = new_array({count});
            const float* c = coords.data();
            float* o = out.mutable_data();
            for (py::ssize_t i = 0; i < count; ++i)
              o[i] = n.lattice_at(glm::vec3(c[3 * i], c[3 * i + 1], c[3 * i + 2]));
            return out;
          },
          py::arg("coords"), "Trilinear lattice value at lattice coordinates (texels).");
}

}  // namespace cumuli::bind
