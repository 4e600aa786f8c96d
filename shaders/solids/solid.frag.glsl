#version 430
// The solid image: per pixel the nearest opaque sphere, shaded
// Lambert by the sun plus ambient, rgb = colour ⊙ (ambient + max(0, n·s)·sun_radiance); alpha the
// view depth Z = t·(d·f), +∞ where no solid is hit. GLSL twin of cumuli::draw_solids
// (cpp/src/rendering/solids.cpp); the camera ray is RENDER_CONTRACT's, tiles as the marcher's.

#include "common/camera.glsl"
#include "common/solid.glsl"

uniform vec3 u_sun_dir;
uniform vec3 u_sun_radiance;
uniform vec3 u_solid_colour[MAX_SOLIDS];
uniform vec3 u_solid_ambient[MAX_SOLIDS];

out vec4 frag;

void main() {
    vec3 dir = camera_ray(pixel_of_fragment());
    int which;
    float t = nearest_solid(u_cam_pos, dir, which);
    if (which < 0) {
        frag = vec4(0.0, 0.0, 0.0, NO_SOLID);
        return;
    }
    vec4 sphere = u_solid_sphere[which];
    precise vec3 p = u_cam_pos + t * dir;
    precise vec3 n = (p - sphere.xyz) * (1.0 / sphere.w);
    float lambert = max(solid_dot3(n, u_sun_dir), 0.0);
    precise vec3 rgb = u_solid_colour[which] * (u_solid_ambient[which] + lambert * u_sun_radiance);
    precise float z = t * solid_dot3(dir, u_cam_f);
    frag = vec4(rgb, z);
}
