// The pinhole camera of RENDER_CONTRACT, shared by every full-image pass drawn in tiles (set from
// Python by cumuli.Camera.uniforms): f, r, u unit vectors, th = tan(fov/2), aspect = W/H.
uniform vec3 u_cam_pos;
uniform vec3 u_cam_f;
uniform vec3 u_cam_r;
uniform vec3 u_cam_u;
uniform float u_th;
uniform float u_aspect;
uniform ivec2 u_image_size;   // W, H
uniform ivec2 u_tile_origin;  // column and row (row 0 = top of the image) of the tile's top-left
uniform int u_tile_height;

// (row i from the top, column j) of this fragment's pixel in the whole image.
ivec2 pixel_of_fragment() {
    int j = u_tile_origin.x + int(gl_FragCoord.x);
    int i = u_tile_origin.y + (u_tile_height - 1 - int(gl_FragCoord.y));
    return ivec2(i, j);
}

// Unit direction of the ray through the centre of pixel (i, j).
vec3 camera_ray(ivec2 pixel) {
    float W = float(u_image_size.x), H = float(u_image_size.y);
    float x = (2.0 * (float(pixel.y) + 0.5) / W - 1.0) * u_th * u_aspect;
    float y = (1.0 - 2.0 * (float(pixel.x) + 0.5) / H) * u_th;
    return normalize(u_cam_f + x * u_cam_r + y * u_cam_u);
}
