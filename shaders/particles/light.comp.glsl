#version 430
// Multiple forward scattering light pass of Harris 2002 (§2.2.1, §2.3, Fig. 4; spec harris.md §4):
// the GLSL compute twin of cumuli::particle_light_one (cpp/src/light/particle_light.cpp).
//
// One work group per light. The N_L² light buffer (cleared to 1) lives in an SSBO; particles come
// in processing order (nearest the light first) with their buffer position, footprint radius,
// forward factor a·τ·p_fwd·γ/4π and alpha 1 − e^{−τ} — computed once by the C++ core, so that the
// pixel each particle reads back (a floor of its position) is the C++'s pixel exactly [decision:
// GLSL allows 2.5-ulp divisions and fused multiply-adds, which could move a floor by one pixel].
// Per particle: invocation 0 reads back I_k (pixel, bilinear or solid-angle patch, the C++ order of
// operations) and stores it; barrier; every invocation blends its share of the footprint pixels,
// B ← w·g + (1 − w·α)·B with w = K(d), g = forward·I_k (recurrence (4)); barrier.
layout(local_size_x = 64) in;

#include "common/splat.glsl"

struct Splat {
    float x, y, r_px, fwd, alpha;
    int index, patch_side, pad;
};

layout(std430, binding = 0) readonly buffer Splats { Splat splats[]; };  // [light][order]
layout(std430, binding = 1) writeonly buffer Light { float light[]; };   // [particle][light]
layout(std430, binding = 2) coherent buffer Buffers { float buf[]; };    // [light][y][x]

uniform int u_count;     // N particles
uniform int u_lights;    // L
uniform int u_res;       // N_L
uniform int u_kernel;    // 0 gaussian, 1 hermite
uniform float u_peak;
uniform int u_readback;  // 0 pixel, 1 bilinear, 2 solid angle
uniform bool u_clamp;
uniform int u_quantize;  // 0 or 8

shared float s_g;

float at(int base, int x, int y) { return buf[base + y * u_res + x]; }

float lerp1(float a, float b, float t) {
    precise float v = a + t * (b - a);
    return v;
}

float read_back(int base, Splat s) {
    float top = float(u_res - 1);
    if (u_readback == 0) {
        int ix = int(clamp(floor(s.x), 0.0, top));
        int iy = int(clamp(floor(s.y), 0.0, top));
        return at(base, ix, iy);
    }
    if (u_readback == 1) {
        precise float u = s.x - 0.5;
        precise float v = s.y - 0.5;
        float fu = floor(u), fv = floor(v);
        precise float wx = u - fu;
        precise float wy = v - fv;
        int x0 = int(clamp(fu, 0.0, top)), x1 = int(clamp(fu + 1.0, 0.0, top));
        int y0 = int(clamp(fv, 0.0, top)), y1 = int(clamp(fv + 1.0, 0.0, top));
        float b0 = lerp1(at(base, x0, y0), at(base, x1, y0), wx);
        float b1 = lerp1(at(base, x0, y1), at(base, x1, y1), wx);
        return lerp1(b0, b1, wy);
    }
    int side = s.patch_side;
    precise float half_side = 0.5 * float(side);
    float last = float(u_res - side);
    int ox = int(clamp(floor(s.x - half_side), 0.0, last));
    int oy = int(clamp(floor(s.y - half_side), 0.0, last));
    precise float sum = 0.0;
    for (int y = oy; y < oy + side; ++y)
        for (int x = ox; x < ox + side; ++x) sum += at(base, x, y);
    precise float mean = sum / float(side * side);
    return mean;
}

void main() {
    int l = int(gl_WorkGroupID.x);
    int lid = int(gl_LocalInvocationID.x);
    int size = int(gl_WorkGroupSize.x);
    int base = l * u_res * u_res;
    for (int p = lid; p < u_res * u_res; p += size) buf[base + p] = 1.0;
    memoryBarrierBuffer();
    barrier();
    float top = float(u_res - 1);
    for (int k = 0; k < u_count; ++k) {
        Splat s = splats[l * u_count + k];
        if (lid == 0) {
            float intensity = read_back(base, s);
            light[s.index * u_lights + l] = intensity;
            precise float g = s.fwd * intensity;
            s_g = g;
        }
        memoryBarrierShared();
        barrier();
        float g = s_g;
        int x0 = int(clamp(floor(s.x - s.r_px), 0.0, top));
        int x1 = int(clamp(floor(s.x + s.r_px), 0.0, top));
        int y0 = int(clamp(floor(s.y - s.r_px), 0.0, top));
        int y1 = int(clamp(floor(s.y + s.r_px), 0.0, top));
        int w = x1 - x0 + 1;
        int count = w * (y1 - y0 + 1);
        for (int p = lid; p < count; p += size) {
            int ix = x0 + p % w, iy = y0 + p / w;
            precise float dx = (float(ix) + 0.5) - s.x;
            precise float dy = (float(iy) + 0.5) - s.y;
            precise float d = sqrt(dx * dx + dy * dy) / s.r_px;
            if (!(d < 1.0)) continue;
            float wk = splat_kernel(u_kernel, u_peak, d);
            int idx = base + iy * u_res + ix;
            precise float b = wk * g + (1.0 - wk * s.alpha) * buf[idx];
            if (u_quantize == 8) {
                b = floor(clamp(b, 0.0, 1.0) * 255.0 + 0.5) / 255.0;
            } else if (u_clamp) {
                b = clamp(b, 0.0, 1.0);
            }
            buf[idx] = b;
        }
        memoryBarrierBuffer();
        barrier();
    }
}
