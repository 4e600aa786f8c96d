// Light for density volumes (Iwasaki, Nishino & Dobashi 2011, §3.1): single scattering of sun
// and sky with precomputed optical depths.
//
// Optical depth f(x, ω) = ∫₀^∞ ρ(x + uω) du (density × length; the extinction σ_t multiplies it
// at render time) is linear in ρ, so the optical depth of a cross-dissolved volume is the blend
// of the optical depths of its two database volumes (eq. 6): precompute once per database volume,
// blend per frame. Towards the sun one value per voxel; towards the sky the function of ω is
// projected onto real spherical harmonics (bands 0..order−1, order² coefficients), and the sky
// transmittance τ = exp(−σ_t f) is recovered with the SH exponential of Ren et al. 2006 (eq. 7):
// exp*(g) ≈ exp(g₀/√4π)·(a(‖ĝ‖)·1 + b(‖ĝ‖)·ĝ), with a, b tabulated by least squares over voxels
// sampled from the database, as the paper does.
//
// Volumes are [z][y][x] over a world box; voxel centres sit at lo + (i + ½)·size/res and values
// between them are trilinear with clamp-to-edge (GL's texel-centre convention, so a GL_LINEAR
// texture with CLAMP_TO_EDGE agrees). Outside the box the density is 0.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/phase.hpp"
#include "cumuli/primitives.hpp"

namespace cumuli {

// A [z][y][x] volume's shape and world box.
struct VolumeGrid {
  int w = 1, h = 1, d = 1;  // voxels along x, y, z
  Box box;

  std::size_t voxels() const { return static_cast<std::size_t>(w) * h * d; }
  glm::vec3 voxel_size() const { return (box.hi - box.lo) / glm::vec3(w, h, d); }
  glm::vec3 centre(int x, int y, int z) const {
    return box.lo + (glm::vec3(x, y, z) + 0.5f) * voxel_size();
  }
  void validate() const;  // throws std::invalid_argument
};

// Trilinear value of `channels`-interleaved field `vol` at world point p (clamp to edge), into
// out[0..channels).
void sample_trilinear(const float* vol, const VolumeGrid& g, int channels, glm::vec3 p, float* out);
float sample_trilinear(const float* vol, const VolumeGrid& g, glm::vec3 p);

// ∫ ρ along p + u·dir from u = 0 to the box exit (midpoint rule, equal steps no longer than
// step_voxels voxel sizes; exact for a constant density).
float optical_depth_ray(const float* vol, const VolumeGrid& g, glm::vec3 p, glm::vec3 dir,
                        float step_voxels);

// How the bulk optical depths below are computed.
//  - March: one ray per voxel (per direction, per point), optical_depth_ray / _segment: the
//    brute-force reference.
//  - Sweep: each voxel reuses what its neighbours' rays already integrated.
//    Along a direction ω (the sun, each SH direction): let a be the axis the ray crosses fastest
//    in voxels; the lines (l_b + s_b·u, u, l_c + s_c·u) of a grid sheared along ω (u the layer
//    coordinate along a, s the shift per layer, one line per voxel column of a layer) are each
//    integrated once, from the box face on the exit side back, by Simpson's rule between voxel
//    layers (panels ≤ 8·step voxels; trilinear density, clamped to the edges, so lines half a
//    voxel beyond the box see the edge density). A voxel's depth is the bilinear blend of the
//    four lines around it of ∫ from its layer to where its own ray leaves the box (the lines'
//    integrals are linear between layers): f is blended once, not once per slice, so the blur
//    does not grow with the distance travelled. Towards a point q the volume is swept outwards
//    from q in order of the max-norm distance in voxels: a voxel x whose ray to q crosses the
//    slice one voxel closer to q at x' (the slice across the axis a where |q − x| is largest in
//    voxels) gets
//        f(x) = ∫ ρ from x to x' (Simpson)  +  |x' − q| · Ḡ(x'),
//    Ḡ the bilinear blend, on that slice, of the mean density along the segment g = f/|x − q| of
//    the four voxels around x'; voxels within 2 voxels of q, or whose neighbours are not known
//    yet, are marched directly. Blending the mean density rather than the depth keeps a constant
//    density exact (f = ρ·ℓ). Results do not depend on the thread count.
enum class DepthMethod { March, Sweep };

// Optical depth towards the sun (`to_sun` points from the scene to the sun) for every voxel
// centre of `count` volumes: count × voxels floats.
std::vector<float> sun_optical_depth(const float* volumes, int count, const VolumeGrid& g,
                                     glm::vec3 to_sun, float step_voxels, int threads,
                                     DepthMethod method = DepthMethod::March);

// The Sweep of one volume along direction `dir` (normalised), into f (voxels floats); `phi` is
// reusable scratch; `vol_yzx` (optional) the same volume as transpose_yzx lays it out, which
// speeds up directions that cross x fastest. Single-threaded.
void sweep_optical_depth(const float* vol, const VolumeGrid& g, glm::vec3 dir, float step_voxels,
                         float* f, std::vector<float>& phi, const float* vol_yzx = nullptr);
// The volume re-laid [x][z][y] (y innermost).
std::vector<float> transpose_yzx(const float* vol, const VolumeGrid& g);

// --- spherical harmonics -------------------------------------------------------------------
constexpr int kMaxShOrder = 4;  // bands 0..3, 16 coefficients (the paper's 4th order)

// Real SH y_m(ω), m = l(l+1) + k over bands l < order, orthonormal on the sphere.
void sh_eval(int order, glm::vec3 dir, float* out);

// A product quadrature on the sphere: Gauss–Legendre in cos θ (n_theta nodes) × 2·n_theta
// uniform angles in φ. Exact for spherical polynomials of degree < 2·n_theta, so projecting a
// constant (or any low band) is exact to rounding whenever order ≤ n_theta.
struct SphereQuadrature {
  std::vector<glm::vec3> dirs;
  std::vector<float> weights;  // sum to 4π
  explicit SphereQuadrature(int n_theta);
};

// SH projection of per-voxel optical depth over the quadrature's directions:
// count × voxels × order² floats (coefficients innermost).
std::vector<float> sh_optical_depth(const float* volumes, int count, const VolumeGrid& g, int order,
                                    int n_theta, float step_voxels, int threads,
                                    DepthMethod method = DepthMethod::March);

// SH projection (order² coefficients per channel, 3 channels) of the render pass's sky radiance
// (phase.hpp sky_radiance) without its sun disc: the sun's own light is the τ_sun term.
std::vector<float> sky_sh(const SkyParams& sky, int order, int n_theta);

// Tripling coefficients C_ijk = ∫ y_i y_j y_k dω (order⁶ floats), exact by quadrature.
std::vector<float> sh_triple(int order);

// SH exponential τ = exp*(g) of an SH vector g (order² coefficients), two ways:
// - the paper's (Ren et al. 2006's optimal linear form, eq. 7):
//   exp*(g) ≈ exp(g₀/√4π)·(a(‖ĝ‖)·1 + b(‖ĝ‖)·ĝ) with a, b tabulated over ‖ĝ‖ ∈ [0, max_norm]
//   (linear between bin centres, clamped at the ends);
// - scaling and squaring (Ren et al. 2006 use it for large ‖ĝ‖): exp(g₀/√4π) is isolated,
//   ĥ = ĝ/2^k with ‖ĥ‖ ≤ ¼, exp*(ĥ) ≈ 1 + ĥ + ½ ĥ*ĥ, then k SH self-products (each truncated
//   to the kept bands). Far more accurate where optical depths vary strongly over directions
//   (a cloud's interior against its edge), at k+1 triple products per voxel.
struct ShExpTable {
  int order = 3;
  float max_norm = 0.0f;
  std::vector<float> a, b;  // one entry per bin centre (the paper's method)
  bool squaring = false;
  std::vector<float> triple;  // sh_triple(order) when squaring

  // τ = exp*(g): order² coefficients of exp(g·y(ω)) from g (order² coefficients) into out.
  void apply(const float* g, float* out) const;
};

// A scaling-and-squaring SH exponential for `order`.
ShExpTable shexp_squaring(int order);

// Fit a, b by least squares: for `count` SH vectors f (optical depths), g = −σ_t·f; the target is
// the quadrature projection of exp(g·y(ω)) (the exponential of the band-limited optical depth)
// divided by exp(g₀/√4π). Since 1 and ĝ are orthogonal the two unknowns decouple per bin:
// a = mean(τ̃₀)/√4π, b = Σ τ̃·ĝ / Σ ‖ĝ‖². Empty bins copy their nearest filled neighbour.
ShExpTable fit_shexp(const float* f, std::size_t count, int order, float sigma_t, int bins,
                     int n_theta);

// The per-voxel light the renderer reads, 4 floats per voxel: τ_sun = exp(−σ_t·f_sun) and the
// sky irradiance E_sky (RGB) = ∫ L_sky(ω) τ(x, ω) dω = Σ_m L_m τ_m(x), τ = exp*(−σ_t·f_sh).
std::vector<float> light_volume(const float* f_sun, const float* f_sh, const VolumeGrid& g,
                                const ShExpTable& table, const float* sky_coeffs, float sigma_t,
                                int threads);

// --- multiple isotropic scattering through sample points (§3.2, eq. 8) ------------------------
//
// K points q_k uniform in the box (seeded, the same for every database volume). The optical depth
// between every voxel centre and every q_k is precomputed per database volume; it is linear in ρ,
// so a blended frame's is the blend (the paper's eq. 9 blends log τ̃, which is −σ_t·f + log G with
// the same G for both volumes: the same thing). Instead of the paper's cuts the K terms are
// summed directly (K is small here).

// `count` points uniform in the box (xyz): jittered over a ⌈∛count⌉³ lattice, then the first
// `count` cells in a seeded shuffle, so the points cover the box evenly.
std::vector<glm::vec3> volume_sample_points(const VolumeGrid& g, int count, std::uint64_t seed);

// ∫ ρ along the segment a → b (midpoint rule, steps ≤ step_voxels voxel sizes).
float optical_depth_segment(const float* vol, const VolumeGrid& g, glm::vec3 a, glm::vec3 b,
                            float step_voxels);

// Optical depth from every voxel centre to every point: count × voxels × points floats.
std::vector<float> point_optical_depth(const float* volumes, int count, const VolumeGrid& g,
                                       const std::vector<glm::vec3>& points, float step_voxels,
                                       int threads, DepthMethod method = DepthMethod::March);

// Adds `orders` orders of isotropic multiple scattering to `light` (voxels × 4, from
// light_volume) in place, as irradiance in channels 1..3. The first order's isotropic irradiance
// is E₁ = sun·τ_sun + E_sky; order n: at each q_k, ρ_k and E_{n−1}(q_k) are trilinear
// (eq. 8's "interpolated from the neighbouring voxels"), and
//   E_n(x) = Σ_k (V/K)·σ_t·ρ_k·albedo·E_{n−1}(q_k)/4π · exp(−σ_t f(x, q_k)) / max(d², d_min²)
// with d = |x − q_k| and d_min half the mean spacing of the points (the geometric term, clamped
// where the Monte Carlo estimate of the 1/d² singularity is unreliable).
void add_multiple_scattering(const float* density, float* light, const VolumeGrid& g,
                             const float* point_depth, const std::vector<glm::vec3>& points,
                             glm::vec3 sun_radiance, float sigma_t, float albedo, int orders,
                             int threads);

}  // namespace cumuli
