#version 430
// Impostor display (Harris 2002 §3); the GL twin of cumuli::display_impostors
// (cpp/src/rendering/impostors.cpp). Per pixel (j, i) of the whole image, the RENDER_CONTRACT ray
// o + t·d meets the impostor plane (centre c, normal f, unit axes r, u, half sizes hw, hh) at
// t = ((c − o)·f)/(d·f) (nothing unless d·f > 0 and t > 0); rel = t·d − (c − o),
// s = rel·r/hw, v = rel·u/hh; outside |s|, |v| ≤ 1 a tight impostor is transparent (a screen
// impostor clamps); texel coordinates tx = (s + 1)/2·w, ty = (1 − v)/2·h (row 0 on top).
// u_exact: bilinear by texelFetch blends with the C++ arithmetic (texel centres, clamp to edge,
// lerp along x then y); otherwise the hardware bilinear filter. Output premultiplied, blended
// (ONE, ONE_MINUS_SRC_ALPHA) in draw order (back to front).

#include "common/camera.glsl"

// The impostor's plane in one array (one upload per impostor): (centre, hw), (forward, hh),
// (right, clamp: 1 for a screen impostor), (up, 0).
uniform vec4 u_quad[4];
uniform bool u_exact;
uniform sampler2D u_image;  // RGBA32F, row 0 = top of the impostor image

out vec4 frag;

float dot3(vec3 a, vec3 b) {
    precise float d = (a.x * b.x + a.y * b.y) + a.z * b.z;
    return d;
}

float lerp1(float a, float b, float t) {
    precise float v = a + t * (b - a);
    return v;
}

void main() {
    vec3 u_centre = u_quad[0].xyz, u_forward = u_quad[1].xyz;
    vec3 u_right = u_quad[2].xyz, u_up = u_quad[3].xyz;
    vec2 u_half = vec2(u_quad[0].w, u_quad[1].w);
    bool u_clamp = u_quad[2].w > 0.5;
    vec3 d = camera_ray(pixel_of_fragment());
    precise vec3 qo = u_centre - u_cam_pos;
    float denom = dot3(d, u_forward);
    if (!(denom > 0.0)) discard;
    precise float t = dot3(qo, u_forward) / denom;
    if (!(t > 0.0)) discard;
    precise vec3 rel = t * d - qo;
    precise float s = dot3(rel, u_right) / u_half.x;
    precise float v = dot3(rel, u_up) / u_half.y;
    if (!u_clamp && !(abs(s) <= 1.0 && abs(v) <= 1.0)) discard;
    ivec2 size = textureSize(u_image, 0);
    float tw = float(size.x), th = float(size.y);
    precise float tx = (s + 1.0) * 0.5 * tw;
    precise float ty = (1.0 - v) * 0.5 * th;
    if (!u_exact) {
        frag = texture(u_image, vec2(tx / tw, ty / th));
        return;
    }
    precise float u = tx - 0.5;
    precise float w = ty - 0.5;
    float fu = floor(u), fw = floor(w);
    precise float wx = u - fu;
    precise float wy = w - fw;
    int x0 = int(clamp(fu, 0.0, tw - 1.0)), x1 = int(clamp(fu + 1.0, 0.0, tw - 1.0));
    int y0 = int(clamp(fw, 0.0, th - 1.0)), y1 = int(clamp(fw + 1.0, 0.0, th - 1.0));
    vec4 a = texelFetch(u_image, ivec2(x0, y0), 0), b = texelFetch(u_image, ivec2(x1, y0), 0);
    vec4 c = texelFetch(u_image, ivec2(x0, y1), 0), e = texelFetch(u_image, ivec2(x1, y1), 0);
    vec4 out_;
    for (int k = 0; k < 4; ++k) out_[k] = lerp1(lerp1(a[k], b[k], wx), lerp1(c[k], e[k], wx), wy);
    frag = out_;
}
