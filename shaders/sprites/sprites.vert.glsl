#version 430
// View-plane-parallel sprites (Harris 2002 particle splats; Torchelsen & Musse
// 2005 billboards): the GL twin of cumuli::project_sprite and
// cumuli::rasterise_sprites (cpp/src/render/sprite_raster.cpp).
//
// One instance per sprite, six vertices (two triangles) built here in screen space from the
// sprite's projection with the RENDER_CONTRACT camera: v = centre − eye, Z = v·f, X = v·r,
// Y = v·u; j_c = W/2·(X/(Z·th·aspect) + 1), i_c = H/2·(1 − Y/(Z·th)), half sizes in pixels
// half·(H/2)/(Z·th) (same float32 operations as the C++). The rectangle is grown by one pixel
// each side so that it covers every pixel centre the fragment shader's |s|, |t| ≤ 1 test keeps;
// the fragment shader recomputes everything from the `flat` parameters. Sprites with Z ≤ near
// are dropped (all six vertices outside the clip volume).
//
// The fragment shader may depth-test each sprite's view depth Z against a per-pixel depth image
// (opaque solids, Harris 2002 §3.1.1: "direct particles with depth test").
// Billboard fragment shading (Torchelsen spec §4.2): in_frame (cloud centre c_C, R_C), in_yrange
// (y_lo, y_hi) and in_row (the sprite's row in the CAF buffer) pass to the fragment shader with the
// world centre and half sizes, where the colour is evaluated per pixel.
//
// u_screen_space: the centre's x, y are already (j_c, i_c) in pixels and the half sizes are
// pixels (the read-back light pass of particles/, which draws into the N_L² light buffer).

in vec3 in_centre;
in vec2 in_half;
in float in_rotation;  // radians
in float in_alpha;
in int in_texture;
in vec3 in_c0;
in vec3 in_c1;
in vec3 in_c2;
in vec3 in_c3;
in vec4 in_frame;
in vec2 in_yrange;
in int in_row;

uniform vec3 u_cam_pos;
uniform vec3 u_cam_f;
uniform vec3 u_cam_r;
uniform vec3 u_cam_u;
uniform float u_th;
uniform ivec2 u_image_size;   // W, H
uniform float u_near;
uniform ivec2 u_tile_origin;  // column, row (row 0 = top of the image) of the tile's top-left
uniform ivec2 u_tile_size;    // tile width, height
uniform bool u_screen_space;

flat out vec4 v_screen;  // j_c, i_c, hx, hy (pixels)
flat out vec2 v_rot;     // cos ψ, sin ψ
flat out float v_alpha;
flat out int v_texture;
flat out vec3 v_c0;
flat out vec3 v_c1;
flat out vec3 v_c2;
flat out vec3 v_c3;
flat out float v_depth;  // view depth Z of the sprite (0 in screen space)
flat out vec3 v_centre;
flat out vec2 v_half;
flat out vec4 v_frame;
flat out vec2 v_yrange;
flat out int v_row;

float dot3(vec3 a, vec3 b) {
    precise float d = (a.x * b.x + a.y * b.y) + a.z * b.z;
    return d;
}

void main() {
    v_alpha = in_alpha;
    v_texture = in_texture;
    v_c0 = in_c0;
    v_c1 = in_c1;
    v_c2 = in_c2;
    v_c3 = in_c3;
    v_centre = in_centre;
    v_half = in_half;
    v_frame = in_frame;
    v_yrange = in_yrange;
    v_row = in_row;
    v_rot = vec2(cos(in_rotation), sin(in_rotation));
    v_depth = 0.0;
    precise float jc, ic, hx, hy;
    if (u_screen_space) {
        jc = in_centre.x;
        ic = in_centre.y;
        hx = in_half.x;
        hy = in_half.y;
    } else {
        precise vec3 v = in_centre - u_cam_pos;
        float z = dot3(v, u_cam_f);
        if (!(z > u_near)) {
            gl_Position = vec4(2.0, 2.0, 2.0, 1.0);  // outside the clip volume: culled
            v_screen = vec4(0.0);
            return;
        }
        v_depth = z;
        float x = dot3(v, u_cam_r);
        float y = dot3(v, u_cam_u);
        float w = float(u_image_size.x), h = float(u_image_size.y);
        precise float aspect = w / h;
        precise float zt = z * u_th;
        jc = (w * 0.5) * (x / (zt * aspect) + 1.0);
        ic = (h * 0.5) * (1.0 - y / zt);
        precise float scale = (h * 0.5) / zt;
        hx = in_half.x * scale;
        hy = in_half.y * scale;
    }
    v_screen = vec4(jc, ic, hx, hy);
    // Corners in sprite coordinates (s, t) for triangles (v0, v1, v2), (v0, v2, v3).
    const vec2 corners[4] = vec2[4](vec2(-1.0, -1.0), vec2(1.0, -1.0), vec2(1.0, 1.0), vec2(-1.0, 1.0));
    const int order[6] = int[6](0, 1, 2, 0, 2, 3);
    vec2 st = corners[order[gl_VertexID % 6]];
    vec2 grown = st * vec2(hx + 1.0, hy + 1.0);
    // Pixel offsets of the rotated right (cos ψ, −sin ψ) and up (−sin ψ, −cos ψ) axes (rows grow down).
    vec2 p = vec2(jc, ic) + grown.x * vec2(v_rot.x, -v_rot.y) + grown.y * vec2(-v_rot.y, -v_rot.x);
    vec2 rel = (p - vec2(u_tile_origin)) / vec2(u_tile_size);
    gl_Position = vec4(2.0 * rel.x - 1.0, 1.0 - 2.0 * rel.y, 0.0, 1.0);
}
