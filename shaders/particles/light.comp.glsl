#version 430
// Multiple forward scattering light pass of Harris 2002 (§2.2.1, §2.3, Fig. 4):
// the GLSL compute twin of cumuli::particle_light_one (cpp/src/light/particles.cpp).
//
// One work group per light. The N_L² light buffer (1 everywhere, uploaded) lives in an SSBO; particles come
// in processing order (nearest the light first) with their buffer position, footprint radius,
// forward factor a·τ·p_fwd·γ/4π and alpha 1 − e^{−τ} — computed once by the C++ core, so that the
// pixel each particle reads back (a floor of its position) is the C++'s pixel exactly [decision:
// GLSL allows 2.5-ulp divisions and fused multiply-adds, which could move a floor by one pixel].
// Per particle: invocation 0 reads back I_k (pixel, bilinear or solid-angle patch, the C++ order of
// operations) and stores it; barrier; every invocation blends its share of the footprint pixels,
// B ← w·g + (1 − w·α)·B with w = K(d), g = forward·I_k (recurrence (4)); barrier.
//
// One dispatch handles the particles [u_first, u_end) of the processing order; the buffer persists
// between dispatches. llvmpipe stops a shader after 65535 loop iterations per invocation (its loop
// limiter), so the host splits the particles into dispatches within a budget of iterations
// (cumuli/light/particles_gl.py) — harmless on GPUs, where the split only adds dispatches.
#ifndef LOCAL_SIZE
#define LOCAL_SIZE 64
#endif
#define MAX_PATCH 4096
layout(local_size_x = LOCAL_SIZE) in;

#include "common/splat.glsl"

struct Splat {
    float x, y, r_px, fwd, alpha;
    int index, patch_side, pad;
};

layout(std430, binding = 0) readonly buffer Splats { Splat splats[]; };  // [light][order]
layout(std430, binding = 1) writeonly buffer Light { float light[]; };   // [particle][light]
layout(std430, binding = 2) coherent buffer Buffers { float buf[]; };    // [light][y][x]

uniform int u_count;     // N particles
uniform int u_first;     // first particle (processing order) of this dispatch
uniform int u_end;       // one past the last
uniform int u_lights;    // L
uniform int u_res;       // N_L
uniform int u_kernel;    // 0 gaussian, 1 hermite
uniform float u_peak;
uniform int u_readback;  // 0 pixel, 1 bilinear, 2 solid angle
uniform bool u_clamp;
uniform int u_quantize;  // 0 or 8

shared float s_g;
shared float s_rows[MAX_PATCH];  // row sums of the solid-angle patch

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
    // Solid-angle patch: the row sums were left in s_rows by every invocation (see main).
    int side = s.patch_side;
    precise float sum = 0.0;
    for (int y = 0; y < side; ++y) sum += s_rows[y];
    precise float mean = sum / float(side * side);
    return mean;
}

void main() {
    int l = int(gl_WorkGroupID.x);
    int lid = int(gl_LocalInvocationID.x);
    int size = int(gl_WorkGroupSize.x);
    int base = l * u_res * u_res;
    float top = float(u_res - 1);
    for (int k = u_first; k < u_end; ++k) {
        Splat s = splats[l * u_count + k];
        if (u_readback == 2) {
            // Patch rows in parallel, each summed in x order (the C++ order), then row sums in
            // y order by invocation 0.
            int side = s.patch_side;
            precise float half_side = 0.5 * float(side);
            float last = float(u_res - side);
            int ox = int(clamp(floor(s.x - half_side), 0.0, last));
            int oy = int(clamp(floor(s.y - half_side), 0.0, last));
            for (int row = lid; row < side; row += size) {
                precise float acc = 0.0;
                for (int x = ox; x < ox + side; ++x) acc += at(base, x, oy + row);
                s_rows[row] = acc;
            }
            memoryBarrierShared();
            barrier();
        }
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
            if (d < 1.0) {
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
        }
        memoryBarrierBuffer();
        barrier();
    }
}
