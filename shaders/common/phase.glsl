// Henyey-Greenstein phase function, eq. (14), normalised by 1/4π.
// c = cos θ = dot(ray direction, sun direction); g in (-1, 1) is the asymmetry factor.
float hg_phase(float g, float c) {
    const float PI = 3.14159265358979;
    float denom = 1.0 + g * g - 2.0 * g * c;
    return (1.0 - g * g) / (4.0 * PI * denom * sqrt(denom));
}
