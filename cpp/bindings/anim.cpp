// Bindings of the anim stage (python/cumuli/anim): the endless animation's similarity,
// transitions, walk and cross-dissolve (anim/endless.hpp), and the climatic-variation weather of
// billboard skies (anim/weather.hpp). Long loops release the GIL.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <pybind11/stl.h>

#include "common.hpp"
#include "cumuli/anim/endless.hpp"
#include "cumuli/anim/weather.hpp"

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
        if (shape_of(a) != shape_of(b))
          throw py::value_error("the two volumes must have the same shape");
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

namespace {

template <class T>
py::array_t<T> array_of(const std::vector<T>& v) {
  py::array_t<T> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

template <class T>
std::vector<T> vector_of(const py::dict& d, const char* key) {
  using Arr = py::array_t<T, py::array::c_style | py::array::forcecast>;
  if (!d.contains(key)) throw py::value_error(std::string("state is missing '") + key + "'");
  const Arr a = Arr::ensure(d[key]);
  if (!a || a.ndim() != 1) throw py::value_error(std::string("state '") + key + "' must be 1-D");
  return std::vector<T>(a.data(), a.data() + a.size());
}

WeatherConfig weather_config(std::array<double, 4> area, const py::list& layers,
                             const std::vector<std::array<double, 2>>& schedule,
                             std::uint64_t seed) {
  WeatherConfig c;
  c.x0 = area[0];
  c.z0 = area[1];
  c.x1 = area[2];
  c.z1 = area[3];
  c.seed = seed;
  for (const auto& k : schedule) c.schedule.emplace_back(k[0], k[1]);
  for (const auto& h : layers) {
    const py::dict d = h.cast<py::dict>();
    LayerConfig l;
    l.altitude = d["altitude"].cast<double>();
    l.thickness = d["thickness"].cast<double>();
    const auto wind = d["wind"].cast<std::array<double, 2>>();
    l.wind_x = wind[0];
    l.wind_z = wind[1];
    for (const auto& s : d["states"].cast<std::vector<std::array<double, 4>>>()) {
      SkyStateConfig st;
      st.cv = s[0];
      st.count = static_cast<int>(s[1]);
      st.models = static_cast<int>(s[2]);
      st.variants = static_cast<int>(s[3]);
      l.states.push_back(st);
    }
    l.radius = d["radius"].cast<std::vector<double>>();
    const auto boundary = d["boundary"].cast<std::string>();
    if (boundary == "respawn")
      l.boundary = Boundary::Respawn;
    else if (boundary == "wrap")
      l.boundary = Boundary::Wrap;
    else
      throw py::value_error("boundary must be 'respawn' or 'wrap', got '" + boundary + "'");
    l.fade_time = d["fade_time"].cast<double>();
    c.layers.push_back(std::move(l));
  }
  return c;
}

}  // namespace

void bind_weather(py::module_& m) {
  m.attr("WEATHER_MAX_INSTANCES") = kMaxLayerInstances;
  py::class_<WeatherSim>(m, "WeatherSim")
      .def(py::init([](std::array<double, 4> area, const py::list& layers,
                       const std::vector<std::array<double, 2>>& schedule, std::uint64_t seed) {
             return WeatherSim(weather_config(area, layers, schedule, seed));
           }),
           py::arg("area"), py::arg("layers"), py::arg("schedule"), py::arg("seed"))
      .def(
          "step",
          [](WeatherSim& w, double dt) {
            if (!(std::isfinite(dt) && dt >= 0.0))
              throw py::value_error("dt must be finite and >= 0");
            py::gil_scoped_release release;
            w.step(dt);
          },
          py::arg("dt"))
      .def_property_readonly("time", &WeatherSim::time)
      .def_property_readonly("cv", &WeatherSim::cv)
      .def("cv_at", &WeatherSim::cv_at, py::arg("t"))
      .def("target", &WeatherSim::target, py::arg("layer"), py::arg("cv"))
      .def("mix",
           [](const WeatherSim& w, std::size_t layer, double cv) {
             int a, b;
             double x;
             w.mix(layer, cv, a, b, x);
             return py::make_tuple(a, b, x);
           })
      .def("counts", &WeatherSim::counts, py::arg("layer"))
      .def(
          "instances",
          [](const WeatherSim& w, std::size_t layer) {
            if (layer >= w.config().layers.size()) throw py::index_error("layer out of range");
            const LayerState& s = w.layer(layer);
            std::vector<double> x, z;
            w.positions(layer, x, z);
            py::dict d;
            d["id"] = array_of(s.id);
            d["x"] = array_of(x);
            d["z"] = array_of(z);
            d["x0"] = array_of(s.x0);
            d["z0"] = array_of(s.z0);
            d["t0"] = array_of(s.t0);
            d["y"] = array_of(s.y);
            d["yaw"] = array_of(s.yaw);
            d["variant"] = array_of(s.variant);
            d["state"] = array_of(s.state);
            d["fade_in"] = array_of(s.fade_in);
            d["fade_out"] = array_of(s.fade_out);
            d["alpha"] = array_of(w.alpha(layer));
            return d;
          },
          py::arg("layer"))
      .def(
          "layer_stats",
          [](const WeatherSim& w, std::size_t layer) {
            if (layer >= w.config().layers.size()) throw py::index_error("layer out of range");
            const LayerState& s = w.layer(layer);
            py::dict d;
            d["quota"] = s.quota;
            d["events"] = s.events;
            d["spawn_edges"] =
                std::vector<std::uint64_t>(s.spawn_edges.begin(), s.spawn_edges.end());
            d["spawned"] = s.spawned;
            d["destroyed"] = s.destroyed;
            d["wrapped"] = s.wrapped;
            d["faded_out"] = s.faded_out;
            d["last_spawn_x"] = array_of(s.last_spawn_x);
            d["last_spawn_z"] = array_of(s.last_spawn_z);
            d["last_spawn_edge"] = array_of(s.last_spawn_edge);
            return d;
          },
          py::arg("layer"))
      .def(
          "set_state",
          [](WeatherSim& w, double t, const py::list& layers) {
            std::vector<LayerState> states;
            for (const auto& h : layers) {
              const py::dict d = h.cast<py::dict>();
              LayerState s;
              s.id = vector_of<std::uint64_t>(d, "id");
              s.x0 = vector_of<double>(d, "x0");
              s.z0 = vector_of<double>(d, "z0");
              s.t0 = vector_of<double>(d, "t0");
              s.y = vector_of<float>(d, "y");
              s.yaw = vector_of<float>(d, "yaw");
              s.variant = vector_of<int>(d, "variant");
              s.state = vector_of<int>(d, "state");
              s.fade_in = vector_of<double>(d, "fade_in");
              s.fade_out = vector_of<double>(d, "fade_out");
              s.quota = d["quota"].cast<double>();
              s.events = d["events"].cast<std::uint64_t>();
              const auto edges = d["spawn_edges"].cast<std::array<std::uint64_t, 4>>();
              s.spawn_edges = edges;
              s.spawned = d["spawned"].cast<std::uint64_t>();
              s.destroyed = d["destroyed"].cast<std::uint64_t>();
              s.wrapped = d["wrapped"].cast<std::uint64_t>();
              s.faded_out = d["faded_out"].cast<std::uint64_t>();
              states.push_back(std::move(s));
            }
            w.set_state(t, std::move(states));
          },
          py::arg("t"), py::arg("layers"),
          "Replace the state (after validating sizes, indices and counters); the weather is "
          "unchanged when it raises.");
}

}  // namespace cumuli::bind
