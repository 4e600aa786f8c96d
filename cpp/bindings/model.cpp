// Bindings of the model stage (python/cumuli/model): the cloud-shape generators (Gaussian
// cumulus, L-system, metaballs, mesh → ellipsoids), cloud density, the voxelised evolving
// clouds of the endless-animation database (anim/endless.hpp), the seed-and-box billboard
// clouds with their sprite atlas (model/seedbox.hpp, model/atlas.hpp) and the cloud
// decks (model/deck.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <pybind11/stl.h>

#include "common.hpp"
#include "cumuli/anim/endless.hpp"
#include "cumuli/model/atlas.hpp"
#include "cumuli/model/cloud.hpp"
#include "cumuli/model/deck.hpp"
#include "cumuli/model/gaussian.hpp"
#include "cumuli/model/lsystem.hpp"
#include "cumuli/model/mesh.hpp"
#include "cumuli/model/particles.hpp"
#include "cumuli/model/seedbox.hpp"
#include "cumuli/noise.hpp"
#include "cumuli/parallel.hpp"

namespace cumuli::bind {

namespace {

py::array_t<float> points_array(const std::vector<glm::vec3>& pts) {
  auto out = new_array({static_cast<py::ssize_t>(pts.size()), 3});
  float* d = out.mutable_data();
  for (std::size_t i = 0; i < pts.size(); ++i)
    for (int k = 0; k < 3; ++k) d[3 * i + k] = pts[i][k];
  return out;
}

py::array_t<float> scalar_array(const std::vector<float>& v) {
  auto out = new_array({static_cast<py::ssize_t>(v.size())});
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

LSystemRules make_rules(const std::map<std::string, std::string>& rules) {
  LSystemRules r;
  for (const auto& [key, value] : rules) {
    if (key.size() != 1)
      throw py::value_error("rules: every key must be one symbol, got '" + key + "'");
    r.set(key[0], value);
  }
  return r;
}

// The density of a cloud: fBm from `noise`, or `constant` everywhere when it is >= 0 (ValueError
// for bad fBm parameters or for neither).
DensitySource density_source(const Noise* noise, float constant, const FbmParams& fbm) {
  DensitySource src;
  src.noise = noise;
  src.fbm = fbm;
  try {
    src.fbm.validate();
  } catch (const std::invalid_argument& e) {
    throw py::value_error(e.what());
  }
  src.constant = constant;
  if (constant < 0.0f && noise == nullptr)
    throw py::value_error("give a noise or a constant density >= 0");
  return src;
}

}  // namespace

const Names<ClampMode> kClampModes = {{"saturate", ClampMode::Saturate},
                                      {"resample", ClampMode::Resample}};
const Names<RadiusModel> kRadiusModels = {
    {"eq15", RadiusModel::Eq15}, {"eq16", RadiusModel::Eq16}, {"uniform", RadiusModel::Uniform}};
const Names<Eq16Combine> kCombines = {{"sum", Eq16Combine::Sum}, {"product", Eq16Combine::Product}};

// This stage's parameter structs as classes (module.cpp binds them before the functions that
// take them): fields as attributes, vectors as tuples, enumerations by name.
void bind_model_params(py::module_& m) {
  py::class_<CloudShape>(m, "CloudShape",
                         "A 2018 cloud as the core takes it: primitives (centres (N, 3), radii "
                         "(N, 3), rotations (N, 3, 3)) and density model, κ, φ; its fBm is read "
                         "at p − noise_offset (a cloud that carries its noise with the wind).")
      .def(py::init([](const FloatArray& centres, const FloatArray& radii,
                       const FloatArray& rotations, const std::string& model, float kappa,
                       float phi, const py::object& noise_offset) {
             return cloud_from_arrays(centres, radii, rotations, model, kappa, phi,
                                      noise_offset_arg(noise_offset));
           }),
           py::arg("centres"), py::arg("radii"), py::arg("rotations"), py::arg("model"),
           py::arg("kappa"), py::arg("phi"), py::arg("noise_offset") = py::none())
      .def_property_readonly("noise_offset",
                             [](const CloudShape& c) {
                               return py::make_tuple(c.noise_offset.x, c.noise_offset.y,
                                                     c.noise_offset.z);
                             })
      .def_property_readonly("n", [](const CloudShape& c) { return c.primitives.size(); })
      .def_property_readonly("kappa", [](const CloudShape& c) { return c.density.kappa; })
      .def_property_readonly("phi", [](const CloudShape& c) { return c.density.phi; });

  py::class_<EvolutionParams> ev(m, "EvolutionParams",
                                 "How a cumulus evolves over the frames of a volume database.");
  ev.def(py::init<>())
      .def_readwrite("frames", &EvolutionParams::frames)
      .def_property(
          "res", [](const EvolutionParams& p) { return py::make_tuple(p.res_x, p.res_y, p.res_z); },
          [](EvolutionParams& p, std::array<int, 3> r) {
            p.res_x = r[0];
            p.res_y = r[1];
            p.res_z = r[2];
          })
      .def_readwrite("growth", &EvolutionParams::growth)
      .def_readwrite("jitter", &EvolutionParams::jitter)
      .def_readwrite("density_scale", &EvolutionParams::density_scale)
      .def_readwrite("padding", &EvolutionParams::padding)
      .def_readwrite("seed", &EvolutionParams::seed);
  vec3_property(ev, "drift", &EvolutionParams::drift, "drift");
  vec3_property(ev, "wind", &EvolutionParams::wind, "wind");

  py::class_<GaussianCumulusParams> gc(m, "GaussianCumulusParams",
                                       "The Gaussian cumulus generator's parameters (§3.6.1).");
  gc.def(py::init<>())
      .def_readwrite("n", &GaussianCumulusParams::n)
      .def_readwrite("epsilon", &GaussianCumulusParams::epsilon)
      .def_readwrite("radius_scale", &GaussianCumulusParams::radius_scale)
      .def_readwrite("radius_lo", &GaussianCumulusParams::radius_lo)
      .def_readwrite("radius_hi", &GaussianCumulusParams::radius_hi)
      .def_readwrite("hollow", &GaussianCumulusParams::hollow)
      .def_readwrite("remove_contained", &GaussianCumulusParams::remove_contained)
      .def_readwrite("seed", &GaussianCumulusParams::seed)
      .def("validate", &GaussianCumulusParams::validate);
  vec3_property(gc, "centre", &GaussianCumulusParams::centre, "centre");
  vec3_property(gc, "mu", &GaussianCumulusParams::mu, "mu");
  vec3_property(gc, "sigma", &GaussianCumulusParams::sigma, "sigma");
  vec3_property(gc, "clamp_lo", &GaussianCumulusParams::clamp_lo, "clamp_lo");
  vec3_property(gc, "clamp_hi", &GaussianCumulusParams::clamp_hi, "clamp_hi");
  vec3_property(gc, "hollow_box", &GaussianCumulusParams::hollow_box, "hollow_box");
  enum_property(gc, "clamp_mode", &GaussianCumulusParams::clamp_mode, kClampModes);
  enum_property(gc, "radius_model", &GaussianCumulusParams::radius_model, kRadiusModels);
  enum_property(gc, "eq16_combine", &GaussianCumulusParams::eq16_combine, kCombines);

  py::class_<TurtleParams> tp(m, "TurtleParams",
                              "The L-system turtle: angle, radius and step ranges, symbols, "
                              "start frame, seed and sphere budget.");
  tp.def(py::init<>())
      .def_readwrite("angle_lo", &TurtleParams::angle_lo)
      .def_readwrite("angle_hi", &TurtleParams::angle_hi)
      .def_readwrite("radius_lo", &TurtleParams::radius_lo)
      .def_readwrite("radius_hi", &TurtleParams::radius_hi)
      .def_readwrite("step_lo", &TurtleParams::step_lo)
      .def_readwrite("step_hi", &TurtleParams::step_hi)
      .def_readwrite("draw_symbols", &TurtleParams::draw_symbols)
      .def_readwrite("move_symbols", &TurtleParams::move_symbols)
      .def_readwrite("seed", &TurtleParams::seed)
      .def_readwrite("max_spheres", &TurtleParams::max_spheres)
      .def("validate", &TurtleParams::validate);
  vec3_property(tp, "start", &TurtleParams::start, "start");
  vec3_property(tp, "heading", &TurtleParams::heading, "heading");
  vec3_property(tp, "up", &TurtleParams::up, "up");
}

void bind_shapes(py::module_& m) {
  m.attr("LSYSTEM_MAX_LENGTH") = kMaxLSystemLength;
  m.def(
      "gaussian_cumulus",
      [](const GaussianCumulusParams& params) {
        const GaussianCumulusParams& p = params;
        p.validate();  // std::invalid_argument → ValueError
        GaussianCumulusResult r;
        {
          py::gil_scoped_release release;
          r = gaussian_cumulus(p);
        }
        py::dict stats;
        stats["drawn"] = r.drawn;
        stats["clamped"] = r.clamped;
        stats["removed_by_hollow"] = r.removed_by_hollow;
        stats["removed_by_containment"] = r.removed_by_containment;
        stats["kept"] = static_cast<int>(r.centres.size());
        return py::make_tuple(points_array(r.centres), scalar_array(r.radii), stats);
      },
      py::arg("params"),
      "Gaussian cumulus (params: a GaussianCumulusParams) (§3.6.1): returns (centres (N,3), radii "
      "(N,), stats dict).");

  m.def(
      "remove_contained_spheres",
      [](const FloatArray& centres, const FloatArray& radii) {
        require_points(centres, "centres");
        if (radii.ndim() != 1 || radii.shape(0) != centres.shape(0))
          throw py::value_error("radii must have shape (N,) matching centres");
        const std::size_t n = static_cast<std::size_t>(centres.shape(0));
        std::vector<glm::vec3> c(n);
        std::vector<float> r(radii.data(), radii.data() + n);
        for (std::size_t i = 0; i < n; ++i)
          c[i] = glm::vec3(centres.data()[3 * i], centres.data()[3 * i + 1],
                           centres.data()[3 * i + 2]);
        // Eq. (17) compares radii and distances: NaN or non-positive radii would make the
        // kept set meaningless rather than fail, so refuse them here.
        for (std::size_t i = 0; i < n; ++i) {
          if (!std::isfinite(c[i].x) || !std::isfinite(c[i].y) || !std::isfinite(c[i].z))
            throw py::value_error("centres must be finite");
          if (!std::isfinite(r[i]) || !(r[i] > 0.0f))
            throw py::value_error("radii must be finite and positive");
        }
        std::vector<int> keep;
        {
          py::gil_scoped_release release;
          keep = remove_contained_spheres(c, r);
        }
        py::array_t<std::int64_t> out(static_cast<py::ssize_t>(keep.size()));
        std::copy(keep.begin(), keep.end(), out.mutable_data());
        return out;
      },
      py::arg("centres"), py::arg("radii"),
      "Eq. (17): indices of the spheres kept so that none lies inside another.");

  m.def(
      "lsystem_length",
      [](const std::string& axiom, const std::map<std::string, std::string>& rules,
         int iterations) {
        const LSystemRules r = make_rules(rules);
        const LSystemLength n = lsystem_length(axiom, r, iterations, UINT64_MAX - 1);
        return py::make_tuple(n.final_length, n.peak_length);
      },
      py::arg("axiom"), py::arg("rules"), py::arg("iterations"),
      "(final, peak) symbol counts of the expansion, saturating at 2**64 - 1; allocates nothing.");

  m.def(
      "lsystem_expand",
      [](const std::string& axiom, const std::map<std::string, std::string>& rules, int iterations,
         std::uint64_t max_length) {
        const LSystemRules r = make_rules(rules);
        std::string out;
        {
          py::gil_scoped_release release;
          out = lsystem_expand(axiom, r, iterations, max_length);
        }
        return out;
      },
      py::arg("axiom"), py::arg("rules"), py::arg("iterations"), py::arg("max_length"),
      "Rewrite the axiom `iterations` times; refuses (ValueError) before allocating when any "
      "string would exceed max_length symbols.");

  m.def(
      "lsystem_interpret",
      [](const std::string& symbols, const TurtleParams& params) {
        const TurtleParams& p = params;
        p.validate();
        TurtleResult r;
        {
          py::gil_scoped_release release;
          r = lsystem_interpret(symbols, p);
        }
        py::dict stats;
        stats["symbols"] = symbols.size();
        stats["spheres"] = r.centres.size();
        stats["turns"] = r.turns;
        stats["moves"] = r.moves;
        stats["max_depth"] = r.max_depth;
        stats["final_position"] =
            py::make_tuple(r.final_position.x, r.final_position.y, r.final_position.z);
        stats["final_heading"] =
            py::make_tuple(r.final_heading.x, r.final_heading.y, r.final_heading.z);
        return py::make_tuple(points_array(r.centres), scalar_array(r.radii), stats);
      },
      py::arg("symbols"), py::arg("params"),
      "Walk an L-system string with the 3D turtle (params: a TurtleParams): returns (centres "
      "(N,3), radii (N,), stats).");

  m.def(
      "cloud_density",
      [](const CloudShape& cloud, const FloatArray& points, const Noise* noise, float constant,
         const FbmParams& fbm, int threads) {
        require_points(points, "points");
        const DensitySource src = density_source(noise, constant, fbm);
        const std::size_t n = static_cast<std::size_t>(points.shape(0));
        auto rho = new_array({static_cast<py::ssize_t>(n)});
        auto gamma = new_array({static_cast<py::ssize_t>(n)});
        const float* p = points.data();
        float* r = rho.mutable_data();
        float* g = gamma.mutable_data();
        {
          py::gil_scoped_release release;
          parallel_for(n, threads, [&](std::size_t i) {
            const glm::vec3 x(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
            // Pseudo-spheroids: attribute the sample to the primitive whose surface it is
            // deepest inside (smallest |q|), as a ray marching that primitive would see it.
            int j = 0;
            if (cloud.density.model == DensityModel::Spheroid) {
              float best = INFINITY;
              for (std::size_t k = 0; k < cloud.primitives.size(); ++k) {
                const float q = cloud.primitives[k].normalised_distance(x);
                if (q < best) {
                  best = q;
                  j = static_cast<int>(k);
                }
              }
            }
            const DensitySample s = cloud_density(cloud, j, x, src);
            r[i] = s.rho;
            g[i] = s.gamma;
          });
        }
        return py::make_tuple(rho, gamma);
      },
      py::arg("cloud"), py::arg("points"), py::arg("noise").none(true), py::arg("constant"),
      py::arg("fbm") = FbmParams{}, py::arg("threads") = 0,
      "Density (rho, gamma) of a cloud at points (eq. 2 or eqs. 19-21).");

  m.def(
      "density_grid",
      [](const CloudShape& cloud, const Noise* noise, float constant, const FbmParams& fbm,
         std::array<float, 3> lo, std::array<float, 3> hi, std::array<int, 3> res, int supersample,
         int threads) {
        const DensitySource src = density_source(noise, constant, fbm);
        Box box{glm::vec3(lo[0], lo[1], lo[2]), glm::vec3(hi[0], hi[1], hi[2])};
        for (int a = 0; a < 3; ++a) {
          if (!(box.hi[a] > box.lo[a]) || !std::isfinite(box.lo[a]) || !std::isfinite(box.hi[a]))
            throw py::value_error("box hi must be greater than lo on every axis (finite)");
          if (res[a] < 1 || res[a] > 4096) throw py::value_error("resolution must be in [1, 4096]");
        }
        if (supersample < 1 || supersample > 8)
          throw py::value_error("supersample must be in [1, 8]");
        if (py::ssize_t{res[0]} * res[1] * res[2] > (py::ssize_t{1} << 30))
          throw py::value_error("resolution has more than 2^30 voxels");
        std::vector<float> out;
        {
          py::gil_scoped_release release;
          out = density_grid(cloud, src, box, res.data(), supersample, threads);
        }
        return adopt_array(std::move(out), {res[2], res[1], res[0]});
      },
      py::arg("cloud"), py::arg("noise").none(true), py::arg("constant"), py::arg("fbm"),
      py::arg("lo"), py::arg("hi"), py::arg("res"), py::arg("supersample") = 1,
      py::arg("threads") = 0,
      "The density field (union attribution) on a lattice over a box: (D, H, W) float32, the "
      "mean of supersample³ points per voxel (1: texel centres).");

  m.def(
      "ellipsoids_from_mesh",
      [](const FloatArray& vertices, const py::array& faces_in, float scale, bool rotate,
         float min_radius, int threads) {
        require_points(vertices, "vertices");
        const char kind = faces_in.dtype().kind();
        if (kind != 'i' && kind != 'u')
          throw py::type_error("faces must be an integer array, got dtype " +
                               std::string(py::str(faces_in.dtype())));
        if (faces_in.ndim() != 2 || faces_in.shape(1) != 3)
          throw py::value_error("faces must have shape (F, 3)");
        // uint64 indices above 2⁶³ wrap to negative int64 here: still reported as out of range.
        using IndexArray = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;
        const IndexArray faces = IndexArray::ensure(faces_in);
        const std::size_t nv = static_cast<std::size_t>(vertices.shape(0));
        const std::size_t nf = static_cast<std::size_t>(faces.shape(0));
        MeshEllipsoidsResult r;
        {
          py::gil_scoped_release release;
          r = ellipsoids_from_mesh(vertices.data(), nv, faces.data(), nf, scale, rotate, min_radius,
                                   threads);
        }
        auto centres = new_array({static_cast<py::ssize_t>(nf), 3});
        auto radii = new_array({static_cast<py::ssize_t>(nf), 3});
        auto rotations = new_array({static_cast<py::ssize_t>(nf), 3, 3});
        float* c = centres.mutable_data();
        float* rr = radii.mutable_data();
        float* m = rotations.mutable_data();
        for (std::size_t i = 0; i < nf; ++i) {
          const Ellipsoid& e = r.ellipsoids[i];
          for (int k = 0; k < 3; ++k) {
            c[3 * i + k] = e.centre[k];
            rr[3 * i + k] = e.radii[k];
          }
          // glm column-major rotation[col][row] → numpy row-major R[row][col].
          for (int row = 0; row < 3; ++row)
            for (int col = 0; col < 3; ++col) m[9 * i + 3 * row + col] = e.rotation[col][row];
        }
        py::dict stats;
        stats["faces"] = nf;
        stats["floored_faces"] = r.floored_faces;
        return py::make_tuple(centres, radii, rotations, stats);
      },
      py::arg("vertices"), py::arg("faces"), py::arg("scale"), py::arg("rotate"),
      py::arg("min_radius"), py::arg("threads") = 0,
      "Mesh → ellipsoids (§3.6.4, eqs. 22–30): returns (centres (F,3), radii (F,3), "
      "rotations (F,3,3), stats).");
}

void bind_volumes(py::module_& m) {
  m.def(
      "evolving_cloud_box",
      [](const CloudShape& cloud, const EvolutionParams& evolution) {
        const Box b = evolving_cloud_box(cloud, evolution);
        return py::make_tuple(V3{b.lo.x, b.lo.y, b.lo.z}, V3{b.hi.x, b.hi.y, b.hi.z});
      },
      py::arg("cloud"), py::arg("evolution"),
      "World box holding the evolving cloud at every frame (padded): ((x,y,z) lo, (x,y,z) hi).");

  m.def(
      "evolving_cloud_volumes",
      [](const CloudShape& cloud, const Noise* noise, float constant, const FbmParams& fbm,
         const EvolutionParams& evolution, V3 box_lo, V3 box_hi, int threads) {
        const DensitySource src = density_source(noise, constant, fbm);
        const EvolutionParams& p = evolution;
        std::vector<float> v;
        {
          py::gil_scoped_release release;
          v = evolving_cloud_volumes(cloud, src, p, Box{v3(box_lo), v3(box_hi)}, threads);
        }
        return to_array(v, {p.frames, p.res_z, p.res_y, p.res_x});
      },
      py::arg("cloud"), py::arg("noise").none(true), py::arg("constant"), py::arg("fbm"),
      py::arg("evolution"), py::arg("box_lo"), py::arg("box_hi"), py::arg("threads"),
      "Voxelise an evolving cloud: (frames, D, H, W) float32 densities.");
}

namespace {

template <class T>
py::array_t<T> int_array(const std::vector<T>& v) {
  py::array_t<T> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

std::pair<int, int> int_pair(const py::dict& d, const char* key) {
  const auto t = d[key].cast<std::array<int, 2>>();
  return {t[0], t[1]};
}

SeedBoxParams seed_params(const py::handle& h) {
  const py::dict d = h.cast<py::dict>();
  SeedBoxParams p;
  p.centre = v3(d["centre"].cast<V3>());
  p.half_size = v3(d["half_size"].cast<V3>());
  for (const auto& v : d["directions"].cast<std::vector<V3>>()) p.directions.push_back(v3(v));
  p.apertures = d["apertures"].cast<std::vector<float>>();
  p.levels = d["levels"].cast<int>();
  std::tie(p.boxes_min, p.boxes_max) = int_pair(d, "boxes_per_level");
  p.reach = d["reach"].cast<float>();
  const auto child = d["child_scale"].cast<std::array<float, 2>>();
  p.child_min = child[0];
  p.child_max = child[1];
  std::tie(p.billboards_min, p.billboards_max) = int_pair(d, "billboards_per_box");
  const auto per = d["count_per"].cast<std::string>();
  if (per == "direction")
    p.count_per = CountPer::Direction;
  else if (per == "level")
    p.count_per = CountPer::Level;
  else
    throw py::value_error("count_per must be 'direction' or 'level', got '" + per + "'");
  p.flat_base = d["flat_base"].cast<bool>();
  return p;
}

}  // namespace

void bind_seedbox(py::module_& m) {
  m.attr("SEEDBOX_MAX_BOXES") = kMaxCloudBoxes;
  m.attr("SEEDBOX_MAX_BILLBOARDS") = kMaxCloudBillboards;
  m.attr("SEEDBOX_MAX_SEEDS") = kMaxSeedBoxes;
  m.def(
      "seed_box_worst_case",
      [](const py::list& seeds) {
        std::vector<SeedBoxParams> s;
        for (const auto& h : seeds) s.push_back(seed_params(h));
        std::uint64_t boxes = 0, billboards = 0;
        worst_case_counts(s, boxes, billboards);
        return py::make_tuple(boxes, billboards);
      },
      py::arg("seeds"), "(boxes, billboards) in the worst case of a seed-box parameter set.");
  m.def(
      "seed_box_cloud",
      [](const py::list& seeds, std::array<float, 2> size, float aspect_min,
         const std::vector<int>& textures, bool rotate, float min_spacing, bool ellipsoid,
         std::uint64_t seed, int threads) {
        std::vector<SeedBoxParams> s;
        for (const auto& h : seeds) s.push_back(seed_params(h));
        BillboardParams bb;
        bb.size_min = size[0];
        bb.size_max = size[1];
        bb.aspect_min = aspect_min;
        bb.textures = textures;
        bb.rotate = rotate;
        bb.min_spacing = min_spacing;
        bb.ellipsoid = ellipsoid;
        validate_seed_box_cloud(s, bb);  // before releasing the GIL: ValueError naming the field
        BillboardCloudData r;
        {
          py::gil_scoped_release release;
          r = seed_box_cloud(s, bb, seed, threads);
        }
        const auto m_boxes = static_cast<py::ssize_t>(r.boxes.size());
        const auto k = static_cast<py::ssize_t>(r.centres.size());
        auto boxes = new_array({m_boxes, 2, 3});
        float* b = boxes.mutable_data();
        for (py::ssize_t i = 0; i < m_boxes; ++i)
          for (int c = 0; c < 3; ++c) {
            b[6 * i + c] = r.boxes[static_cast<std::size_t>(i)].lo[c];
            b[6 * i + 3 + c] = r.boxes[static_cast<std::size_t>(i)].hi[c];
          }
        auto sizes = new_array({k, 2});
        float* sz = sizes.mutable_data();
        for (py::ssize_t i = 0; i < k; ++i) {
          sz[2 * i] = r.sizes[static_cast<std::size_t>(i)].x;
          sz[2 * i + 1] = r.sizes[static_cast<std::size_t>(i)].y;
        }
        py::dict out;
        out["boxes"] = boxes;
        out["box_level"] = int_array(r.box_level);
        out["box_seed"] = int_array(r.box_seed);
        out["box_direction"] = int_array(r.box_direction);
        out["centres"] = points_array(r.centres);
        out["sizes"] = sizes;
        out["texture"] = int_array(r.texture);
        out["box"] = int_array(r.box);
        out["rotation"] = scalar_array(r.rotation);
        py::dict stats;
        stats["boxes"] = r.boxes.size();
        stats["billboards"] = r.centres.size();
        stats["boxes_per_level"] = r.boxes_per_level;
        stats["billboards_drawn"] = r.billboards_drawn;
        stats["dropped_by_spacing"] = r.dropped_by_spacing;
        out["stats"] = stats;
        return out;
      },
      py::arg("seeds"), py::arg("billboard_size"), py::arg("aspect_min"), py::arg("textures"),
      py::arg("rotate"), py::arg("min_spacing"), py::arg("ellipsoid"), py::arg("seed"),
      py::arg("threads") = 0,
      "Seed-and-box cloud (Torchelsen & Musse 2005 §3, eq. 1): dict of boxes and billboards.");
  m.def("variant_seed", &variant_seed, py::arg("seed"), py::arg("basis"), py::arg("variant"),
        "Generator seed of variant v of basis model b: Rng::stream(seed, b·2¹⁶ + v).");
}

void bind_sprite_atlas(py::module_& m) {
  m.attr("ATLAS_MAX_SPRITES") = kMaxAtlasSprites;
  m.attr("ATLAS_MIN_SIZE") = kMinAtlasSprite;
  m.attr("ATLAS_MAX_SIZE") = kMaxAtlasSprite;
  m.def(
      "sprite_atlas",
      [](const std::string& style, int n, int size, std::uint64_t seed, int threads) {
        AtlasStyle s;
        if (style == "sunny")
          s = AtlasStyle::Sunny;
        else if (style == "rainy")
          s = AtlasStyle::Rainy;
        else if (style == "wispy")
          s = AtlasStyle::Wispy;
        else
          throw py::value_error("style must be 'sunny', 'rainy' or 'wispy', got '" + style + "'");
        if (n < 1 || n > kMaxAtlasSprites) throw py::value_error("n must be in [1, 256]");
        if (size < kMinAtlasSprite || size > kMaxAtlasSprite)
          throw py::value_error("size must be in [8, 512]");
        SpriteAtlas a;
        {
          py::gil_scoped_release release;
          a = sprite_atlas(s, n, size, seed, threads);
        }
        auto img = to_array(a.rgba, {static_cast<py::ssize_t>(a.ny) * a.size,
                                     static_cast<py::ssize_t>(a.nx) * a.size, 4});
        return py::make_tuple(img, py::make_tuple(a.nx, a.ny));
      },
      py::arg("style"), py::arg("n"), py::arg("size"), py::arg("seed"), py::arg("threads") = 0,
      "Procedural sprite atlas: ((H, W, 4) float32 straight-alpha RGBA, (nx, ny) grid).");
  m.def(
      "atlas_grid",
      [](int n) {
        if (n < 1 || n > kMaxAtlasSprites) throw py::value_error("n must be in [1, 256]");
        int nx, ny;
        atlas_grid(n, nx, ny);
        return py::make_tuple(nx, ny);
      },
      py::arg("n"));
}

// Particle clouds of Harris 2002 (model/particles.hpp): generators, bounds, density volume.
void bind_particles(py::module_& m) {
  m.attr("PARTICLES_MAX") = static_cast<py::ssize_t>(kMaxParticles);
  const auto arrays = [](ParticleArrays&& a) {
    const auto n = static_cast<py::ssize_t>(a.size());
    return py::make_tuple(to_array(a.centres, {n, 3}), to_array(a.radii, {n}), to_array(a.tau, {n}),
                          to_array(a.albedo, {n}));
  };
  m.def(
      "particle_fill",
      [arrays](const CloudShape& cloud, int n, float radius_min, float radius_max, float tau,
               float albedo, const Noise* noise, const FbmParams& fbm, float tau_floor,
               std::uint64_t seed, int threads) {
        ParticleFillParams p;
        p.n = n;
        p.radius_min = radius_min;
        p.radius_max = radius_max;
        p.tau = tau;
        p.albedo = albedo;
        p.noise = noise;
        p.fbm = fbm;
        p.tau_floor = tau_floor;
        p.seed = seed;
        p.validate();
        ParticleArrays out;
        {
          py::gil_scoped_release release;
          out = particle_fill(cloud, p, threads);
        }
        return arrays(std::move(out));
      },
      py::arg("cloud"), py::arg("n"), py::arg("radius_min"), py::arg("radius_max"), py::arg("tau"),
      py::arg("albedo"), py::arg("noise").none(true), py::arg("fbm"), py::arg("tau_floor"),
      py::arg("seed"), py::arg("threads"),
      "Fill a cloud's ellipsoid union with particles: (centres, radii, tau, albedo).");

  m.def(
      "particles_from_volume",
      [arrays](const FloatArray& density, V3 lo, V3 hi, int n, float radius, float tau,
               float albedo, float tau_floor, std::uint64_t seed, int threads) {
        if (density.ndim() != 3) throw py::value_error("density must be a (D, H, W) volume");
        VolumeSampleParams p;
        p.n = n;
        p.radius = radius;
        p.tau = tau;
        p.albedo = albedo;
        p.tau_floor = tau_floor;
        p.seed = seed;
        p.validate();
        const float* data = density.data();
        const int d = static_cast<int>(density.shape(0)), h = static_cast<int>(density.shape(1)),
                  w = static_cast<int>(density.shape(2));
        ParticleArrays out;
        {
          py::gil_scoped_release release;
          out = particles_from_volume(data, d, h, w, Box{v3(lo), v3(hi)}, p, threads);
        }
        return arrays(std::move(out));
      },
      py::arg("density"), py::arg("lo"), py::arg("hi"), py::arg("n"), py::arg("radius"),
      py::arg("tau"), py::arg("albedo"), py::arg("tau_floor"), py::arg("seed"), py::arg("threads"),
      "Importance-sample a density volume into particles: (centres, radii, tau, albedo).");

  m.def(
      "particle_sphere",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& tau,
         const FloatArray& albedo) {
        const ParticleView v = particle_view(centres, radii, tau, albedo);
        const Box b = particle_bounds(v);
        const Sphere s = particle_sphere(v);
        return py::make_tuple(py::make_tuple(b.lo.x, b.lo.y, b.lo.z),
                              py::make_tuple(b.hi.x, b.hi.y, b.hi.z),
                              py::make_tuple(s.centre.x, s.centre.y, s.centre.z), s.radius);
      },
      "((lo), (hi), (sphere centre), sphere radius) of a particle cloud, float32 as the core.");

  m.def(
      "particles_to_volume",
      [](const FloatArray& centres, const FloatArray& radii, const FloatArray& tau,
         const FloatArray& albedo, std::array<int, 3> res, V3 lo, V3 hi, int threads) {
        const ParticleView v = particle_view(centres, radii, tau, albedo);
        for (int a = 0; a < 3; ++a)
          if (res[a] < 1 || res[a] > 2048)
            throw py::value_error("resolution must be in [1, 2048] per axis");
        if (static_cast<double>(res[0]) * res[1] * res[2] > double(1 << 28))
          throw py::value_error("resolution has more than 2^28 voxels");
        const Box box{v3(lo), v3(hi)};
        for (int a = 0; a < 3; ++a)
          if (!std::isfinite(box.lo[a]) || !std::isfinite(box.hi[a]) || !(box.hi[a] > box.lo[a]))
            throw py::value_error("box must be finite with hi > lo on every axis");
        auto out = new_array({res[2], res[1], res[0]});
        float* dst = out.mutable_data();
        {
          py::gil_scoped_release release;
          particles_to_volume(v, res[0], res[1], res[2], box, dst, threads);
        }
        return out;
      },
      "Sample the particles' Gaussian-blob extinction on a (nz, ny, nx) grid [z, y, x].");
}

}  // namespace cumuli::bind

namespace cumuli::bind {

namespace {

DeckType parse_deck_type(const std::string& s) {
  if (s == "stratus") return DeckType::Stratus;
  if (s == "stratocumulus") return DeckType::Stratocumulus;
  if (s == "altostratus") return DeckType::Altostratus;
  throw py::value_error(
      "cloud_type must be one of 'stratus', 'stratocumulus', 'altostratus', got '" + s + "'");
}

const char* deck_type_name(DeckType t) {
  switch (t) {
    case DeckType::Stratus:
      return "stratus";
    case DeckType::Stratocumulus:
      return "stratocumulus";
    case DeckType::Altostratus:
      return "altostratus";
  }
  return "?";
}

// A weather map (nz, nx) float32 as a DeckMap view (kept alive by the caller).
DeckMap deck_map(const FloatArray& map) {
  if (map.ndim() != 2) throw py::value_error("coverage map must be a (nz, nx) array");
  DeckMap m{map.data(), static_cast<int>(map.shape(1)), static_cast<int>(map.shape(0))};
  if (map.shape(0) > kMaxDeckMapEdge || map.shape(1) > kMaxDeckMapEdge)
    throw py::value_error("coverage map edges must be at most " + std::to_string(kMaxDeckMapEdge));
  m.validate();
  return m;
}

}  // namespace

// Cloud decks (model/deck.hpp): the shape struct, density at points and on the slab's lattice.
void bind_deck(py::module_& m) {
  m.attr("DECK_MAX_MAP_EDGE") = kMaxDeckMapEdge;
  m.attr("DECK_MAX_LATTICE_EDGE") = kMaxDeckLatticeEdge;
  m.attr("DECK_MAX_VOXELS") = static_cast<py::ssize_t>(kMaxDeckVoxels);
  m.attr("DECK_DETAIL_CONTRAST") = kDeckDetailContrast;
  py::class_<DeckShape>(m, "DeckShape",
                        "A cloud deck's heights, type, density, erosion, fBm, wind offset and "
                        "extent (everything but its weather map).")
      .def(py::init<>())
      .def_readwrite("base", &DeckShape::base)
      .def_readwrite("top", &DeckShape::top)
      .def_property(
          "cloud_type", [](const DeckShape& s) { return std::string(deck_type_name(s.type)); },
          [](DeckShape& s, const std::string& v) { s.type = parse_deck_type(v); })
      .def_readwrite("density", &DeckShape::density)
      .def_readwrite("detail", &DeckShape::detail)
      .def_property(
          "fbm",
          [](const DeckShape& s) {
            return py::make_tuple(s.fbm.octaves, s.fbm.gain, s.fbm.lacunarity, s.fbm.frequency);
          },
          [](DeckShape& s, std::tuple<int, float, float, float> f) {
            s.fbm = FbmParams{std::get<0>(f), std::get<1>(f), std::get<2>(f), std::get<3>(f)};
          },
          "(octaves, gain, lacunarity, frequency) of the detail fBm.")
      .def_property(
          "offset", [](const DeckShape& s) { return py::make_tuple(s.offset_x, s.offset_z); },
          [](DeckShape& s, std::array<float, 2> o) {
            s.offset_x = o[0];
            s.offset_z = o[1];
          },
          "(ox, oz): the map's and the fBm's shift, wind · time.")
      .def_property(
          "extent", [](const DeckShape& s) { return py::make_tuple(s.x0, s.z0, s.x1, s.z1); },
          [](DeckShape& s, std::array<double, 4> e) {
            s.x0 = e[0];
            s.z0 = e[1];
            s.x1 = e[2];
            s.z1 = e[3];
          },
          "(x0, z0, x1, z1): the weather map's extent and the slab's in x and z.")
      .def("validate", [](const DeckShape& s) { s.validate(); });

  m.def(
      "deck_density",
      [](const DeckShape& shape, const FloatArray& map, const Noise& noise,
         const FloatArray& points, int threads) {
        require_points(points, "points");
        const DeckMap view = deck_map(map);
        shape.validate();
        const auto n = static_cast<std::size_t>(points.shape(0));
        auto out = new_array({static_cast<py::ssize_t>(n)});
        float* dst = out.mutable_data();
        const float* src = points.data();
        {
          py::gil_scoped_release release;
          deck_density_many(shape, view, noise, src, n, dst, threads);
        }
        return out;
      },
      py::arg("shape"), py::arg("map"), py::arg("noise"), py::arg("points"), py::arg("threads"),
      "A cloud deck's density at (N, 3) points: (N,) float32.");
  m.def(
      "deck_lattice",
      [](const DeckShape& shape, const FloatArray& map, const Noise& noise,
         std::array<int, 3> resolution, int threads) {
        const DeckMap view = deck_map(map);
        shape.validate();
        const auto [nx, ny, nz] = resolution;
        for (const int e : resolution)
          if (e < 1 || e > kMaxDeckLatticeEdge)
            throw py::value_error("resolution must be in [1, " +
                                  std::to_string(kMaxDeckLatticeEdge) + "] per axis");
        if (static_cast<double>(nx) * ny * nz > static_cast<double>(kMaxDeckVoxels))
          throw py::value_error("resolution has more than 2^27 voxels");
        auto out = new_array({nz, ny, nx});
        float* dst = out.mutable_data();
        {
          py::gil_scoped_release release;
          deck_lattice(shape, view, noise, nx, ny, nz, dst, threads);
        }
        return out;
      },
      py::arg("shape"), py::arg("map"), py::arg("noise"), py::arg("resolution"), py::arg("threads"),
      "A cloud deck's density at the texel centres of its slab: (nz, ny, nx) float32 [z, y, x].");
}

}  // namespace cumuli::bind
