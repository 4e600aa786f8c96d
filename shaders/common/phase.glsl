// Henyey-Greenstein phase function, eq. (14), normalised by 1/4π.
// c = cos θ = dot(ray direction, sun direction); g in (-1, 1) is the asymmetry factor.
float hg_phase(float g, float c) {
    const float PI = 3.14159265358979;
    float denom = 1.0 + g * g - 2.0 * g * c;
    return (1.0 - g * g) / (4.0 * PI * denom * sqrt(denom));
}

// Draine's phase (Draine 2003), normalised by 1/4π: HG(g, c)·(1 + α·c²)/(1 + α(1 + 2g²)/3).
// C++ twin: cumuli::draine (cpp/include/cumuli/phase.hpp).
float draine_phase(float g, float alpha, float c) {
    return hg_phase(g, c) * (1.0 + alpha * c * c) / (1.0 + alpha * (1.0 + 2.0 * g * g) / 3.0);
}

// The approximate Mie phase of water droplets (Jendersie & d'Eon 2023):
// (1 − w_D)·HG(g_HG) + w_D·Draine(g_D, α), m = (g_HG, g_D, α, w_D) fitted over the droplet
// diameter by cumuli::approx_mie_params (the constants live there only); both g scaled by
// `scale`. C++ twin: cumuli::approx_mie.
float approx_mie_phase(vec4 m, float c, float scale) {
    return (1.0 - m.w) * hg_phase(m.x * scale, c) + m.w * draine_phase(m.y * scale, m.z, c);
}

// Rayleigh phase (Harris 2002 §2.1: p(θ) = ¾(1 + cos²θ)), normalised by 1/4π like hg_phase:
// 3(1 + c²)/(16π). C++ twin: cumuli::rayleigh (cpp/include/cumuli/phase.hpp).
float rayleigh_phase(float c) {
    const float SIXTEEN_PI = 50.26548245743669;
    return 3.0 * (1.0 + c * c) / SIXTEEN_PI;
}

// The phase functions of the Harris 2002 particle passes normalised to 4π (∫p dω = 4π):
// kind 0 Rayleigh ¾(1 + c²), 1 isotropic, 2 Henyey-Greenstein (1 − g²)/(d·√d), d = 1 + g² − 2gc.
// C++ twin: cumuli::phase_4pi.
float phase_4pi(int kind, float g, float c) {
    if (kind == 0) return 0.75 * (1.0 + c * c);
    if (kind == 1) return 1.0;
    float denom = 1.0 + g * g - 2.0 * g * c;
    return (1.0 - g * g) / (denom * sqrt(denom));
}
