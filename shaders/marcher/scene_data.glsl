// The scene as the marcher sees it: primitives and clouds in two storage buffers (std430), the
// light grids packed into one 3D atlas (grids stacked along z). Filled by cumuli/renderer.py.

struct Primitive {
    vec4 centre;  // xyz
    vec4 radii;   // xyz
    vec4 ax0;     // rotation columns: the ellipsoid's axes in world space
    vec4 ax1;
    vec4 ax2;
};

struct CloudData {
    vec4 box_lo;     // xyz: bounds of the primitives grown by candidate scale; w: candidate scale
    vec4 box_hi;     // xyz; w: unused
    vec4 centre;     // xyz: centre of the primitives' bounds (LOD distance)
    vec4 light_lo;   // xyz: light grid world box
    vec4 light_hi;
    vec4 params;     // x: κ, y: r̄² (eq. 20), z: φ (eq. 21; metaball density fbm·r̄²·φ)
    vec4 noise;      // xyz: the noise offset a cloud moved by the wind carries (fbm(p − xyz))
    ivec4 info;      // x: first primitive, y: primitive count, z: model (0 spheroid, 1 metaball)
    ivec4 light;     // xyz: grid resolution (x, y, z); w: first z slice in the atlas
};

layout(std430, binding = 0) readonly buffer Primitives { Primitive prims[]; };
layout(std430, binding = 1) readonly buffer Clouds { CloudData clouds[]; };

uniform sampler3D u_light_atlas;  // R32F, LINEAR, CLAMP_TO_EDGE
