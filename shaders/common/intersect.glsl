// Ray intersections (twins of cpp/src/primitives.cpp).

// Slab test (Smits; Williams et al.): the span [t.x, t.y] of o + t·d inside the box [lo, hi].
// inv_d = 1/d with zero components replaced by a huge value of the same sign, so the slab of an
// axis the ray runs parallel to is (-huge, +huge) when o is inside it and empty otherwise.
bool intersect_box(vec3 lo, vec3 hi, vec3 o, vec3 inv_d, out vec2 t) {
    vec3 ta = (lo - o) * inv_d;
    vec3 tb = (hi - o) * inv_d;
    vec3 tmin = min(ta, tb);
    vec3 tmax = max(ta, tb);
    t.x = max(max(tmin.x, tmin.y), tmin.z);
    t.y = min(min(tmax.x, tmax.y), tmax.z);
    return t.x <= t.y;
}

// World point -> the ellipsoid's unit-sphere frame, q = Rᵀ(p − c) / radii. R's columns are the
// ellipsoid's axes, so Rᵀv is the three dot products with the columns.
vec3 to_unit_frame(vec3 v, vec3 ax0, vec3 ax1, vec3 ax2) {
    return vec3(dot(ax0, v), dot(ax1, v), dot(ax2, v));
}

// o + t·d against an ellipsoid, solved in its unit-sphere frame (t is the same as in world space).
bool intersect_ellipsoid(vec3 centre, vec3 radii, vec3 ax0, vec3 ax1, vec3 ax2, vec3 o, vec3 d,
                         out vec2 t) {
    vec3 lo = to_unit_frame(o - centre, ax0, ax1, ax2) / radii;
    vec3 ld = to_unit_frame(d, ax0, ax1, ax2) / radii;
    float a = dot(ld, ld);
    if (!(a > 0.0)) return false;
    float b = dot(lo, ld);
    float c = dot(lo, lo) - 1.0;
    float disc = b * b - a * c;
    if (disc < 0.0) return false;
    float s = sqrt(disc);
    t = vec2((-b - s) / a, (-b + s) / a);
    return true;
}
