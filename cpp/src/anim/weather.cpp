#include "cumuli/anim/weather.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "cumuli/columns.hpp"
#include "cumuli/rng.hpp"

namespace cumuli {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kZeroWind = 1e-9;
constexpr std::size_t kMaxLayers = 64;

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

int pick(double u, int n) { return std::min(n - 1, static_cast<int>(u * static_cast<double>(n))); }

bool zero_wind(const LayerConfig& l) { return std::hypot(l.wind_x, l.wind_z) < kZeroWind; }

}  // namespace

int LayerConfig::variant_id(int state, int model, int variant) const {
  int offset = 0;
  for (int s = 0; s < state; ++s)
    offset +=
        states[static_cast<std::size_t>(s)].models * states[static_cast<std::size_t>(s)].variants;
  return offset + model * states[static_cast<std::size_t>(state)].variants + variant;
}

int LayerConfig::variant_count() const {
  int n = 0;
  for (const SkyStateConfig& s : states) n += s.models * s.variants;
  return n;
}

void WeatherConfig::validate() const {
  require(std::isfinite(x0) && std::isfinite(z0) && std::isfinite(x1) && std::isfinite(z1) &&
              x1 > x0 && z1 > z0,
          "area must be ((x0, z0), (x1, z1)) with x1 > x0 and z1 > z0, finite");
  require(!layers.empty() && layers.size() <= kMaxLayers, "layers must hold 1 to 64 layers");
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const LayerConfig& l = layers[i];
    const std::string at = "layers[" + std::to_string(i) + "].";
    require(std::isfinite(l.altitude), at + "altitude must be finite");
    require(std::isfinite(l.thickness) && l.thickness >= 0.0, at + "thickness must be >= 0");
    require(std::isfinite(l.wind_x) && std::isfinite(l.wind_z), at + "wind must be finite");
    require(std::isfinite(l.fade_time) && l.fade_time >= 0.0, at + "fade_time must be >= 0");
    require(!l.states.empty() && l.states.size() <= 256, at + "states must hold 1 to 256 states");
    std::uint64_t variants = 0;
    for (std::size_t s = 0; s < l.states.size(); ++s) {
      const SkyStateConfig& st = l.states[s];
      const std::string ss = at + "states[" + std::to_string(s) + "].";
      require(std::isfinite(st.cv) && st.cv >= 0.0 && st.cv <= 1.0, ss + "cv must be in [0, 1]");
      require(s == 0 || st.cv > l.states[s - 1].cv, at + "states must have increasing cv");
      require(st.count >= 0 && static_cast<std::size_t>(st.count) <= kMaxLayerInstances,
              ss + "count must be in [0, 2**20]");
      require(st.models >= 1 && st.models <= 4096, ss + "models must hold 1 to 4096 models");
      require(st.variants >= 1 && st.variants <= 65535, ss + "variants must be in [1, 65535]");
      variants += static_cast<std::uint64_t>(st.models) * static_cast<std::uint64_t>(st.variants);
    }
    require(variants <= (std::uint64_t{1} << 24), at + "too many variants (> 2**24)");
    require(l.radius.size() == variants, at + "radius must have one entry per variant");
    for (double r : l.radius) require(std::isfinite(r) && r >= 0.0, at + "radius must be >= 0");
  }
  require(!schedule.empty(), "cv schedule must hold at least one keyframe");
  for (std::size_t k = 0; k < schedule.size(); ++k) {
    require(std::isfinite(schedule[k].first), "cv schedule times must be finite");
    require(
        std::isfinite(schedule[k].second) && schedule[k].second >= 0.0 && schedule[k].second <= 1.0,
        "cv schedule values must be in [0, 1]");
    require(k == 0 || schedule[k].first > schedule[k - 1].first,
            "cv schedule times must be strictly increasing");
  }
}

struct WeatherSim::Draw {
  std::uint64_t id;
  int state, variant;
  double radius;
  double u_edge, u_pos, u_pos2;
  float y, yaw;
};

WeatherSim::WeatherSim(WeatherConfig config) : config_(std::move(config)) {
  config_.validate();
  layers_.resize(config_.layers.size());
  const double cv0 = cv_at(0.0);
  for (std::size_t l = 0; l < layers_.size(); ++l) {
    const int n = target(l, cv0);
    for (int k = 0; k < n; ++k) spawn_inside(l, draw(l, cv0), -kInf);
  }
}

double WeatherSim::cv_at(double t) const {
  const auto& s = config_.schedule;
  if (t <= s.front().first) return s.front().second;
  if (t >= s.back().first) return s.back().second;
  for (std::size_t k = 1; k < s.size(); ++k) {
    if (t <= s[k].first) {
      const double w = (t - s[k - 1].first) / (s[k].first - s[k - 1].first);
      return std::clamp(s[k - 1].second + w * (s[k].second - s[k - 1].second), 0.0, 1.0);
    }
  }
  return s.back().second;
}

void WeatherSim::mix(std::size_t layer, double cv, int& a, int& b, double& w) const {
  const auto& st = config_.layers[layer].states;
  const int n = static_cast<int>(st.size());
  if (cv <= st.front().cv) {
    a = b = 0;
    w = 0.0;
    return;
  }
  if (cv >= st.back().cv) {
    a = b = n - 1;
    w = 0.0;
    return;
  }
  for (int k = 0; k + 1 < n; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    if (cv >= st[uk].cv && cv < st[uk + 1].cv) {
      a = k;
      b = k + 1;
      w = (cv - st[uk].cv) / (st[uk + 1].cv - st[uk].cv);
      return;
    }
  }
  a = b = n - 1;
  w = 0.0;
}

int WeatherSim::target(std::size_t layer, double cv) const {
  int a, b;
  double w;
  mix(layer, cv, a, b, w);
  const auto& st = config_.layers[layer].states;
  const double n =
      (1.0 - w) * st[static_cast<std::size_t>(a)].count + w * st[static_cast<std::size_t>(b)].count;
  return static_cast<int>(std::floor(n + 0.5));
}

WeatherSim::Draw WeatherSim::draw(std::size_t layer, double cv) {
  LayerState& ls = layers_[layer];
  const LayerConfig& lc = config_.layers[layer];
  Draw d;
  d.id = ls.events++;
  Rng rng = Rng::stream(config_.seed, (static_cast<std::uint64_t>(layer) << 32) + d.id);
  const double u_state = rng.uniform_double(), u_model = rng.uniform_double();
  const double u_variant = rng.uniform_double();
  d.u_edge = rng.uniform_double();
  d.u_pos = rng.uniform_double();
  d.u_pos2 = rng.uniform_double();
  const double u_y = rng.uniform_double(), u_yaw = rng.uniform_double();
  int a, b;
  double w;
  mix(layer, cv, a, b, w);
  d.state = u_state < w ? b : a;
  const SkyStateConfig& st = lc.states[static_cast<std::size_t>(d.state)];
  const int model = pick(u_model, st.models);
  const int variant = pick(u_variant, st.variants);
  d.variant = lc.variant_id(d.state, model, variant);
  d.radius = lc.radius[static_cast<std::size_t>(d.variant)];
  d.y = static_cast<float>(lc.altitude + (u_y - 0.5) * lc.thickness);
  d.yaw = static_cast<float>(360.0 * u_yaw);
  return d;
}

void WeatherSim::push(std::size_t layer, const Draw& d, double x, double z, double fade_in) {
  LayerState& ls = layers_[layer];
  ls.id.push_back(d.id);
  ls.x0.push_back(x);
  ls.z0.push_back(z);
  ls.t0.push_back(t_);
  ls.y.push_back(d.y);
  ls.yaw.push_back(d.yaw);
  ls.variant.push_back(d.variant);
  ls.state.push_back(d.state);
  ls.fade_in.push_back(fade_in);
  ls.fade_out.push_back(kInf);
  ls.spawned += 1;
}

void WeatherSim::spawn_inside(std::size_t layer, const Draw& d, double fade_in) {
  const WeatherConfig& c = config_;
  const double x = c.x0 + d.u_pos * (c.x1 - c.x0);
  const double z = c.z0 + d.u_pos2 * (c.z1 - c.z0);
  push(layer, d, x, z, fade_in);
  LayerState& ls = layers_[layer];
  ls.last_spawn_x.push_back(x);
  ls.last_spawn_z.push_back(z);
  ls.last_spawn_edge.push_back(-1);
}

void WeatherSim::spawn_edge(std::size_t layer, const Draw& d) {
  const WeatherConfig& c = config_;
  const LayerConfig& lc = config_.layers[layer];
  const double speed = std::hypot(lc.wind_x, lc.wind_z);
  const double wx = lc.wind_x / speed, wz = lc.wind_z / speed;
  const double width = c.x1 - c.x0, depth = c.z1 - c.z0;
  // Upwind edges (outward normal n with n·ŵ < 0), weight |n·ŵ|·length: x0 (n = −x̂), x1, z0, z1.
  const double weight[4] = {wx > 0 ? wx * depth : 0.0, wx < 0 ? -wx * depth : 0.0,
                            wz > 0 ? wz * width : 0.0, wz < 0 ? -wz * width : 0.0};
  const double total = weight[0] + weight[1] + weight[2] + weight[3];
  double acc = 0.0;
  int edge = -1;
  for (int e = 0; e < 4; ++e) {
    if (weight[e] <= 0.0) continue;
    edge = e;  // the last upwind edge takes any rounding remainder
    acc += weight[e];
    if (d.u_edge * total < acc) break;
  }
  double x = 0.0, z = 0.0;
  switch (edge) {
    case 0:
      x = c.x0 - d.radius;
      z = c.z0 + d.u_pos * depth;
      break;
    case 1:
      x = c.x1 + d.radius;
      z = c.z0 + d.u_pos * depth;
      break;
    case 2:
      z = c.z0 - d.radius;
      x = c.x0 + d.u_pos * width;
      break;
    default:
      z = c.z1 + d.radius;
      x = c.x0 + d.u_pos * width;
      break;
  }
  push(layer, d, x, z, -kInf);
  LayerState& ls = layers_[layer];
  ls.spawn_edges[static_cast<std::size_t>(edge)] += 1;
  ls.last_spawn_x.push_back(x);
  ls.last_spawn_z.push_back(z);
  ls.last_spawn_edge.push_back(edge);
}

void WeatherSim::remove_if(std::size_t layer, const std::vector<char>& gone) {
  LayerState& ls = layers_[layer];
  std::vector<char> keep(ls.size());
  for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = gone[i] ? 0 : 1;
  keep_rows(keep, ls.id, ls.x0, ls.z0, ls.t0, ls.y, ls.yaw, ls.variant, ls.state, ls.fade_in,
            ls.fade_out);
}

void WeatherSim::step(double dt) {
  require(std::isfinite(dt) && dt >= 0.0, "dt must be finite and >= 0");
  t_ += dt;  // spawns of this step are stamped with the new time (push() reads t_)
  for (std::size_t l = 0; l < layers_.size(); ++l) step_layer(l, t_, dt);
}

void WeatherSim::step_layer(std::size_t layer, double t_new, double dt) {
  LayerState& ls = layers_[layer];
  const LayerConfig& lc = config_.layers[layer];
  const WeatherConfig& c = config_;
  ls.last_spawn_x.clear();
  ls.last_spawn_z.clear();
  ls.last_spawn_edge.clear();
  const double cv = cv_at(t_new);
  const int target_n = target(layer, cv);
  // Fully faded-out instances leave.
  std::vector<char> gone(ls.size(), 0);
  bool any = false;
  for (std::size_t i = 0; i < ls.size(); ++i)
    if (ls.fade_out[i] < kInf && t_new >= ls.fade_out[i] + lc.fade_time) {
      gone[i] = 1;
      any = true;
      ls.faded_out += 1;
    }
  if (any) remove_if(layer, gone);
  auto live_count = [&] {
    int n = 0;
    for (std::size_t i = 0; i < ls.size(); ++i) n += ls.fade_out[i] == kInf ? 1 : 0;
    return n;
  };

  if (zero_wind(lc)) {
    int live = live_count();
    for (; live < target_n; ++live) spawn_inside(layer, draw(layer, cv), t_new);
    for (; live > target_n; --live) {
      const std::uint64_t event = ls.events++;
      Rng rng = Rng::stream(config_.seed, (static_cast<std::uint64_t>(layer) << 32) + event);
      int k = pick(rng.uniform_double(), live);
      for (std::size_t i = 0; i < ls.size(); ++i) {
        if (ls.fade_out[i] != kInf) continue;
        if (k-- == 0) {
          ls.fade_out[i] = t_new;
          break;
        }
      }
    }
    return;
  }

  // Destroy (or wrap) instances entirely outside on a downwind side.
  int live = live_count();
  gone.assign(ls.size(), 0);
  any = false;
  for (std::size_t i = 0; i < ls.size(); ++i) {
    const double x = ls.x0[i] + lc.wind_x * (t_new - ls.t0[i]);
    const double z = ls.z0[i] + lc.wind_z * (t_new - ls.t0[i]);
    const double r = lc.radius[static_cast<std::size_t>(ls.variant[i])];
    const bool out_x = (lc.wind_x > 0 && x - r > c.x1) || (lc.wind_x < 0 && x + r < c.x0);
    const bool out_z = (lc.wind_z > 0 && z - r > c.z1) || (lc.wind_z < 0 && z + r < c.z0);
    if (!out_x && !out_z) continue;
    const bool was_live = ls.fade_out[i] == kInf;
    if (lc.boundary == Boundary::Wrap && was_live && live - 1 < target_n) {
      const Draw d = draw(layer, cv);
      double nx = x, nz = z;  // the tangential coordinate is kept: position-continuous
      if (out_x) nx = lc.wind_x > 0 ? c.x0 - d.radius : c.x1 + d.radius;
      if (out_z) nz = lc.wind_z > 0 ? c.z0 - d.radius : c.z1 + d.radius;
      ls.id[i] = d.id;
      ls.x0[i] = nx;
      ls.z0[i] = nz;
      ls.t0[i] = t_new;
      ls.y[i] = d.y;
      ls.yaw[i] = d.yaw;
      ls.variant[i] = d.variant;
      ls.state[i] = d.state;
      ls.fade_in[i] = -kInf;
      ls.wrapped += 1;
      continue;
    }
    gone[i] = 1;
    any = true;
    ls.destroyed += 1;
    if (was_live) --live;
  }
  if (any) remove_if(layer, gone);

  // Inflow quota and spawns on the upwind edges. The quota grows at the steady-state inflow
  // N*·(|w_x|/W + |w_z|/H) and is capped at the deficit plus a reserve of ⌈√N*⌉ clouds, so that
  // clouds leaving a full layer are replaced at once. (Capped at the bare deficit, the quota
  // restarts from 0 at every exit; exits come at random — under an oblique wind the residence
  // times vary — while refills take a fixed time, and the count sags below N*, by ~4 % for
  // N* = 100 and wind (6, 8) on a 1000-unit square.) Spawns never exceed the deficit.
  const int deficit = std::max(target_n - live, 0);
  const double width = c.x1 - c.x0, depth = c.z1 - c.z0;
  const double reserve = target_n > 0 ? std::ceil(std::sqrt(static_cast<double>(target_n))) : 0.0;
  ls.quota += target_n * (std::abs(lc.wind_x) / width + std::abs(lc.wind_z) / depth) * dt;
  ls.quota = std::min(ls.quota, static_cast<double>(deficit) + reserve);
  const int k = std::min(static_cast<int>(std::floor(ls.quota)), deficit);
  ls.quota -= k;
  for (int s = 0; s < k; ++s) spawn_edge(layer, draw(layer, cv));
}

void WeatherSim::set_state(double t, std::vector<LayerState> layers) {
  require(std::isfinite(t), "t must be finite");
  require(layers.size() == config_.layers.size(), "state must hold one entry per layer");
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const LayerState& s = layers[l];
    const std::size_t n = s.id.size();
    const std::string at = "layers[" + std::to_string(l) + "]: ";
    require(n <= 2 * kMaxLayerInstances, at + "too many instances");
    require(s.x0.size() == n && s.z0.size() == n && s.t0.size() == n && s.y.size() == n &&
                s.yaw.size() == n && s.variant.size() == n && s.state.size() == n &&
                s.fade_in.size() == n && s.fade_out.size() == n,
            at + "instance arrays differ in length");
    const int nv = config_.layers[l].variant_count();
    const int ns = static_cast<int>(config_.layers[l].states.size());
    for (std::size_t i = 0; i < n; ++i) {
      require(s.variant[i] >= 0 && s.variant[i] < nv, at + "variant id out of range");
      require(s.state[i] >= 0 && s.state[i] < ns, at + "state id out of range");
      require(std::isfinite(s.x0[i]) && std::isfinite(s.z0[i]) && std::isfinite(s.t0[i]) &&
                  std::isfinite(s.y[i]) && std::isfinite(s.yaw[i]),
              at + "instance data must be finite");
      require(!std::isnan(s.fade_in[i]) && !std::isnan(s.fade_out[i]),
              at + "fades must not be NaN");
      require(s.id[i] < s.events, at + "instance id beyond the event counter");
    }
    require(std::isfinite(s.quota) && s.quota >= 0.0, at + "quota must be finite and >= 0");
  }
  layers_ = std::move(layers);
  t_ = t;
}

void WeatherSim::positions(std::size_t layer, std::vector<double>& x,
                           std::vector<double>& z) const {
  const LayerState& ls = layers_[layer];
  const LayerConfig& lc = config_.layers[layer];
  const bool still = zero_wind(lc);
  x.resize(ls.size());
  z.resize(ls.size());
  for (std::size_t i = 0; i < ls.size(); ++i) {
    x[i] = still ? ls.x0[i] : ls.x0[i] + lc.wind_x * (t_ - ls.t0[i]);
    z[i] = still ? ls.z0[i] : ls.z0[i] + lc.wind_z * (t_ - ls.t0[i]);
  }
}

std::vector<float> WeatherSim::alpha(std::size_t layer) const {
  const LayerState& ls = layers_[layer];
  const double ft = config_.layers[layer].fade_time;
  std::vector<float> a(ls.size(), 1.0f);
  for (std::size_t i = 0; i < ls.size(); ++i) {
    double in = 1.0, out = 1.0;
    if (ls.fade_in[i] > -kInf) in = ft > 0 ? std::clamp((t_ - ls.fade_in[i]) / ft, 0.0, 1.0) : 1.0;
    if (ls.fade_out[i] < kInf)
      out = ft > 0 ? std::clamp(1.0 - (t_ - ls.fade_out[i]) / ft, 0.0, 1.0) : 0.0;
    a[i] = static_cast<float>(std::min(in, out));
  }
  return a;
}

std::vector<int> WeatherSim::counts(std::size_t layer) const {
  const LayerState& ls = layers_[layer];
  std::vector<int> n(config_.layers[layer].states.size(), 0);
  for (std::size_t i = 0; i < ls.size(); ++i)
    if (ls.fade_out[i] == kInf) n[static_cast<std::size_t>(ls.state[i])] += 1;
  return n;
}

}  // namespace cumuli
