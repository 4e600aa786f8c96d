#version 430
// Evaluates phase_4pi of common/phase.glsl at given cosines: the GLSL side of the phase parity
// check (cumuli.light.particles.phase_values(..., backend="gl")).
layout(local_size_x = 64) in;

#include "common/phase.glsl"

layout(std430, binding = 0) readonly buffer Cosines { float cosines[]; };
layout(std430, binding = 1) writeonly buffer Values { float values[]; };

uniform int u_count;
uniform int u_kind;  // 0 rayleigh, 1 isotropic, 2 HG
uniform float u_g;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(u_count)) return;
    values[i] = phase_4pi(u_kind, u_g, cosines[i]);
}
