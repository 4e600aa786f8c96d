#version 430
// Dynamically generated impostors (Harris 2002 §3): one impostor per draw,
// two triangles covering its conservative pixel rectangle (cumuli::impostor_rect, computed on the
// CPU); the fragment shader decides coverage exactly by intersecting the pixel's ray with the
// impostor's plane.

uniform ivec4 u_rect;         // j0, i0, j1, i1: inclusive pixel range of the whole image
uniform ivec2 u_tile_origin;  // column, row (row 0 = top) of the tile's top-left
uniform ivec2 u_tile_size;

void main() {
    const vec2 corners[6] = vec2[6](vec2(0.0, 0.0), vec2(1.0, 0.0), vec2(1.0, 1.0),
                                    vec2(0.0, 0.0), vec2(1.0, 1.0), vec2(0.0, 1.0));
    vec2 c = corners[gl_VertexID % 6];
    vec2 lo = vec2(u_rect.xy), hi = vec2(u_rect.zw) + 1.0;  // pixel edges
    vec2 p = lo + c * (hi - lo);
    vec2 rel = (p - vec2(u_tile_origin)) / vec2(u_tile_size);
    gl_Position = vec4(2.0 * rel.x - 1.0, 1.0 - 2.0 * rel.y, 0.0, 1.0);
}
