#include "cumuli/rendering/billboards.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include <glm/geometric.hpp>

#include "cumuli/parallel.hpp"
#include "cumuli/phase.hpp"

namespace cumuli {

namespace {

constexpr float kDegToRad = static_cast<float>(3.14159265358979323846 / 180.0);

// R_y(yaw)·p + offset in double, rounded to float (as BillboardField.world_billboards does).
glm::vec3 to_world(glm::vec3 p, double c, double s, glm::vec3 offset) {
  const double x = c * static_cast<double>(p.x) + s * static_cast<double>(p.z);
  const double z = -s * static_cast<double>(p.x) + c * static_cast<double>(p.z);
  return glm::vec3(static_cast<float>(x + static_cast<double>(offset.x)),
                   static_cast<float>(static_cast<double>(p.y) + static_cast<double>(offset.y)),
                   static_cast<float>(z + static_cast<double>(offset.z)));
}

// R_yᵀ·v: a world vector in an instance's local frame (light/caf.py's _local).
glm::vec3 to_local(glm::vec3 v, double c, double s) {
  const double x = static_cast<double>(v.x), z = static_cast<double>(v.z);
  return glm::vec3(static_cast<float>(c * x - s * z), v.y, static_cast<float>(s * x + c * z));
}

struct Kept {
  std::uint32_t billboard;
  float key;
  float alpha;
  glm::vec3 centre;
};

}  // namespace

void BillboardDrawSettings::validate() const {
  if (fade_near && !(std::isfinite(near_start) && std::isfinite(near_end) && near_start >= 0.0f &&
                     near_start < near_end))
    throw std::invalid_argument("fade_near must be (z0, z1) with 0 <= z0 < z1");
  if (fade_far && !(std::isfinite(range) && range > 0.0f))
    throw std::invalid_argument("fade_far must be a range > 0");
}

BillboardSpriteList billboard_sprites(const std::vector<BillboardVariant>& variants,
                                      const std::vector<BillboardInstance>& instances,
                                      const float* caf, std::size_t columns,
                                      const std::vector<ShadeLight>& lights,
                                      const ShadeParams& params, const SpriteCamera& camera,
                                      const BillboardDrawSettings& settings, int threads) {
  camera.validate();
  params.validate();
  settings.validate();
  for (const BillboardVariant& v : variants) {
    if (v.billboards > 0 && (v.centres == nullptr || v.sizes == nullptr || v.rotation == nullptr ||
                             v.texture == nullptr || v.box == nullptr))
      throw std::invalid_argument("a billboard variant lacks its arrays");
    if (v.texture_base < 0) throw std::invalid_argument("texture_base must be >= 0");
    if (!(v.opacity >= 0.0f && v.opacity <= 1.0f)) throw std::invalid_argument("opacity in [0, 1]");
    for (std::size_t q = 0; q < v.billboards; ++q)
      if (v.box[q] < 0 || static_cast<std::size_t>(v.box[q]) >= v.boxes)
        throw std::invalid_argument("billboard box index out of range");
  }
  for (const BillboardInstance& in : instances) {
    if (in.variant < 0 || static_cast<std::size_t>(in.variant) >= variants.size())
      throw std::invalid_argument("instance variant out of range");
    const BillboardVariant& v = variants[static_cast<std::size_t>(in.variant)];
    const std::size_t need = settings.caf_per_box ? v.boxes : v.billboards;
    if (in.caf_first + need > columns)
      throw std::invalid_argument("instance CAF block out of range");
    if (!(in.alpha >= 0.0f && in.alpha <= 1.0f))
      throw std::invalid_argument("instance alpha in [0, 1]");
    if (!std::isfinite(in.yaw) || !std::isfinite(in.offset.x) || !std::isfinite(in.offset.y) ||
        !std::isfinite(in.offset.z))
      throw std::invalid_argument("instance offset and yaw must be finite");
  }
  if (!lights.empty() && caf == nullptr) throw std::invalid_argument("caf is missing");

  const std::size_t ni = instances.size();
  std::vector<std::vector<Kept>> kept(ni);
  std::vector<float> cloud_key(ni, 0.0f);
  std::vector<double> cos_yaw(ni), sin_yaw(ni);
  parallel_for(ni, threads, [&](std::size_t i) {
    const BillboardInstance& in = instances[i];
    const BillboardVariant& v = variants[static_cast<std::size_t>(in.variant)];
    double c, s;
    yaw_cos_sin(in.yaw, c, s);
    cos_yaw[i] = c;
    sin_yaw[i] = s;
    const glm::vec3 centre = to_world(v.frame.centre, c, s, in.offset);
    const glm::vec3 to_centre = centre - camera.position;
    cloud_key[i] = settings.sort == SpriteSort::Depth ? glm::dot(to_centre, camera.forward)
                                                      : glm::length(to_centre);
    const float alpha_i = v.opacity * in.alpha;
    if (!(alpha_i > 0.0f) || v.billboards == 0) return;
    if (settings.cull &&
        sphere_outside_frustum(to_world(v.sphere_centre, c, s, in.offset), v.sphere_radius, camera))
      return;
    std::vector<Kept>& out = kept[i];
    out.reserve(v.billboards);
    for (std::size_t q = 0; q < v.billboards; ++q) {
      const glm::vec3 p = to_world(v.centres[q], c, s, in.offset);
      const glm::vec3 d = p - camera.position;
      const float z = glm::dot(d, camera.forward);
      if (!(z > camera.near)) continue;
      float a = alpha_i;
      if (settings.fade_near) a *= smoothstep(settings.near_start, settings.near_end, z);
      if (settings.fade_far) a *= 1.0f - smoothstep(0.9f * settings.range, settings.range, z);
      if (!(a > 0.0f)) continue;
      if (settings.cull) {
        Sprite sp;
        sp.centre = p;
        sp.half_size = 0.5f * v.sizes[q];
        sp.rotation = v.rotation[q] * kDegToRad;
        const ScreenSprite scr = project_sprite(sp, camera);
        if (!scr.visible || scr.j0 > scr.j1 || scr.i0 > scr.i1) continue;
      }
      const float key = settings.sort == SpriteSort::Depth ? z : glm::length(d);
      out.push_back(Kept{static_cast<std::uint32_t>(q), key, a, p});
    }
  });

  // Back to front (decreasing key), stable.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> order;  // (instance, index in kept)
  std::size_t total = 0;
  for (const auto& k : kept) total += k.size();
  order.reserve(total);
  if (settings.global_sort) {
    for (std::size_t i = 0; i < ni; ++i)
      for (std::size_t j = 0; j < kept[i].size(); ++j)
        order.emplace_back(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j));
    std::stable_sort(order.begin(), order.end(), [&](const auto& a, const auto& b) {
      return kept[a.first][a.second].key > kept[b.first][b.second].key;
    });
  } else {
    std::vector<std::uint32_t> inst(ni);
    std::iota(inst.begin(), inst.end(), 0u);
    std::stable_sort(inst.begin(), inst.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return cloud_key[a] > cloud_key[b]; });
    for (const std::uint32_t i : inst) {
      std::vector<Kept>& k = kept[i];
      std::stable_sort(k.begin(), k.end(),
                       [](const Kept& a, const Kept& b) { return a.key > b.key; });
      for (std::size_t j = 0; j < k.size(); ++j)
        order.emplace_back(i, static_cast<std::uint32_t>(j));
    }
  }

  BillboardSpriteList out;
  const std::size_t n = order.size(), nl = lights.size();
  out.centre.resize(n);
  out.half.resize(n);
  out.rotation.resize(n);
  out.alpha.resize(n);
  out.texture.resize(n);
  out.colour.assign(n * 12, 0.0f);
  out.instance.resize(n);
  out.billboard.resize(n);
  if (settings.fragment) {
    out.frame.resize(n);
    out.yrange.resize(n);
    out.caf.resize(n * nl);
  }
  // Per instance: the camera's right/up and the lights in its local frame (vertex shading).
  std::vector<glm::vec3> local_right(ni), local_up(ni);
  std::vector<std::vector<ShadeLight>> local_lights(settings.fragment ? 0 : ni);
  if (!settings.fragment) {
    for (std::size_t i = 0; i < ni; ++i) {
      if (kept[i].empty()) continue;
      local_right[i] = to_local(camera.right, cos_yaw[i], sin_yaw[i]);
      local_up[i] = to_local(camera.up, cos_yaw[i], sin_yaw[i]);
      local_lights[i] = lights;
      for (ShadeLight& l : local_lights[i])
        l.direction = to_local(l.direction, cos_yaw[i], sin_yaw[i]);
    }
  }
  const float sx[4] = {-0.5f, 0.5f, 0.5f, -0.5f};
  const float sy[4] = {-0.5f, -0.5f, 0.5f, 0.5f};
  parallel_for(n, threads, [&](std::size_t k) {
    const auto [i, j] = order[k];
    const Kept& e = kept[i][j];
    const BillboardInstance& in = instances[i];
    const BillboardVariant& v = variants[static_cast<std::size_t>(in.variant)];
    const std::size_t q = e.billboard;
    out.centre[k] = e.centre;
    out.half[k] = 0.5f * v.sizes[q];
    out.rotation[k] = v.rotation[q];
    out.alpha[k] = e.alpha;
    out.texture[k] = v.texture[q] + v.texture_base;
    out.instance[k] = i;
    out.billboard[k] = static_cast<std::uint32_t>(q);
    const std::size_t column =
        in.caf_first + (settings.caf_per_box ? static_cast<std::size_t>(v.box[q]) : q);
    if (settings.fragment) {
      const glm::vec3 c = to_world(v.frame.centre, cos_yaw[i], sin_yaw[i], in.offset);
      out.frame[k] = glm::vec4(c, v.frame.radius);
      out.yrange[k] = glm::vec2(v.frame.y_lo + in.offset.y, v.frame.y_hi + in.offset.y);
      for (std::size_t l = 0; l < nl; ++l) out.caf[k * nl + l] = caf[l * columns + column];
      return;
    }
    // billboard_corners in the local frame, then shade_point (light/caf.cpp).
    double rc, rs;
    yaw_cos_sin(v.rotation[q], rc, rs);
    const glm::vec3 r2 =
        static_cast<float>(rc) * local_right[i] + static_cast<float>(rs) * local_up[i];
    const glm::vec3 u2 =
        static_cast<float>(-rs) * local_right[i] + static_cast<float>(rc) * local_up[i];
    for (int corner = 0; corner < 4; ++corner) {
      const glm::vec3 p =
          v.centres[q] + (sx[corner] * v.sizes[q].x) * r2 + (sy[corner] * v.sizes[q].y) * u2;
      const glm::vec3 col = shade_point(p, v.frame, caf + column, columns, local_lights[i], params);
      out.colour[12 * k + 3 * corner] = col.x;
      out.colour[12 * k + 3 * corner + 1] = col.y;
      out.colour[12 * k + 3 * corner + 2] = col.z;
    }
  });
  return out;
}

}  // namespace cumuli
