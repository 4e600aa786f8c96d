// The physical lighting mode's shading (RENDER_CONTRACT "Physical lighting"; C++ twin:
// cpp/src/rendering/physical.cpp): phase function, scattering octaves, the interleaved-gradient
// jitter, and the lookups of a drawable's physical light (τ_sun on the sun's lattice, the world
// lattice's diffuse sunlight F and sky light S) in atlases.
#include "common/jitter.glsl"
#include "common/phase.glsl"
#include "common/trilinear.glsl"

#define MAX_OCTAVES 8
#define ORDER_PHASE_SIZE 64  // entries per order of u_phys_order_phase (kOrderPhaseSize)

uniform float u_phys_extinction;  // σt = u_phys_extinction · ρ
uniform float u_phys_albedo;      // ϖ
uniform bool u_phys_dual;         // two HG lobes
uniform vec3 u_phys_g;            // g1, g2, weight of the second lobe
uniform bool u_phys_mie;          // the approximate Mie phase instead
uniform vec4 u_phys_mie_p;        // its g_HG, g_D, α, w_D
uniform int u_phys_octaves;       // scattering orders drawn
uniform vec3 u_phys_abc;          // octave constants a, b, c
uniform float u_phys_poisson;     // β of the Poisson weights (0: plain octaves)
uniform bool u_phys_order_table;  // orders ≥ 1 turn by the tabulated phase, not phase(bⁱ·g)
// Order i's phase (i ≥ 1) at sin(θ/2) = k/(ORDER_PHASE_SIZE − 1): entry (i − 1)·SIZE + k, 4 a
// vec4.
uniform vec4 u_phys_order_phase[(MAX_OCTAVES - 1) * ORDER_PHASE_SIZE / 4];
uniform float u_phys_first;       // order 0's depth scale, 1 − f·ϖ (the δ-M sun)
uniform float u_phys_view;        // the radiance's depth scale along the view, 1 − f·ϖ (δ-M view)
uniform float u_phys_diffuse;     // the diffuse light's share of the view's emission, 1 − f
uniform int u_phys_seed;          // jitter seed
uniform float u_phys_min_t;       // the ray stops below this transmittance
// The camera ray's step doubles for each decade its view transmittance falls below this
// (PhysicalParams::coarsen_below; 0: never), looked at after every COARSEN_EVERY samples inside
// the cloud, at most MAX_COARSEN times the step: the C++ marcher's batches, so both take the same
// steps.
uniform float u_phys_coarsen;
#define COARSEN_EVERY 16  // kCoarsenEvery
#define MAX_COARSEN 8.0   // kMaxCoarsen

float phys_coarsening(float T_view) {
    float m = 1.0;
    for (float limit = u_phys_coarsen; m < MAX_COARSEN && T_view < limit; limit *= 0.1) m *= 2.0;
    return m;
}

float phys_phase(float c, float scale) {
    if (u_phys_mie) return approx_mie_phase(u_phys_mie_p, c, scale);
    float p1 = hg_phase(u_phys_g.x * scale, c);
    if (!u_phys_dual) return p1;
    return (1.0 - u_phys_g.z) * p1 + u_phys_g.z * hg_phase(u_phys_g.y * scale, c);
}

float order_phase_entry(int i) {
    return u_phys_order_phase[i >> 2][i & 3];
}

// Order i's phase at cos θ = c: the phase itself for order 0; else the table's row, linear in
// sin(θ/2) = √((1 − c)/2) between its entries (PhysicalParams::order_phase_at; no acos, whose
// accuracy varies between drivers), or phase(bⁱ·g) without one.
float order_phase_at(int order, float c, float b) {
    if (order == 0 || !u_phys_order_table) return phys_phase(c, b);
    float u = sqrt(max(0.5 - 0.5 * c, 0.0));
    float x = min(u, 1.0) * float(ORDER_PHASE_SIZE - 1);
    int k = min(int(x), ORDER_PHASE_SIZE - 2);
    float w = x - float(k);
    int base = (order - 1) * ORDER_PHASE_SIZE + k;
    float v0 = order_phase_entry(base);
    return v0 + w * (order_phase_entry(base + 1) - v0);
}

// Weights aⁱ·pᵢ(c) (order_phase_at) and depth scales cⁱ of the drawn orders (order 0's the δ-M
// sun's, u_phys_first); returns their count.
int octave_terms(float c, out float w[MAX_OCTAVES], out float k[MAX_OCTAVES]) {
    int n = clamp(u_phys_octaves, 1, MAX_OCTAVES);
    float a = 1.0, b = 1.0, s = 1.0;
    for (int i = 0; i < MAX_OCTAVES; ++i) {
        w[i] = 0.0;
        k[i] = 0.0;
        if (i >= n) continue;
        w[i] = a * order_phase_at(i, c, b);
        k[i] = i == 0 ? u_phys_first : s;
        a *= u_phys_abc.x;
        b *= u_phys_abc.y;
        s *= u_phys_abc.z;
    }
    return n;
}

// Σ wᵢ·Pᵢ(τ) of the drawn orders: Pᵢ = e^{−kᵢτ}, times (βτ)ⁱ/i! with the Poisson weights.
float octave_sum(float w[MAX_OCTAVES], float k[MAX_OCTAVES], int n, float tau) {
    bool poisson = u_phys_poisson > 0.0;
    float x = u_phys_poisson * max(tau, 0.0);
    float pw = 1.0;
    float sum = 0.0;
    for (int i = 0; i < MAX_OCTAVES; ++i) {
        if (i >= n) break;
        sum += w[i] * pw * exp(-k[i] * tau);
        if (poisson) pw *= x / float(i + 1);
    }
    return sum;
}

// The camera ray's jitter of pixel (row, col).
float phys_jitter(int row, int col) {
    return ign_jitter(row, col, u_phys_seed);
}

// Trilinear lookup at texel coordinate q (texel centres at i + ½) of a lattice of size `res`
// placed at `offset` in an atlas: hand-blended texelFetch (exact) or the hardware filter with
// the coordinate clamped inside the tile (the same clamp to edge).
vec4 atlas_lookup(sampler3D atlas, ivec3 offset, ivec3 res, vec3 q, bool exact) {
    if (!exact) {
        vec3 u = clamp(q, vec3(0.5), vec3(res) - 0.5) + vec3(offset);
        return texture(atlas, u / vec3(textureSize(atlas, 0)));
    }
    return fetch_trilinear(atlas, offset, res, q - 0.5);
}

// A drawable's physical light in the atlases.
struct PhysicalCloud {
    vec4 fu;      // xyz: the sun frame's u axis; w: frame lo.x
    vec4 fv;      // xyz: v axis; w: lo.y
    vec4 fw;      // xyz: w axis (the way light travels); w: lo.z
    vec4 fhi;     // xyz: frame hi
    ivec4 fres;   // xyz: sun lattice resolution (u, v, w)
    ivec4 foff;   // xyz: its offset in the depth atlas
    vec4 glo;     // xyz: world lattice box
    vec4 ghi;
    ivec4 gres;   // xyz: world lattice resolution (x, y, z)
    ivec4 goff;   // xyz: its offset in the light atlas
};

uniform sampler3D u_depth_atlas;  // R32F τ_sun lattices
uniform sampler3D u_grid_atlas;   // RGBA32F (F, S.rgb) lattices

// ϖ·(E_sun·(Σ octaves + F/4π) + S/4π) at p.
vec3 phys_source(PhysicalCloud c, vec3 p, float w[MAX_OCTAVES], float k[MAX_OCTAVES], int n,
                 vec3 sun_irradiance, bool exact) {
    const float INV_4PI = 0.0795774715459477;
    vec3 fq = vec3(dot(p, c.fu.xyz), dot(p, c.fv.xyz), dot(p, c.fw.xyz));
    vec3 flo = vec3(c.fu.w, c.fv.w, c.fw.w);
    vec3 q = (fq - flo) / (c.fhi.xyz - flo) * vec3(c.fres.xyz);
    float tau = atlas_lookup(u_depth_atlas, c.foff.xyz, c.fres.xyz, q, exact).r;
    vec3 g = (p - c.glo.xyz) / (c.ghi.xyz - c.glo.xyz) * vec3(c.gres.xyz);
    vec4 L = atlas_lookup(u_grid_atlas, c.goff.xyz, c.gres.xyz, g, exact);
    float d = u_phys_diffuse * INV_4PI;
    float sun = octave_sum(w, k, n, tau) + L.x * d;
    return u_phys_albedo * (sun_irradiance * sun + L.yzw * d);
}
