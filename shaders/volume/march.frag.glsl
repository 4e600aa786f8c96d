#version 430
// Emission–absorption march through a lit density volume (Iwasaki et al. 2011 rendering).
// GLSL twin of cpp/src/volume_march.cpp: same ray, same equal steps, same trilinear lookups
// (done by hand with texelFetch so the weights are full float, as in C++), same light:
//   S = albedo·(sun·τ_sun·HG(g, d·sun) + E_sky/4π), colour += T·(1 − e^{−σ_t ρ h})·S, T *= e^{−σ_t ρ h}.
// u_density: R32F [z][y][x]; u_light: RGBA32F (τ_sun, E_sky RGB). The sky (background) and the
// phase function are the render pass's shared pieces.

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

void main() {
  float aspect = u_resolution.x / u_resolution.y;
  float sx = (2.0 * gl_FragCoord.x / u_resolution.x - 1.0) * u_tan_half_fov * aspect;
  float sy = (2.0 * gl_FragCoord.y / u_resolution.y - 1.0) * u_tan_half_fov;
  vec3 d = normalize(u_cam_forward + sx * u_cam_right + sy * u_cam_up);

  vec3 colour = vec3(0.0);
  float T = 1.0;
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
    for (int k = 0; k < n && T >= u_phys_min_t; ++k) {
      vec3 x = u_cam_pos + (t0 + (float(k) + xi) * h) * d;
      float rho = trilinear(u_density, x).r;
      if (rho <= 0.0) continue;
      float dtau = exp(-u_sigma_t * rho * h);
      colour += T * (1.0 - dtau) * phys_source(phys[0], x, ow, ok, no, u_sun_radiance, u_exact_light);
      T *= dtau;
    }
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
#endif
  }
  vec3 rgb = u_with_sky ? colour + T * sky(d, u_sun_dir, u_sun_radiance) : colour;
  frag_colour = vec4(rgb, 1.0 - T);
}
