#version 430
// Fragment side of the shared sprite pipeline (see sprites.vert.glsl; CPU twin
// cumuli::rasterise_sprites). Per pixel (j, i) of the whole image (tile origin added, rows flipped
// to row 0 on top like marcher/march.frag.glsl): sprite coordinates
//   dx = (j + ½) − j_c, dy = (i + ½) − i_c, s = (dx·cos ψ − dy·sin ψ)/hx, t = (−dx·sin ψ − dy·cos ψ)/hy,
// discarded outside |s|, |t| ≤ 1; colour interpolated barycentrically over (v0, v1, v2) (s ≥ t) or
// (v0, v2, v3) unless the four are equal;
//   texture < 0 (Harris splat): w = K(√(s² + t²)), output (w·colour, w·alpha);
//   texture ≥ 0 (billboard): straight-alpha atlas cell, bilinear with the texel-centre convention
//     and clamp to the cell's edge (u_exact: texelFetch blends, the C++ twin's arithmetic; else the
//     hardware filter), a = tex.a·alpha, output (colour·tex.rgb·a, a).
// u_depth_test: a fragment is kept only where the sprite's view depth Z < u_depth[i][j] (the view
// depth of the nearest opaque solid, +∞ where none; Harris 2002 §3.1.1's direct rendering).
// u_fragment_shading (billboards, spec §4.2): the colour is billboard_shade (common/billboard_shade.glsl,
// twin of cumuli::shade_point) at the pixel's point on the billboard
//   p = centre + (s·half.x)·r′ + (t·half.y)·u′,  r′ = cos ψ·r + sin ψ·u,  u′ = −sin ψ·r + cos ψ·u,
// with the sprite's cloud frame and its CAF row (buffer binding 0, u_bb_lights floats per sprite).
// Blending (ONE, ONE_MINUS_SRC_ALPHA) into an RGBA32F target cleared to 0 makes the premultiplied
// layer (C, A); GL blends the fragments of a draw in primitive order, i.e. back to front.

#include "common/splat.glsl"
#include "common/billboard_shade.glsl"

flat in vec4 v_screen;
flat in vec2 v_rot;
flat in float v_alpha;
flat in int v_texture;
flat in vec3 v_c0;
flat in vec3 v_c1;
flat in vec3 v_c2;
flat in vec3 v_c3;
flat in float v_depth;
flat in vec3 v_centre;
flat in vec2 v_half;
flat in vec4 v_frame;
flat in vec2 v_yrange;
flat in int v_row;

uniform ivec2 u_tile_origin;
uniform int u_tile_height;
uniform int u_kernel;  // 0 gaussian, 1 hermite
uniform float u_peak;
uniform sampler2D u_atlas;
uniform ivec2 u_atlas_grid;  // cells across, down
uniform bool u_exact;
uniform bool u_depth_test;
uniform sampler2D u_depth;  // R32F, (W, H), row i = image row i (row 0 on top)
uniform bool u_fragment_shading;
uniform vec3 u_cam_r;
uniform vec3 u_cam_u;

layout(std430, binding = 0) readonly buffer BillboardCaf { float bb_caf_data[]; };

float bb_caf(int l) { return bb_caf_data[v_row * u_bb_lights + l]; }

out vec4 frag;

float lerp1(float a, float b, float t) {
    precise float v = a + t * (b - a);
    return v;
}

vec4 sample_cell(int cell, float tx, float ty) {
    ivec2 size = textureSize(u_atlas, 0);
    int cw = size.x / u_atlas_grid.x, ch = size.y / u_atlas_grid.y;
    int cx0 = (cell % u_atlas_grid.x) * cw, cy0 = (cell / u_atlas_grid.x) * ch;
    if (!u_exact) {
        return texture(u_atlas, vec2(tx, ty) / vec2(size));
    }
    precise float u = tx - 0.5;
    precise float v = ty - 0.5;
    float fu = floor(u), fv = floor(v);
    precise float wx = u - fu;
    precise float wy = v - fv;
    float xlo = float(cx0), xhi = float(cx0 + cw - 1);
    float ylo = float(cy0), yhi = float(cy0 + ch - 1);
    int x0 = int(clamp(fu, xlo, xhi)), x1 = int(clamp(fu + 1.0, xlo, xhi));
    int y0 = int(clamp(fv, ylo, yhi)), y1 = int(clamp(fv + 1.0, ylo, yhi));
    vec4 a = texelFetch(u_atlas, ivec2(x0, y0), 0), b = texelFetch(u_atlas, ivec2(x1, y0), 0);
    vec4 c = texelFetch(u_atlas, ivec2(x0, y1), 0), d = texelFetch(u_atlas, ivec2(x1, y1), 0);
    vec4 out_;
    for (int k = 0; k < 4; ++k) out_[k] = lerp1(lerp1(a[k], b[k], wx), lerp1(c[k], d[k], wx), wy);
    return out_;
}

void main() {
    int j = u_tile_origin.x + int(gl_FragCoord.x);
    int i = u_tile_origin.y + (u_tile_height - 1 - int(gl_FragCoord.y));
    precise float dx = (float(j) + 0.5) - v_screen.x;
    precise float dy = (float(i) + 0.5) - v_screen.y;
    precise float s = (dx * v_rot.x - dy * v_rot.y) / v_screen.z;
    precise float t = (-dx * v_rot.y - dy * v_rot.x) / v_screen.w;
    if (!(abs(s) <= 1.0 && abs(t) <= 1.0)) discard;
    if (u_depth_test && !(v_depth < texelFetch(u_depth, ivec2(j, i), 0).r)) discard;
    precise vec3 colour = v_c0;
    if (u_fragment_shading) {
        precise vec3 r2 = v_rot.x * u_cam_r + v_rot.y * u_cam_u;
        precise vec3 u2 = (-v_rot.y) * u_cam_r + v_rot.x * u_cam_u;
        precise vec3 p = v_centre + (s * v_half.x) * r2 + (t * v_half.y) * u2;
        colour = billboard_shade(p, v_frame, v_yrange);
    } else if (!(v_c0 == v_c1 && v_c0 == v_c2 && v_c0 == v_c3)) {
        if (s >= t) {
            colour = v_c0 * ((1.0 - s) * 0.5) + v_c1 * ((s - t) * 0.5) + v_c2 * ((t + 1.0) * 0.5);
        } else {
            colour = v_c0 * ((1.0 - t) * 0.5) + v_c2 * ((s + 1.0) * 0.5) + v_c3 * ((t - s) * 0.5);
        }
    }
    if (v_texture < 0) {
        precise float d = sqrt(s * s + t * t);
        if (!(d < 1.0)) discard;
        float w = splat_kernel(u_kernel, u_peak, d);
        frag = vec4(w * colour, w * v_alpha);
    } else {
        ivec2 size = textureSize(u_atlas, 0);
        int cw = size.x / u_atlas_grid.x, ch = size.y / u_atlas_grid.y;
        precise float tx = float((v_texture % u_atlas_grid.x) * cw) + (s + 1.0) * 0.5 * float(cw);
        precise float ty = float((v_texture / u_atlas_grid.x) * ch) + (1.0 - t) * 0.5 * float(ch);
        vec4 tex = sample_cell(v_texture, tx, ty);
        precise float a = tex.a * v_alpha;
        frag = vec4(colour * tex.rgb * a, a);
    }
}
