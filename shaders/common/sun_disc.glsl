// The sun's visible disc (RENDER_CONTRACT "Sky"): the one formula of the disc, added to the sky
// where the view ray points at the sun. C++ twin: sun_disc in cpp/include/cumuli/sky.hpp; the
// uniforms are filled by cumuli.rendering.params.sky_uniforms.
uniform vec2 u_sun_disc;        // cos(1.5·radius), cos(radius)
uniform float u_sun_disc_intensity;

// smoothstep(cos(1.5·radius), cos(radius), dot(d, sun_dir)) · intensity · sun_radiance
vec3 sun_disc(vec3 d, vec3 sun_dir, vec3 sun_radiance) {
    float w = smoothstep(u_sun_disc.x, u_sun_disc.y, dot(d, sun_dir));
    return w * u_sun_disc_intensity * sun_radiance;
}
