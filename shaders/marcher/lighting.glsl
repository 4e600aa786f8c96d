// Algorithm 3 (lighting and shading): the light grid lookup and one sample's contribution.
#include "common/phase.glsl"
#include "marcher/scene_data.glsl"
#include "common/trilinear.glsl"

// Trilinear lookup of a cloud's light grid at world p: GL texel-centre convention over the grid's
// box, clamp to edge. In the atlas, clamping the texel coordinate to [0.5, R − 0.5] keeps the
// hardware filter inside this cloud's slices and gives exactly clamp-to-edge.
float light_lookup(CloudData c, vec3 p, bool exact) {
    vec3 res = vec3(c.light.xyz);
    vec3 u = (p - c.light_lo.xyz) / (c.light_hi.xyz - c.light_lo.xyz) * res;
    if (!exact) {
        u = clamp(u, vec3(0.5), res - 0.5);
        u.z += float(c.light.w);
        return texture(u_light_atlas, u / vec3(textureSize(u_light_atlas, 0))).r;
    }
    // Same blend by hand with float weights, indices clamped to the grid (as GL_CLAMP_TO_EDGE).
    vec3 x = u - 0.5;
    vec3 f = floor(x);
    vec3 w = x - f;
    ivec3 hi = c.light.xyz - 1;
    ivec3 i0 = clamp(ivec3(f), ivec3(0), hi);
    ivec3 i1 = clamp(ivec3(f) + 1, ivec3(0), hi);
    int z0 = c.light.w;
    float c000 = texelFetch(u_light_atlas, ivec3(i0.x, i0.y, i0.z + z0), 0).r;
    float c100 = texelFetch(u_light_atlas, ivec3(i1.x, i0.y, i0.z + z0), 0).r;
    float c010 = texelFetch(u_light_atlas, ivec3(i0.x, i1.y, i0.z + z0), 0).r;
    float c110 = texelFetch(u_light_atlas, ivec3(i1.x, i1.y, i0.z + z0), 0).r;
    float c001 = texelFetch(u_light_atlas, ivec3(i0.x, i0.y, i1.z + z0), 0).r;
    float c101 = texelFetch(u_light_atlas, ivec3(i1.x, i0.y, i1.z + z0), 0).r;
    float c011 = texelFetch(u_light_atlas, ivec3(i0.x, i1.y, i1.z + z0), 0).r;
    float c111 = texelFetch(u_light_atlas, ivec3(i1.x, i1.y, i1.z + z0), 0).r;
    return trilinear_blend(c000, c100, c010, c110, c001, c101, c011, c111, w);
}
