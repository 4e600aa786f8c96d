// Gradient sky with a sun disc (RENDER_CONTRACT "Sky"; C++ twin: sky_radiance in
// cpp/include/cumuli/sky.hpp; numpy twin: cumuli.Sky.colour).
#include "common/sun_disc.glsl"

uniform vec3 u_sky_zenith;
uniform vec3 u_sky_horizon;
uniform vec3 u_sky_ground;
uniform float u_sky_exponent;

vec3 sky(vec3 d, vec3 sun_dir, vec3 sun_radiance) {
    vec3 base = d.y >= 0.0
        ? u_sky_horizon + (u_sky_zenith - u_sky_horizon) * pow(d.y, u_sky_exponent)
        : u_sky_horizon + (u_sky_ground - u_sky_horizon) * min(1.0, -8.0 * d.y);
    return base + sun_disc(d, sun_dir, sun_radiance);
}
