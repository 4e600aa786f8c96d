// Billboard shading of Torchelsen & Musse 2005 (§3.2) at one point:
// the GLSL twin of cumuli::shade_point (cpp/src/light/caf.cpp), used per pixel by the sprite
// pipeline's fragment-shading mode. Same float32 operations in the same order (`precise` keeps
// the compiler from fusing or reordering them):
//
//   cos φ  = dot((v − c_C)/|v − c_C|, s_ℓ)            (0 when |v − c_C| < 1e−6·R_C)
//   D_ℓ    = d_min + (d_max − d_min)·x^k_dir,  x = (1 + cos φ)/2 (linear) or
//            smoothstep(−0.3, 0.3, cos φ) (FlightGear), clamped to [0, 1]
//   colour = k_amb·ambient + H(f_v)·Σ_ℓ CAF_ℓ·D_ℓ·radiance_ℓ
//
// H is 1 without height levels, else piecewise linear through (f, h) at the point's height
// fraction f_v = (y − y_lo)/(y_hi − y_lo) in the cloud's box AABB.

#define BB_MAX_LIGHTS 17
#define BB_MAX_LEVELS 16

uniform int u_bb_lights;                    // number of lights (sun first)
uniform vec3 u_bb_dir[BB_MAX_LIGHTS];       // unit, towards the light
uniform vec3 u_bb_radiance[BB_MAX_LIGHTS];
uniform float u_bb_d_min;
uniform float u_bb_d_max;
uniform float u_bb_k_dir;
uniform int u_bb_directional;               // 0 linear, 1 smoothstep
uniform vec3 u_bb_ambient;                  // k_amb·ambient (float32 product made on the CPU)
uniform int u_bb_levels;
uniform vec2 u_bb_level[BB_MAX_LEVELS];     // (f, h), f increasing

float bb_dot(vec3 a, vec3 b) {
    precise float d = (a.x * b.x + a.y * b.y) + a.z * b.z;
    return d;
}

float bb_smoothstep(float e0, float e1, float x) {
    precise float t = clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    precise float r = t * t * (3.0 - 2.0 * t);
    return r;
}

float bb_directional(vec3 v, vec4 frame, vec3 light) {
    precise vec3 off = v - frame.xyz;
    precise float len = sqrt(bb_dot(off, off));
    precise float cos_phi = 0.0;
    if (!(len < 1e-6 * frame.w)) {
        precise vec3 unit = off / len;
        cos_phi = bb_dot(unit, light);
    }
    precise float x = u_bb_directional == 0 ? 0.5 * (1.0 + cos_phi)
                                            : bb_smoothstep(-0.3, 0.3, cos_phi);
    x = clamp(x, 0.0, 1.0);
    if (u_bb_k_dir != 1.0) x = pow(x, u_bb_k_dir);
    precise float d = u_bb_d_min + (u_bb_d_max - u_bb_d_min) * x;
    return d;
}

float bb_height(float y, vec2 yrange) {
    if (u_bb_levels == 0) return 1.0;
    precise float span = yrange.y - yrange.x;
    precise float f = span > 0.0 ? (y - yrange.x) / span : 0.5;
    if (f <= u_bb_level[0].x) return u_bb_level[0].y;
    if (f >= u_bb_level[u_bb_levels - 1].x) return u_bb_level[u_bb_levels - 1].y;
    for (int i = 1; i < u_bb_levels; ++i) {
        if (f <= u_bb_level[i].x) {
            precise float w = (f - u_bb_level[i - 1].x) / (u_bb_level[i].x - u_bb_level[i - 1].x);
            precise float h = u_bb_level[i - 1].y + w * (u_bb_level[i].y - u_bb_level[i - 1].y);
            return h;
        }
    }
    return u_bb_level[u_bb_levels - 1].y;
}

// caf(ℓ) must be defined by the includer: the CAF of the current sprite for light ℓ.
float bb_caf(int l);

vec3 billboard_shade(vec3 v, vec4 frame, vec2 yrange) {
    precise vec3 direct = vec3(0.0);
    for (int l = 0; l < u_bb_lights; ++l) {
        float d = bb_directional(v, frame, u_bb_dir[l]);
        precise float w = bb_caf(l) * d;
        direct += w * u_bb_radiance[l];
    }
    precise vec3 c = u_bb_ambient + bb_height(v.y, yrange) * direct;
    return c;
}
