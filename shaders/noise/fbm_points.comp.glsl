#version 430
// fBm (eq. 1) at a list of points: the GPU side of cumuli.gl.fbm, used for C++ ↔ GLSL parity.
//
// Points arrive as a tightly packed float array (x, y, z, x, y, z, ...): a vec3[] in std430 would
// be padded to 16 bytes per element, which numpy (N, 3) arrays are not. One invocation per point;
// the dispatch is two-dimensional so that large batches stay under the 65535 work-group limit.

layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Points { float points[]; };
layout(std430, binding = 1) writeonly buffer Values { float values[]; };

uniform uint u_count;   // number of points in this batch
uniform bool u_exact;   // true: texelFetch + float weights (matches the C++); false: texture()

#include "common/noise.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;
    if (i >= u_count) return;
    vec3 p = vec3(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]);
    values[i] = fbm(p, u_exact);
}
