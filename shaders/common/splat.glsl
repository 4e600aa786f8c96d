// Splat kernel of Harris 2002 particles, twin of cumuli::splat_kernel
// (cpp/src/light/particles.cpp): K(d) = peak·k(d) for d < 1, 0 for d ≥ 1, with
//   kind 0: windowed Gaussian σ = 1/3, k = (e^{−4.5d²} − e^{−4.5})/(1 − e^{−4.5})
//   kind 1: SkyWorks' cubic Hermite, k = 1 − 3d² + 2d³.
// Same float32 constants and operation order as the C++; `precise` keeps compilers from fusing.
float splat_kernel(int kind, float peak, float d) {
    if (!(d < 1.0)) return 0.0;
    const float GAUSS_TAIL = 0.011108996538242306;  // e^{−4.5}
    precise float d2 = d * d;
    precise float k;
    if (kind == 1) {
        k = (1.0 - 3.0 * d2) + 2.0 * d2 * d;
    } else {
        k = (exp(-4.5 * d2) - GAUSS_TAIL) / (1.0 - GAUSS_TAIL);
    }
    precise float w = peak * k;
    return w;
}
