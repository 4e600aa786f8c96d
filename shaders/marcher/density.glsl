// Cloud density (twin of cpp/src/cloud.cpp): the pseudo-spheroid model of eq. (2) and the
// metaball model of eqs. (19–21). Returns vec2(ρ, γ); ρ = 0 outside the cloud.
#include "common/noise.glsl"
#include "common/intersect.glsl"
#include "marcher/scene_data.glsl"

uniform bool u_exact;  // exact float trilinear lookups (parity) instead of the hardware filter

float primitive_q(int j, vec3 p) {
    Primitive e = prims[j];
    vec3 q = to_unit_frame(p - e.centre.xyz, e.ax0.xyz, e.ax1.xyz, e.ax2.xyz) / e.radii.xyz;
    return length(q);
}

// eq. (2): ρ = fbm(p), γ = exp(−|q_j| / ((1 − κ) + 2κρ)); cloud only where ρ < γ.
vec2 spheroid_density(CloudData c, int j, vec3 p) {
    float q = primitive_q(j, p);
    if (q > 1.0) return vec2(0.0);
    float rho = fbm(p - c.noise.xyz, u_exact);
    float kappa = c.params.x;
    float gamma = exp(-q / ((1.0 - kappa) + 2.0 * kappa * rho));
    if (!(rho < gamma)) return vec2(0.0, gamma);
    return vec2(rho, gamma);
}

// eqs. (19–21): inside where Σ 1/|q_i|² ≥ 1; ρ = fbm(p)·r̄²·φ, γ = 1.
vec2 metaball_density(CloudData c, vec3 p) {
    float field = 0.0;
    int first = c.info.x;
    int count = c.info.y;
    for (int i = 0; i < count; ++i) {
        Primitive e = prims[first + i];
        vec3 q = to_unit_frame(p - e.centre.xyz, e.ax0.xyz, e.ax1.xyz, e.ax2.xyz) / e.radii.xyz;
        float d2 = dot(q, q);
        if (d2 <= 1e-12) { field = 1.0; break; }
        field += 1.0 / d2;
        if (field >= 1.0) break;
    }
    if (field < 1.0) return vec2(0.0);
    return vec2(fbm(p - c.noise.xyz, u_exact) * c.params.y * c.params.z, 1.0);  // (fbm·r̄²)·φ, as the C++
}

vec2 cloud_density(CloudData c, int j, vec3 p) {
    return c.info.z == 1 ? metaball_density(c, p) : spheroid_density(c, j, p);
}
