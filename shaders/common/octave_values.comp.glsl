#version 430
// Evaluates octave_sum of common/physical.glsl (the drawn orders' octave term) at given optical
// depths for one cosine: the GLSL side of the octave parity check
// (cumuli.rendering.physical_gl.octave_sum_gl).
layout(local_size_x = 64) in;

#include "common/physical.glsl"

layout(std430, binding = 0) readonly buffer Depths { float depths[]; };
layout(std430, binding = 1) writeonly buffer Values { float values[]; };

uniform int u_count;
uniform float u_cos;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(u_count)) return;
    float w[MAX_OCTAVES];
    float k[MAX_OCTAVES];
    int n = octave_terms(u_cos, w, k);
    values[i] = octave_sum(w, k, n, depths[i]);
}
