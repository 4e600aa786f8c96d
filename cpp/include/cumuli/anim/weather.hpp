// Animated skies with climatic variation, wind and layers (Torchelsen & Musse 2005, §4, Fig. 8,
// Table 1).
//
// A layer holds sky states sorted by their climatic value cv (0 sunny … 1 stormy), each with NC
// clouds drawn from NBM basis models × NM variants. One schedule CV(t) (piecewise linear, clamped)
// drives every layer; with cv_a ≤ CV ≤ cv_b and w = (CV − cv_a)/(cv_b − cv_a) the layer's target is
// N* = round((1 − w)·NC_a + w·NC_b) and a new cloud comes from state b with probability w.
//
// Step(dt), per layer (§7): t += dt; advect every instance by the wind (positions are kept as
// spawn point + w·(t − t_spawn), exact); destroy those whose bounding circle (radius R of its
// variant, in xz) lies entirely outside the area on a downwind side (boundary "wrap": re-enter it
// at once on the opposite, upwind edge with a new draw when the layer is not above N*); inflow
// quota q += N*·(|w_x|/W + |w_z|/H)·dt, capped at (N* − n) + ⌈√N*⌉ (a reserve, see
// step_layer); spawn min(⌊q⌋, N* − n) clouds on the upwind edges (edge chosen ∝ |n_e·ŵ|·length,
// uniform along it, R outside it). Zero wind
// (|w| < 1e−9): nothing moves; a deficit spawns at uniform positions fading in over fade_time, an
// excess fades out randomly chosen instances. At t = 0 the layer holds N*(CV(0)) instances
// uniform in the area. Every spawn or fade event draws from its own stream
// Rng::stream(seed, layer·2³² + event), so the state is reproducible from (instances, quota,
// event counter, t).
#pragma once

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace cumuli {

enum class Boundary { Respawn, Wrap };

constexpr std::size_t kMaxLayerInstances = std::size_t{1} << 20;

struct SkyStateConfig {
  double cv = 0.0;
  int count = 0;     // NC
  int models = 1;    // NBM
  int variants = 1;  // NM
};

struct LayerConfig {
  double altitude = 0.0, thickness = 0.0;
  double wind_x = 0.0, wind_z = 0.0;
  std::vector<SkyStateConfig> states;  // sorted by cv (strictly increasing)
  std::vector<double> radius;          // bounding-circle radius per variant id (state-major)
  Boundary boundary = Boundary::Respawn;
  double fade_time = 10.0;
  // Variant id of (state, model, variant): offset of the state + model·NM + variant.
  int variant_id(int state, int model, int variant) const;
  int variant_count() const;
};

struct WeatherConfig {
  double x0 = -500, z0 = -500, x1 = 500, z1 = 500;
  std::vector<LayerConfig> layers;
  std::vector<std::pair<double, double>> schedule;  // (t, cv), t strictly increasing
  std::uint64_t seed = 0;

  void validate() const;  // std::invalid_argument naming the parameter
};

// The instances of one layer (structure of arrays) and its bookkeeping.
struct LayerState {
  std::vector<std::uint64_t> id;          // the spawn event that created it (unique per layer)
  std::vector<double> x0, z0, t0;         // spawn position and time
  std::vector<float> y, yaw;              // height, yaw in degrees
  std::vector<int> variant, state;        // variant id, source state
  std::vector<double> fade_in, fade_out;  // start times (−inf / +inf: none)
  double quota = 0.0;
  std::uint64_t events = 0;                    // spawn/fade events drawn so far
  std::array<std::uint64_t, 4> spawn_edges{};  // spawns on edges x0, x1, z0, z1
  std::uint64_t spawned = 0, destroyed = 0, wrapped = 0, faded_out = 0;
  std::vector<double> last_spawn_x, last_spawn_z;  // spawns of the last step (or the start)
  std::vector<int> last_spawn_edge;                // 0..3, −1 inside (zero wind / start)

  std::size_t size() const { return id.size(); }
};

class WeatherSim {
 public:
  // Validates the configuration and builds the initial state at t = 0.
  explicit WeatherSim(WeatherConfig config);

  void step(double dt);

  double time() const { return t_; }
  double cv() const { return cv_at(t_); }
  double cv_at(double t) const;
  // (a, b, w) and N* of a layer at a climatic value.
  void mix(std::size_t layer, double cv, int& a, int& b, double& w) const;
  int target(std::size_t layer, double cv) const;

  const WeatherConfig& config() const { return config_; }
  const LayerState& layer(std::size_t i) const { return layers_[i]; }
  // Replaces the state (load); validates sizes and indices.
  void set_state(double t, std::vector<LayerState> layers);

  // Current xz positions and alpha of a layer's instances.
  void positions(std::size_t layer, std::vector<double>& x, std::vector<double>& z) const;
  std::vector<float> alpha(std::size_t layer) const;
  // Instances not fading out, per state.
  std::vector<int> counts(std::size_t layer) const;

 private:
  struct Draw;
  Draw draw(std::size_t layer, double cv);
  void spawn_edge(std::size_t layer, const Draw& d);
  void spawn_inside(std::size_t layer, const Draw& d, double fade_in);
  void push(std::size_t layer, const Draw& d, double x, double z, double fade_in);
  void remove_if(std::size_t layer, const std::vector<char>& gone);
  void step_layer(std::size_t layer, double t_new, double dt);

  WeatherConfig config_;
  std::vector<LayerState> layers_;
  double t_ = 0.0;
};

}  // namespace cumuli
