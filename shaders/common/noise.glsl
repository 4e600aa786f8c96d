// fBm noise (Jiménez de Parga & Gómez Palomo 2018, §3.1, eq. 1) — GLSL twin of cpp/src/noise.cpp.
//
// u_lattice is the size³ uniform lattice as an R32F 3D texture with LINEAR filtering and REPEAT
// wrapping, so texture() at u/size is the trilinear lookup of the GL texel-centre convention.
// fbm_exact() does the same blend by hand with texelFetch and float weights, matching the C++ to
// rounding; GPUs filter with low-precision (often 8-bit) weights, so texture() differs slightly.

#include "common/trilinear.glsl"

// Noise versions: version 1 (table) reads its values from u_lattice. Version 2 (hash) gives texel
// (x, y, z) the value lattice_hash() − 1 of its index (z·size + y)·size + x and the key
// u_noise_key, as noise.hpp's Noise::hash_biased does; u_lattice then holds the same values, so
// lattice_hw() serves both versions, and lattice_exact() computes version 2's corners instead of
// fetching them, blends them biased by 1 and takes the 1 off the blend, as the C++ does.
uniform sampler3D u_lattice;
uniform bool u_noise_hash;    // true: version 2 (hash)
uniform uint u_noise_key;     // version 2's key of the seed
uniform int u_octaves;        // n
uniform float u_gain;         // w
uniform float u_lacunarity;   // s
uniform float u_frequency;    // f, lattice texels per world unit

float lattice_hw(vec3 u) {
    return texture(u_lattice, u / vec3(textureSize(u_lattice, 0))).r;
}

// Texel t's value plus 1, in [1, 2) (uint arithmetic wraps modulo 2³², as the C++'s does).
float lattice_hash(ivec3 t, ivec3 size) {
    uint h = (uint((t.z * size.y + t.y) * size.x + t.x) + u_noise_key) * 0x21f0aaadu;
    h ^= h >> 16;
    h *= 0x735a2d97u;
    return uintBitsToFloat((h >> 9) | 0x3f800000u);
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
    if (u_noise_hash) {
        return trilinear_blend(
            lattice_hash(ivec3(i0.x, i0.y, i0.z), size), lattice_hash(ivec3(i1.x, i0.y, i0.z), size),
            lattice_hash(ivec3(i0.x, i1.y, i0.z), size), lattice_hash(ivec3(i1.x, i1.y, i0.z), size),
            lattice_hash(ivec3(i0.x, i0.y, i1.z), size), lattice_hash(ivec3(i1.x, i0.y, i1.z), size),
            lattice_hash(ivec3(i0.x, i1.y, i1.z), size), lattice_hash(ivec3(i1.x, i1.y, i1.z), size),
            w) - 1.0;
    }
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
