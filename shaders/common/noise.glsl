// fBm noise (Jiménez de Parga & Gómez Palomo 2018, §3.1, eq. 1) — GLSL twin of cpp/src/noise.cpp.
//
// u_lattice is the size³ uniform lattice as an R32F 3D texture with LINEAR filtering and REPEAT
// wrapping, so texture() at u/size is the trilinear lookup of the GL texel-centre convention.
// fbm_exact() does the same blend by hand with texelFetch and float weights, matching the C++ to
// rounding; GPUs filter with low-precision (often 8-bit) weights, so texture() differs slightly.

#include "common/trilinear.glsl"

uniform sampler3D u_lattice;
uniform int u_octaves;        // n
uniform float u_gain;         // w
uniform float u_lacunarity;   // s
uniform float u_frequency;    // f, lattice texels per world unit

float lattice_hw(vec3 u) {
    return texture(u_lattice, u / vec3(textureSize(u_lattice, 0))).r;
}

float lattice_exact(vec3 u) {
    ivec3 size = textureSize(u_lattice, 0);
    vec3 x = u - 0.5;
    vec3 f = floor(x);
    vec3 w = x - f;
    // Wrap with floor (GLSL's % is undefined for negative operands); % catches rounding to size.
    vec3 fs = vec3(size);
    ivec3 i0 = ivec3(f - fs * floor(f / fs)) % size;
    ivec3 i1 = (i0 + 1) % size;
    float c000 = texelFetch(u_lattice, ivec3(i0.x, i0.y, i0.z), 0).r;
    float c100 = texelFetch(u_lattice, ivec3(i1.x, i0.y, i0.z), 0).r;
    float c010 = texelFetch(u_lattice, ivec3(i0.x, i1.y, i0.z), 0).r;
    float c110 = texelFetch(u_lattice, ivec3(i1.x, i1.y, i0.z), 0).r;
    float c001 = texelFetch(u_lattice, ivec3(i0.x, i0.y, i1.z), 0).r;
    float c101 = texelFetch(u_lattice, ivec3(i1.x, i0.y, i1.z), 0).r;
    float c011 = texelFetch(u_lattice, ivec3(i0.x, i1.y, i1.z), 0).r;
    float c111 = texelFetch(u_lattice, ivec3(i1.x, i1.y, i1.z), 0).r;
    return trilinear_blend(c000, c100, c010, c110, c001, c101, c011, c111, w);
}

// eq. (1): sum over i = 1..n of w^i * lattice(s^i * f * p). `exact` picks the lookup.
float fbm(vec3 p, bool exact) {
    float sum = 0.0;
    float amplitude = 1.0;
    float scale = u_frequency;
    for (int i = 1; i <= u_octaves && i <= 16; ++i) {
        amplitude *= u_gain;
        scale *= u_lacunarity;
        vec3 u = p * scale;
        sum += amplitude * (exact ? lattice_exact(u) : lattice_hw(u));
    }
    return sum;
}
