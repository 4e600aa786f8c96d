// Empty-space skipping (twin of cpp/src/rendering/occupancy.cpp and RayMarcher::skip_empty in
// cpp/src/rendering/marcher.cpp; RENDER_CONTRACT "Empty-space skipping"): each cloud's occupancy
// grid (OCC_RES³ cells over its candidate box, 1 where density may be > 0, 0 where it is
// certainly 0) is a slab of u_occupancy, clouds stacked along z from CloudData.info.w.
#include "marcher/scene_data.glsl"

#define OCC_RES 16

uniform bool u_skip_empty;
uniform sampler3D u_occupancy;  // R8, read with texelFetch

// True when p lies in an empty cell of cloud c; then `t_safe` is the ray parameter up to which
// every point of o + t·d stays in that cell (its exit less a thousandth of its smallest edge).
bool empty_cell(CloudData c, vec3 p, vec3 o, vec3 d, out float t_safe) {
    t_safe = 0.0;
    vec3 lo = c.box_lo.xyz, hi = c.box_hi.xyz;
    if (any(lessThan(p, lo)) || any(greaterThan(p, hi))) return false;
    vec3 u = (p - lo) / (hi - lo) * float(OCC_RES);
    ivec3 cell = clamp(ivec3(u), ivec3(0), ivec3(OCC_RES - 1));
    if (texelFetch(u_occupancy, ivec3(cell.x, cell.y, c.info.w + cell.z), 0).r > 0.5) return false;
    vec3 size = (hi - lo) / float(OCC_RES);
    float t_exit = 1e30;
    for (int a = 0; a < 3; ++a) {
        if (d[a] > 0.0) t_exit = min(t_exit, (lo[a] + float(cell[a] + 1) * size[a] - o[a]) / d[a]);
        else if (d[a] < 0.0) t_exit = min(t_exit, (lo[a] + float(cell[a]) * size[a] - o[a]) / d[a]);
    }
    t_safe = t_exit - 1e-3 * min(min(size.x, size.y), size.z);
    return true;
}
