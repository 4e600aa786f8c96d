// Gradient sky with a sun disc (RENDER_CONTRACT "Sky"; numpy twin: cumuli.Sky.colour).
uniform vec3 u_sky_zenith;
uniform vec3 u_sky_horizon;
uniform vec3 u_sky_ground;
uniform float u_sky_exponent;
uniform vec2 u_sun_disc;        // cos(1.5·radius), cos(radius)
uniform float u_sun_disc_intensity;

vec3 sky(vec3 d, vec3 sun_dir, vec3 sun_radiance) {
    vec3 base = d.y >= 0.0
        ? u_sky_horizon + (u_sky_zenith - u_sky_horizon) * pow(d.y, u_sky_exponent)
        : u_sky_horizon + (u_sky_ground - u_sky_horizon) * min(1.0, -8.0 * d.y);
    float disc = smoothstep(u_sun_disc.x, u_sun_disc.y, dot(d, sun_dir));
    return base + disc * u_sun_disc_intensity * sun_radiance;
}
