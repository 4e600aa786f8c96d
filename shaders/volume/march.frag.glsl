#version 430
// Emission–absorption march through a lit density volume (Iwasaki et al. 2011 rendering).
// GLSL twin of cpp/src/volume_march.cpp: same ray, same equal steps, same trilinear lookups
// (done by hand with texelFetch so the weights are full float, as in C++), same light:
//   S = albedo·(sun·τ_sun·HG(g, d·sun) + E_sky/4π), colour += T·(1 − e^{−σ_t ρ h})·S, T *= e^{−σ_t ρ h}.
// u_density: R32F [z][y][x]; u_light: RGBA32F (τ_sun, E_sky RGB). The sky (background) and the
// phase function are the render pass's shared pieces. The physical mode may read the density
// as a tricubic B-spline eroded by the scene's fBm (density_at, eroded below).

#include "common/sky.glsl"
#include "common/phase.glsl"
#include "common/trilinear.glsl"
#include "common/solid.glsl"
#ifdef PHYSICAL
// The physical lighting mode (RENDER_CONTRACT "Physical lighting"): σ = σ_t·ρ, samples at
// (k + ξ)·h, physical.glsl's shading; u_light is not read.
#include "common/physical.glsl"
layout(std430, binding = 2) readonly buffer Physical { PhysicalCloud phys[]; };
uniform bool u_exact_light;
// The sharp-volume reconstruction (C++: VolumeRenderParams cubic, detail): the tricubic
// B-spline of the density, eroded by the scene's fBm (common/noise.glsl's u_lattice at
// u_frequency = the detail frequency).
#include "common/noise.glsl"
uniform bool u_cubic;
uniform float u_detail;
uniform float u_detail_inv_max;
#endif

uniform sampler3D u_density;
uniform sampler3D u_light;
uniform vec3 u_box_min;
uniform vec3 u_box_max;
uniform vec3 u_cam_pos;
uniform vec3 u_cam_forward;
uniform vec3 u_cam_right;
uniform vec3 u_cam_up;
uniform float u_tan_half_fov;
uniform vec2 u_resolution;
uniform vec3 u_sun_dir;
uniform vec3 u_sun_radiance;
uniform float u_sigma_t;
uniform float u_albedo;
uniform float u_g;
uniform float u_step;
uniform int u_max_steps;
uniform bool u_with_sky;  // false: the premultiplied layer (colour, 1 − T) for the compositor

out vec4 frag_colour;

const float INV_4PI = 0.0795774715459477;
const float MIN_TRANSMITTANCE = 1e-4;

// Trilinear, GL texel centres, clamp to edge (C++: sample_trilinear).
vec4 trilinear(sampler3D tex, vec3 p) {
  ivec3 n = textureSize(tex, 0);
  vec3 u = (p - u_box_min) / ((u_box_max - u_box_min) / vec3(n)) - 0.5;
  return fetch_trilinear(tex, ivec3(0), n, u);
}

#ifdef PHYSICAL
// The tricubic B-spline at p as eight trilinear lookups (C++: sample_cubic_bspline).
void bspline_axis(float u, out float h0, out float h1, out float g0, out float g1) {
  float x = u - 0.5;
  float i = floor(x);
  float f = x - i;
  float f2 = f * f;
  float f3 = f2 * f;
  float w0 = (1.0 - 3.0 * f + 3.0 * f2 - f3) / 6.0;
  float w1 = (4.0 - 6.0 * f2 + 3.0 * f3) / 6.0;
  float w2 = (1.0 + 3.0 * f + 3.0 * f2 - 3.0 * f3) / 6.0;
  float w3 = f3 / 6.0;
  g0 = w0 + w1;
  g1 = w2 + w3;
  h0 = i - 1.0 + w1 / g0 + 0.5;
  h1 = i + 1.0 + w3 / g1 + 0.5;
}

float density_at(vec3 p) {
  if (!u_cubic) return trilinear(u_density, p).r;
  vec3 vs = (u_box_max - u_box_min) / vec3(textureSize(u_density, 0));
  vec3 u = (p - u_box_min) / vs;
  vec2 hx, hy, hz, gx, gy, gz;
  bspline_axis(u.x, hx.x, hx.y, gx.x, gx.y);
  bspline_axis(u.y, hy.x, hy.y, gy.x, gy.y);
  bspline_axis(u.z, hz.x, hz.y, gz.x, gz.y);
  float sum = 0.0;
  for (int c = 0; c < 2; ++c)
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        vec3 q = u_box_min + vec3(hx[a], hy[b], hz[c]) * vs;
        sum += gx[a] * gy[b] * gz[c] * trilinear(u_density, q).r;
      }
  return sum;
}

// The eroded density (C++: erode_density): ρ' = max(ρn − e, 0)/(1 − e)/inv_max.
float eroded(float rho, vec3 p) {
  if (!(u_detail > 0.0)) return rho;
  float top = 0.0;
  float a = 1.0;
  for (int i = 0; i < u_octaves && i < 16; ++i) {
    a *= u_gain;
    top += a;
  }
  float n = top > 0.0 ? fbm(p, u_exact_light) / top : 0.0;
  float e = u_detail * n;
  float rn = min(rho * u_detail_inv_max, 1.0);
  return max(rn - e, 0.0) / (1.0 - e) / u_detail_inv_max;
}
#endif

void main() {
  float aspect = u_resolution.x / u_resolution.y;
  float sx = (2.0 * gl_FragCoord.x / u_resolution.x - 1.0) * u_tan_half_fov * aspect;
  float sy = (2.0 * gl_FragCoord.y / u_resolution.y - 1.0) * u_tan_half_fov;
  vec3 d = normalize(u_cam_forward + sx * u_cam_right + sy * u_cam_up);

  vec3 colour = vec3(0.0);
  float T = 1.0;
  float T_view = 1.0;  // the radiance's transmittance (the physical mode's δ-M view; else T)
  // Slab test (C++: intersect(Box, ...)).
  vec3 inv = 1.0 / d;
  vec3 ta = (u_box_min - u_cam_pos) * inv;
  vec3 tb = (u_box_max - u_cam_pos) * inv;
  vec3 tmin = min(ta, tb);
  vec3 tmax = max(ta, tb);
  float t_in = max(max(tmin.x, tmin.y), tmin.z);
  float t_out = min(min(tmax.x, tmax.y), tmax.z);
  float t0 = max(t_in, 0.0);
  // Opaque solids: march only up to the nearest one (+∞ without solids; C++ the same).
  int solid_index;
  bool hit = t_out >= t_in;
  if (hit) t_out = min(t_out, nearest_solid(u_cam_pos, d, solid_index));
  if (hit && t_out > t0) {
    float len = t_out - t0;
    int n = clamp(int(ceil(len / u_step)), 1, u_max_steps);
    float h = len / float(n);
#ifdef PHYSICAL
    float ow[MAX_OCTAVES];
    float ok[MAX_OCTAVES];
    int no = octave_terms(dot(d, u_sun_dir), ow, ok);
    int row = int(u_resolution.y) - 1 - int(gl_FragCoord.y);
    float xi = phys_jitter(row, int(gl_FragCoord.x));
    for (int k = 0; k < n && T_view >= u_phys_min_t; ++k) {
      vec3 x = u_cam_pos + (t0 + (float(k) + xi) * h) * d;
      float rho = density_at(x);
      if (!(rho > 0.0)) continue;
      rho = eroded(rho, x);
      if (!(rho > 0.0)) continue;
      float dtau = exp(-u_sigma_t * rho * h);
      // The radiance sees σ·u_phys_view (the δ-M view); each unit of σ emits the source.
      float dview = exp(-u_sigma_t * rho * u_phys_view * h);
      colour += T_view * ((1.0 - dview) / u_phys_view) *
                phys_source(phys[0], x, ow, ok, no, u_sun_radiance, u_exact_light);
      T *= dtau;
      T_view *= dview;
    }
    // Stopped: opaque, as the 2018 marcher's (no light from behind leaks through the rest).
    if (T_view < u_phys_min_t) { T = 0.0; T_view = 0.0; }
#else
    float phase = hg_phase(u_g, dot(d, u_sun_dir));
    for (int k = 0; k < n && T >= MIN_TRANSMITTANCE; ++k) {
      vec3 x = u_cam_pos + (t0 + (float(k) + 0.5) * h) * d;
      float rho = trilinear(u_density, x).r;
      if (rho <= 0.0) continue;
      vec4 L = trilinear(u_light, x);
      vec3 S = u_albedo * (u_sun_radiance * (L.x * phase) + L.yzw * INV_4PI);
      float dtau = exp(-u_sigma_t * rho * h);
      colour += T * (1.0 - dtau) * S;
      T *= dtau;
    }
    T_view = T;
#endif
  }
  vec3 rgb = u_with_sky ? colour + T_view * sky(d, u_sun_dir, u_sun_radiance) : colour;
  frag_colour = vec4(rgb, 1.0 - T);
}
