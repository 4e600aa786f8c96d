// Opaque solid spheres (Harris 2002 §3.1.1): the GLSL twin of
// cpp/include/cumuli/rendering/solids.hpp. Ray o + t·d (d unit): oc = o − c, b = oc·d,
// k = oc·oc − r², disc = b² − k; a miss when disc < 0 or −b + √disc < 0; else t = max(−b − √disc, 0).
// The marchers stop at the nearest solid (nearest_solid); shaders/solids/solid.frag.glsl draws them.

#define MAX_SOLIDS 16
const float NO_SOLID = uintBitsToFloat(0x7F800000u);  // +∞, as the C++ kNoSolid

uniform int u_solid_count;               // 0: no solids
uniform vec4 u_solid_sphere[MAX_SOLIDS];  // xyz centre, w radius

float solid_dot3(vec3 a, vec3 b) {
    precise float d = (a.x * b.x + a.y * b.y) + a.z * b.z;
    return d;
}

float ray_sphere(vec3 o, vec3 d, vec3 c, float r) {
    precise vec3 oc = o - c;
    precise float b = solid_dot3(oc, d);
    precise float k = solid_dot3(oc, oc) - r * r;
    precise float disc = b * b - k;
    if (!(disc >= 0.0)) return NO_SOLID;
    float root = sqrt(disc);
    precise float far_t = -b + root;
    if (far_t < 0.0) return NO_SOLID;
    precise float near_t = -b - root;
    return max(near_t, 0.0);
}

// Nearest hit over the solids (ties: the first); `which` is its index or −1.
float nearest_solid(vec3 o, vec3 d, out int which) {
    float best = NO_SOLID;
    which = -1;
    for (int s = 0; s < min(u_solid_count, MAX_SOLIDS); ++s) {
        float t = ray_sphere(o, d, u_solid_sphere[s].xyz, u_solid_sphere[s].w);
        if (t < best) {
            best = t;
            which = s;
        }
    }
    return best;
}
