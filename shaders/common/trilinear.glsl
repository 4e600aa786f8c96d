// Trilinear blend of the 8 texels of a cell with float weights w, in the order the C++ uses
// (cpp/src/noise.cpp Noise::blend, cpp/src/march.cpp LightGrid::sample): along x, then y, then z.
// cXYZ is the texel at offset (X, Y, Z) from the cell's lower corner.
float trilinear_blend(float c000, float c100, float c010, float c110,
                      float c001, float c101, float c011, float c111, vec3 w) {
    float c00 = c000 + w.x * (c100 - c000);
    float c10 = c010 + w.x * (c110 - c010);
    float c01 = c001 + w.x * (c101 - c001);
    float c11 = c011 + w.x * (c111 - c011);
    float c0 = c00 + w.y * (c10 - c00);
    float c1 = c01 + w.y * (c11 - c01);
    return c0 + w.z * (c1 - c0);
}
