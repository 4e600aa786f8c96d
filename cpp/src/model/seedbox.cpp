#include "cumuli/model/seedbox.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include <glm/geometric.hpp>

#include "cumuli/columns.hpp"
#include "cumuli/parallel.hpp"
#include "cumuli/rng.hpp"

namespace cumuli {

namespace {

constexpr double kPi = 3.141592653589793;
// Largest coordinate a generated box may reach (as the Python side's MAX_COORD).
constexpr double kMaxCoord = 1e15;
// Rejection draws for `ellipsoid` placement before falling back to the box centre (the chance
// of 64 misses at acceptance π/6 is ~1e-20).
constexpr int kMaxEllipsoidTries = 64;
// Billboard streams start here so they never meet the box streams (one per seed box).
constexpr std::uint64_t kBillboardStreams = std::uint64_t{1} << 32;

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

bool finite3(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Uniform integer in [lo, hi] from one draw.
int uniform_int(Rng& rng, int lo, int hi) {
  const double u = rng.uniform_double();
  const int k = lo + static_cast<int>(u * static_cast<double>(hi - lo + 1));
  return std::min(k, hi);
}

struct SeedOutput {
  std::vector<Box> boxes;
  std::vector<int> level, direction;
};

// Children of one seed box (spec §2.1), from the seed box's own stream.
SeedOutput grow_seed(const SeedBoxParams& p, std::uint64_t seed, std::uint64_t index) {
  Rng rng = Rng::stream(seed, index);
  SeedOutput out;
  const glm::dvec3 s(p.centre);
  const glm::dvec3 h(p.half_size);
  const double reach = p.effective_reach();
  const std::size_t n = p.directions.size();
  std::vector<glm::dvec3> dir(n), e1(n), e2(n);
  std::vector<double> cos_half(n);
  for (std::size_t i = 0; i < n; ++i) {
    dir[i] = glm::normalize(glm::dvec3(p.directions[i]));
    cone_frame(dir[i], e1[i], e2[i]);
    cos_half[i] = std::cos(0.5 * double(p.apertures[i]) * kPi / 180.0);
  }
  const float base = p.centre.y - p.half_size.y;
  auto child = [&](int level, std::size_t i) {
    const double u1 = rng.uniform_double(), u2 = rng.uniform_double();
    const double u3 = rng.uniform_double(), u4 = rng.uniform_double();
    // Direction uniform on the cap of half-angle θ_i/2: cos α uniform in [cos(θ_i/2), 1].
    const double c = 1.0 - u1 * (1.0 - cos_half[i]);
    const double sn = std::sqrt(std::max(0.0, 1.0 - c * c));
    const double phi = 2.0 * kPi * u2;
    const glm::dvec3 r = c * dir[i] + sn * (std::cos(phi) * e1[i] + std::sin(phi) * e2[i]);
    const double rho = 1.0 - u3;                                 // ‖R‖ uniform in (0, 1]
    const glm::dvec3 b = s + (double(level) * rho * reach) * r;  // eq. (1)
    const double scale = double(p.child_min) + u4 * double(p.child_max - p.child_min);
    const glm::dvec3 hh = scale * h;
    Box box{glm::vec3(b - hh), glm::vec3(b + hh)};
    if (p.flat_base && box.lo.y < base) {  // keep the box's size, lift it onto the base
      const float lift = base - box.lo.y;
      box.lo.y = base;
      box.hi.y += lift;
    }
    out.boxes.push_back(box);
    out.level.push_back(level);
    out.direction.push_back(static_cast<int>(i));
  };
  for (int level = 1; level <= p.levels; ++level) {
    if (p.count_per == CountPer::Direction) {
      for (std::size_t i = 0; i < n; ++i) {
        const int count = uniform_int(rng, p.boxes_min, p.boxes_max);
        for (int m = 0; m < count; ++m) child(level, i);
      }
    } else {
      const int count = uniform_int(rng, p.boxes_min, p.boxes_max);
      for (int m = 0; m < count; ++m) {
        const std::size_t i = std::min<std::size_t>(
            n - 1, static_cast<std::size_t>(rng.uniform_double() * static_cast<double>(n)));
        child(level, i);
      }
    }
  }
  return out;
}

struct BoxBillboards {
  std::vector<glm::vec3> centres;
  std::vector<glm::vec2> sizes;
  std::vector<int> texture;
  std::vector<float> rotation;
};

BoxBillboards fill_box(const Box& box, const SeedBoxParams& p, const BillboardParams& bb,
                       std::uint64_t seed, std::uint64_t index) {
  Rng rng = Rng::stream(seed, kBillboardStreams + index);
  BoxBillboards out;
  const int count = uniform_int(rng, p.billboards_min, p.billboards_max);
  const glm::vec3 extent = box.hi - box.lo;
  const float mean_half = (0.5f * extent.x + 0.5f * extent.y + 0.5f * extent.z) / 3.0f;
  const float base = p.centre.y - p.half_size.y;
  const std::size_t ntex = bb.textures.size();
  for (int q = 0; q < count; ++q) {
    glm::vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
    if (bb.ellipsoid) {
      int tries = 1;
      auto inside = [](glm::vec3 v) {
        const glm::vec3 x = 2.0f * v - 1.0f;
        return x.x * x.x + x.y * x.y + x.z * x.z <= 1.0f;
      };
      while (!inside(u) && tries < kMaxEllipsoidTries) {
        u = glm::vec3(rng.uniform(), rng.uniform(), rng.uniform());
        ++tries;
      }
      if (!inside(u)) u = glm::vec3(0.5f);
    }
    glm::vec3 c = box.lo + u * extent;
    const float u4 = rng.uniform(), u5 = rng.uniform(), u6 = rng.uniform(), u7 = rng.uniform();
    const float width = (bb.size_min + u4 * (bb.size_max - bb.size_min)) * mean_half;
    const float height = width * (bb.aspect_min + u5 * (1.0f - bb.aspect_min));
    const std::size_t t =
        std::min(ntex - 1, static_cast<std::size_t>(u6 * static_cast<float>(ntex)));
    if (p.flat_base) c.y = std::max(c.y, base + 0.5f * height);  // no sprite below the base
    out.centres.push_back(c);
    out.sizes.emplace_back(width, height);
    out.texture.push_back(bb.textures[t]);
    out.rotation.push_back(bb.rotate ? 360.0f * u7 : 0.0f);
  }
  return out;
}

// Keeps billboards (in order) farther than `spacing` from every kept one; returns the kept mask.
std::vector<char> spacing_filter(const std::vector<glm::vec3>& centres, float spacing) {
  std::vector<char> keep(centres.size(), 0);
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> cells;
  const double inv = 1.0 / double(spacing);
  auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return (static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ULL) ^
           (static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4FULL) ^
           (static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ULL);
  };
  const float s2 = spacing * spacing;
  for (std::size_t i = 0; i < centres.size(); ++i) {
    const glm::vec3 c = centres[i];
    const auto cx = static_cast<std::int64_t>(std::floor(double(c.x) * inv));
    const auto cy = static_cast<std::int64_t>(std::floor(double(c.y) * inv));
    const auto cz = static_cast<std::int64_t>(std::floor(double(c.z) * inv));
    bool ok = true;
    for (std::int64_t dx = -1; dx <= 1 && ok; ++dx)
      for (std::int64_t dy = -1; dy <= 1 && ok; ++dy)
        for (std::int64_t dz = -1; dz <= 1 && ok; ++dz) {
          const auto it = cells.find(key(cx + dx, cy + dy, cz + dz));
          if (it == cells.end()) continue;
          for (std::size_t j : it->second) {
            const glm::vec3 d = centres[j] - c;
            if (glm::dot(d, d) < s2) {
              ok = false;
              break;
            }
          }
        }
    if (ok) {
      keep[i] = 1;
      cells[key(cx, cy, cz)].push_back(i);
    }
  }
  return keep;
}

}  // namespace

void cone_frame(const glm::dvec3& d, glm::dvec3& e1, glm::dvec3& e2) {
  const glm::dvec3 a = std::abs(d.y) > 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  e1 = glm::normalize(glm::cross(d, a));
  e2 = glm::cross(d, e1);
}

float SeedBoxParams::effective_reach() const {
  return reach > 0.0f ? reach : glm::length(half_size);
}

void SeedBoxParams::validate() const {
  require(finite3(centre), "centre must be finite");
  require(finite3(half_size) && half_size.x > 0 && half_size.y > 0 && half_size.z > 0,
          "half_size must be finite and positive on every axis");
  require(!directions.empty() && directions.size() <= std::size_t(kMaxDirections),
          "directions must hold 1 to " + std::to_string(kMaxDirections) + " vectors");
  require(apertures.size() == directions.size(), "apertures must have one entry per direction");
  for (std::size_t i = 0; i < directions.size(); ++i) {
    require(finite3(directions[i]) && glm::length(glm::dvec3(directions[i])) > 1e-12,
            "directions must be finite and non-zero");
    require(std::isfinite(apertures[i]) && apertures[i] >= 0.0f && apertures[i] <= 360.0f,
            "apertures must be in [0, 360] degrees");
  }
  require(levels >= 1 && levels <= kMaxLevels,
          "levels must be in [1, " + std::to_string(kMaxLevels) + "]");
  require(boxes_min >= 0 && boxes_min <= boxes_max && boxes_max <= kMaxBoxesPerLevel,
          "boxes_per_level must satisfy 0 <= min <= max <= " + std::to_string(kMaxBoxesPerLevel));
  require(std::isfinite(reach) && reach >= 0.0f, "reach must be finite and positive");
  require(std::isfinite(child_min) && std::isfinite(child_max) && child_min > 0.0f &&
              child_min <= child_max && child_max <= 4.0f,
          "child_scale must satisfy 0 < min <= max <= 4");
  require(
      billboards_min >= 0 && billboards_min <= billboards_max &&
          billboards_max <= kMaxBillboardsPerBox,
      "billboards_per_box must satisfy 0 <= min <= max <= " + std::to_string(kMaxBillboardsPerBox));
  // The farthest box corner must stay a sane float32 coordinate.
  const double far = std::abs(double(centre.x)) + std::abs(double(centre.y)) +
                     std::abs(double(centre.z)) + double(levels) * double(effective_reach()) +
                     double(child_max) * (double(half_size.x) + half_size.y + half_size.z);
  require(far < kMaxCoord, "reach: centre + levels·reach + half sizes exceeds 1e15");
}

std::uint64_t SeedBoxParams::max_boxes() const {
  const std::uint64_t per_level =
      static_cast<std::uint64_t>(boxes_max) *
      (count_per == CountPer::Direction ? static_cast<std::uint64_t>(directions.size()) : 1u);
  return 1u + static_cast<std::uint64_t>(levels) * per_level;
}

void BillboardParams::validate() const {
  require(std::isfinite(size_min) && std::isfinite(size_max) && size_min > 0.0f &&
              size_min <= size_max && size_max <= 1e3f,
          "billboard_size must satisfy 0 < min <= max <= 1000");
  require(std::isfinite(aspect_min) && aspect_min > 0.0f && aspect_min <= 1.0f,
          "aspect must be in (0, 1]");
  require(!textures.empty() && textures.size() <= std::size_t(kMaxTextures),
          "textures must hold 1 to " + std::to_string(kMaxTextures) + " indices");
  for (int t : textures)
    require(t >= 0 && t < kMaxTextures,
            "textures must be in [0, " + std::to_string(kMaxTextures) + ")");
  require(std::isfinite(min_spacing) && min_spacing >= 0.0f, "min_spacing must be finite and >= 0");
}

void worst_case_counts(const std::vector<SeedBoxParams>& seeds, std::uint64_t& boxes,
                       std::uint64_t& billboards) {
  boxes = 0;
  billboards = 0;
  for (const SeedBoxParams& s : seeds) {
    const std::uint64_t b = s.max_boxes();
    boxes += b;
    billboards += b * static_cast<std::uint64_t>(s.billboards_max);
  }
}

void validate_seed_box_cloud(const std::vector<SeedBoxParams>& seeds, const BillboardParams& bb) {
  require(!seeds.empty() && seeds.size() <= kMaxSeedBoxes,
          "seeds must hold 1 to " + std::to_string(kMaxSeedBoxes) + " seed boxes");
  for (std::size_t j = 0; j < seeds.size(); ++j) {
    try {
      seeds[j].validate();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("seeds[" + std::to_string(j) + "]." + e.what());
    }
  }
  bb.validate();
  std::uint64_t boxes = 0, billboards = 0;
  worst_case_counts(seeds, boxes, billboards);
  require(boxes <= kMaxCloudBoxes, "seeds: up to " + std::to_string(boxes) +
                                       " boxes in the worst case, more than the limit " +
                                       std::to_string(kMaxCloudBoxes));
  require(billboards <= kMaxCloudBillboards,
          "billboards_per_box: up to " + std::to_string(billboards) +
              " billboards in the worst case, more than the limit " +
              std::to_string(kMaxCloudBillboards));
}

BillboardCloudData seed_box_cloud(const std::vector<SeedBoxParams>& seeds,
                                  const BillboardParams& bb, std::uint64_t seed, int threads) {
  validate_seed_box_cloud(seeds, bb);
  const std::size_t nseeds = seeds.size();
  std::vector<SeedOutput> grown(nseeds);
  parallel_for(nseeds, threads, [&](std::size_t j) { grown[j] = grow_seed(seeds[j], seed, j); });

  BillboardCloudData out;
  std::size_t total = nseeds;
  int max_level = 0;
  for (std::size_t j = 0; j < nseeds; ++j) {
    total += grown[j].boxes.size();
    max_level = std::max(max_level, seeds[j].levels);
  }
  out.boxes.reserve(total);
  out.boxes_per_level.assign(static_cast<std::size_t>(max_level) + 1, 0);
  std::vector<int> owner_seed;  // seed box of each box (for the billboard parameters)
  owner_seed.reserve(total);
  auto push = [&](const Box& b, int level, int seed_index, int direction) {
    out.boxes.push_back(b);
    out.box_level.push_back(level);
    out.box_seed.push_back(seed_index);
    out.box_direction.push_back(direction);
    out.boxes_per_level[static_cast<std::size_t>(level)] += 1;
    owner_seed.push_back(seed_index);
  };
  for (std::size_t j = 0; j < nseeds; ++j) {
    const SeedBoxParams& p = seeds[j];
    push(Box{p.centre - p.half_size, p.centre + p.half_size}, 0, static_cast<int>(j), -1);
  }
  for (std::size_t j = 0; j < nseeds; ++j)
    for (std::size_t k = 0; k < grown[j].boxes.size(); ++k)
      push(grown[j].boxes[k], grown[j].level[k], static_cast<int>(j), grown[j].direction[k]);

  const std::size_t m = out.boxes.size();
  std::vector<BoxBillboards> filled(m);
  parallel_for(m, threads, [&](std::size_t k) {
    filled[k] = fill_box(out.boxes[k], seeds[static_cast<std::size_t>(owner_seed[k])], bb, seed, k);
  });
  std::size_t nbb = 0;
  for (const BoxBillboards& f : filled) nbb += f.centres.size();
  out.centres.reserve(nbb);
  for (std::size_t k = 0; k < m; ++k) {
    const BoxBillboards& f = filled[k];
    out.centres.insert(out.centres.end(), f.centres.begin(), f.centres.end());
    out.sizes.insert(out.sizes.end(), f.sizes.begin(), f.sizes.end());
    out.texture.insert(out.texture.end(), f.texture.begin(), f.texture.end());
    out.rotation.insert(out.rotation.end(), f.rotation.begin(), f.rotation.end());
    out.box.insert(out.box.end(), f.centres.size(), static_cast<int>(k));
  }
  out.billboards_drawn = nbb;
  if (bb.min_spacing > 0.0f && nbb > 0) {
    const std::vector<char> keep = spacing_filter(out.centres, bb.min_spacing);
    const std::size_t w =
        keep_rows(keep, out.centres, out.sizes, out.texture, out.rotation, out.box);
    out.dropped_by_spacing = nbb - w;
  }
  return out;
}

std::uint64_t variant_seed(std::uint64_t seed, std::uint64_t basis, std::uint64_t variant) {
  Rng rng = Rng::stream(seed, (basis << 16) + variant);
  return rng.next_u64();
}

}  // namespace cumuli
