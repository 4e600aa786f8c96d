// Interleaved gradient noise (Jimenez 2014) of pixel (row, col) for a seed in [0, 1023]: the
// per-pixel offset ξ ∈ [0, 1) of a ray's samples within their step (RENDER_CONTRACT "Camera
// rays"; C++ twin: jitter() in cpp/src/rendering/physical.cpp).
float ign_jitter(int row, int col, int seed) {
    float s = 5.588238 * float(seed);
    float x = float(col) + s, y = float(row) + s;
    float a = 0.06711056 * x;
    float b = 0.00583715 * y;
    float f = a + b;
    float inner = f - floor(f);
    float g = 52.9829189 * inner;
    return g - floor(g);
}
