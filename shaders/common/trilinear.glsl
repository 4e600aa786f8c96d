// Trilinear blend of the 8 texels of a cell with float weights w, in the order the C++ uses
// (cpp/src/noise.cpp Noise::blend, cpp/src/march.cpp LightGrid::sample): along x, then y, then z.
// cXYZ is the texel at offset (X, Y, Z) from the cell's lower corner.
vec4 trilinear_blend(vec4 c000, vec4 c100, vec4 c010, vec4 c110,
                     vec4 c001, vec4 c101, vec4 c011, vec4 c111, vec3 w) {
    vec4 c00 = c000 + w.x * (c100 - c000);
    vec4 c10 = c010 + w.x * (c110 - c010);
    vec4 c01 = c001 + w.x * (c101 - c001);
    vec4 c11 = c011 + w.x * (c111 - c011);
    vec4 c0 = c00 + w.y * (c10 - c00);
    vec4 c1 = c01 + w.y * (c11 - c01);
    return c0 + w.z * (c1 - c0);
}

// One channel: the same operations on its first component.
float trilinear_blend(float c000, float c100, float c010, float c110,
                      float c001, float c101, float c011, float c111, vec3 w) {
    return trilinear_blend(vec4(c000), vec4(c100), vec4(c010), vec4(c110),
                           vec4(c001), vec4(c101), vec4(c011), vec4(c111), w).x;
}

// The blend of the fetched texels: trilinear value at texel coordinate x (texel centres at
// integers, i.e. the texel-centre coordinate minus ½) of a res-sized tile placed at `offset` in
// `tex`, clamped to the tile's edge. Exact: texelFetch and the blend above, not the hardware
// filter (whose 8-bit weights differ from the C++).
vec4 fetch_trilinear(sampler3D tex, ivec3 offset, ivec3 res, vec3 x) {
    vec3 f = floor(x);
    vec3 w = x - f;
    ivec3 hi = res - 1;
    ivec3 i0 = clamp(ivec3(f), ivec3(0), hi) + offset;
    ivec3 i1 = clamp(ivec3(f) + 1, ivec3(0), hi) + offset;
    vec4 c000 = texelFetch(tex, ivec3(i0.x, i0.y, i0.z), 0);
    vec4 c100 = texelFetch(tex, ivec3(i1.x, i0.y, i0.z), 0);
    vec4 c010 = texelFetch(tex, ivec3(i0.x, i1.y, i0.z), 0);
    vec4 c110 = texelFetch(tex, ivec3(i1.x, i1.y, i0.z), 0);
    vec4 c001 = texelFetch(tex, ivec3(i0.x, i0.y, i1.z), 0);
    vec4 c101 = texelFetch(tex, ivec3(i1.x, i0.y, i1.z), 0);
    vec4 c011 = texelFetch(tex, ivec3(i0.x, i1.y, i1.z), 0);
    vec4 c111 = texelFetch(tex, ivec3(i1.x, i1.y, i1.z), 0);
    return trilinear_blend(c000, c100, c010, c110, c001, c101, c011, c111, w);
}
