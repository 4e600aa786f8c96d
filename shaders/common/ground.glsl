// The ground (RENDER_CONTRACT "Ground"; C++ twin: cpp/src/rendering/ground.cpp): a Lambertian
// plane y = height, the background of the rays that meet it from above, the sky's elsewhere.
//   L = albedo/π · (E_sun·max(sun.y, 0)·T_shadow(x, z) + E_sky)
// T_shadow: the shadow map, bilinear over its extent (texel centres, clamped), 1 outside.
#include "common/sky.glsl"

uniform bool u_ground;             // the scene has a ground
uniform float u_ground_height;
uniform vec3 u_ground_albedo;
uniform vec3 u_ground_sky;         // the sky's irradiance on the plane
uniform bool u_shadow_on;          // a shadow map is bound
uniform vec4 u_shadow_extent;      // x0, z0, x1, z1
uniform sampler2D u_shadow;        // R32F [z][x]

float ground_shadow(float x, float z) {
    if (!u_shadow_on || x < u_shadow_extent.x || x > u_shadow_extent.z || z < u_shadow_extent.y ||
        z > u_shadow_extent.w) return 1.0;
    ivec2 n = textureSize(u_shadow, 0);
    float u = (x - u_shadow_extent.x) / (u_shadow_extent.z - u_shadow_extent.x) * float(n.x) - 0.5;
    float v = (z - u_shadow_extent.y) / (u_shadow_extent.w - u_shadow_extent.y) * float(n.y) - 0.5;
    float fu = floor(u), fv = floor(v);
    float wu = u - fu, wv = v - fv;
    int i0 = clamp(int(fu), 0, n.x - 1), i1 = clamp(int(fu) + 1, 0, n.x - 1);
    int j0 = clamp(int(fv), 0, n.y - 1), j1 = clamp(int(fv) + 1, 0, n.y - 1);
    float c00 = texelFetch(u_shadow, ivec2(i0, j0), 0).r;
    float c10 = texelFetch(u_shadow, ivec2(i1, j0), 0).r;
    float c01 = texelFetch(u_shadow, ivec2(i0, j1), 0).r;
    float c11 = texelFetch(u_shadow, ivec2(i1, j1), 0).r;
    float a = c00 + wu * (c10 - c00);
    float b = c01 + wu * (c11 - c01);
    return a + wv * (b - a);
}

vec3 background(vec3 o, vec3 d, vec3 sun_dir, vec3 sun_radiance) {
    if (u_ground && o.y > u_ground_height && d.y < 0.0) {
        float t = (u_ground_height - o.y) / d.y;
        vec3 x = o + t * d;
        float lit = max(sun_dir.y, 0.0) * ground_shadow(x.x, x.z);
        const float INV_PI = 0.3183098861837907;
        return u_ground_albedo * INV_PI * (sun_radiance * lit + u_ground_sky);
    }
    return sky(d, sun_dir, sun_radiance);
}
