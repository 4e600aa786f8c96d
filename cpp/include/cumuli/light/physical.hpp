// The light step of the physical lighting mode (RENDER_CONTRACT "Physical lighting"): what the
// drawers read to solve the volume rendering equation with three stated approximations.
//
// 1. Sun transmittance: the optical depth τ_sun towards the sun on a lattice in the SUN'S frame
//    (axes u, v across the light, w along it), fine along w, so that the steep rise of τ at a
//    sunlit surface is resolved and trilinear lookups show no cells. Each column of the lattice
//    is one ray marched through the drawable's extinction σt (the cloud's density field with
//    the union march's attribution, or a volume's trilinear density), the τ of a node being the
//    integral from the lattice's sun-side face to the node (the lattice box encloses the
//    drawable, so nothing upstream of it is missed).
// 2. Sky light: the SH projection (Sloan et al. 2002; the endless animation's sh_eval and
//    quadrature, light/volume.hpp) of the visibility V(x, ω) = exp(−∫σt) over the quadrature's
//    directions, dotted with the sky radiance's SH projection: E_sky(x) = Σ_m L_m V_m(x), the
//    sky irradiance over the whole sphere that reaches x unscattered (clamped at 0).
// 3. Multiple scattering: the diffusion approximation (Stam 1995, "Multiple scattering as a
//    diffusion process"; Jensen et al. 2001 for the boundary) on the world lattice:
//    −∇·(D∇φ) + σa·φ = Q, D = 1/(3σt'), σt' = σa + σs(1 − ḡ), with the collided source
//    Q = σs·(E_sun·T_sun + E_sky) (scaled so that each cell receives the power it removes from
//    the light, see diffusion_sources) and Marshak's vacuum boundary (no diffuse light enters)
//    on every face between a medium cell and an empty one: outward flux 2D/(h + 4D)·φ. Cells
//    with σt·h < 0.02 are empty. Solved by Jacobi-preconditioned conjugate gradients with
//    reductions in fixed blocks, so the result does not depend on the thread count; empty
//    cells next to the medium take the boundary value φ·4D/(h + 4D) so that trilinear lookups
//    at the surface see the fluence there.
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/large_buffer.hpp"
#include "cumuli/light/volume.hpp"
#include "cumuli/model/cloud.hpp"
#include "cumuli/primitives.hpp"

namespace cumuli {

// A lattice in the sun's frame. Node (i, j, k) sits at frame coordinates
// lo + ((i, j, k) + ½)·(hi − lo)/res; frame coordinates of a world point are (p·u, p·v, p·w).
struct SunFrame {
  glm::vec3 u{1.0f, 0.0f, 0.0f}, v{0.0f, 1.0f, 0.0f}, w{0.0f, 0.0f, 1.0f};
  glm::vec3 lo{0.0f}, hi{1.0f};
  int res[3] = {2, 2, 2};

  glm::vec3 to_frame(glm::vec3 p) const;
  // World position of a node.
  glm::vec3 node(int i, int j, int k) const;
  void validate() const;  // throws std::invalid_argument
};

// The frame of light travelling along −to_sun, its box enclosing `world_box` (padded by half a
// node on every side so that the outermost nodes lie on the enclosing box).
SunFrame make_sun_frame(const Box& world_box, glm::vec3 to_sun, const int res[3]);

// Trilinear value of a [w][v][u] lattice at world point p (texel centres, clamp to edge), plus,
// when `columns` is given, the bilinear value of a [v][u] map of one value per column (the same
// along the light: the optical depth of other media upstream of the lattice).
float sample_frame(const float* values, const SunFrame& f, glm::vec3 p,
                   const float* columns = nullptr);

// The collided sun light carried on along the light before it diffuses: a share `share` of
// what collides travels on along the sun's way and turns diffuse at the rate `rate`·σ (in
// optical depth). The diffusion's sun source then follows, per unit of the collided light,
// (1 − share)·e^{−kτ} + share·a/(a − k)·(e^{−kτ} − e^{−aτ}) (a = rate, k the depth scale):
// the solution of dC/dτ = e^{−kτ} − a·C, read as a·C. share 0: the light diffuses where it
// collides.
struct CarriedSource {
  float share = 0.0f;
  float rate = 1.0f;
};

// The carried source's factor at optical depth τ with depth scale k (see CarriedSource).
double carried_factor(double tau, double k, const CarriedSource& carried);

// e^{−τ} of a frame's optical depths `depth` at the centres of a dims[0] × dims[1] × dims[2]
// (x, y, z) lattice, [z][y][x]: centre (i, j, k) at lo + (index + ½)·cell per axis, in float32
// as written (the sun's transmittance on a drawable's world lattice); `columns`, when given, the
// per-column depths sample_frame adds; `depth_scale` k: e^{−k·τ} (the δ-M similarity relation's
// transmittance, with the phase's forward peak taken as unscattered); `carried`, when its share
// is > 0: carried_factor instead of e^{−kτ} (the diffusion's sun source).
LargeVector<float> lattice_transmittance(const float* depth, const SunFrame& f, glm::vec3 lo,
                                         glm::vec3 cell, const int dims[3], int threads,
                                         const float* columns = nullptr, float depth_scale = 1.0f,
                                         const CarriedSource& carried = {});

// What extinction a ray meets.
struct CloudMedium {
  const CloudShape* shape = nullptr;
  DensitySource source;
  float scale = 1.0f;  // σt = scale · ρ
};
struct VolumeMedium {
  const float* density = nullptr;  // [z][y][x]
  VolumeGrid grid;
  float scale = 1.0f;  // σt = scale · density
};
struct Medium {
  std::vector<CloudMedium> clouds;
  std::vector<VolumeMedium> volumes;

  // ∫ σt along o + t·d for t ≥ 0 through every cloud and volume (each to its box exit), in
  // segments of at most `step` sampled at their midpoints (a cloud: only inside the union of its
  // candidate primitives; exact for a constant σt). `d` is unit length.
  float optical_depth(glm::vec3 o, glm::vec3 d, float step) const;
};

// τ at every node of `frame` ([w][v][u] floats): the optical depth of `medium` from the frame's
// sun-side face (w = lo.w) to the node along +w, marched in segments of at most `step`.
// `depth_cut` (> 0; infinite: none) ends each drawable's march along a column after the segment
// where its depth exceeds the cut: a node keeps the exact value unless that segment ends before
// it, and then holds a depth above the cut (the light beyond, e^−cut, is not worth marching).
LargeVector<float> light_space_depth(const Medium& medium, const SunFrame& frame, float step,
                                     int threads, double depth_cut = INFINITY);

// The sky visibility's rays: Lattice, the 26 steps to a voxel's neighbours (Lebedev's 26-point
// rule where voxels are cubes; τ exact for the trilinear field, one pass over the lattice per
// direction), or March, the n_theta product quadrature (SphereQuadrature) with a ray marched per
// voxel and direction.
enum class SkyRays { Lattice, March };

// E_sky (RGB, interleaved) at every voxel centre of the extinction lattice `ext` (σt, [z][y][x]
// over g): Σ_m L_m V_m with V the SH projection (order² coefficients) of exp(−τ(x, ω)); voxels
// with no medium within one voxel get the open sky. March rays (the default): τ marched through
// `ext` with steps of step_voxels voxels, stopped once τ > 6 (the e^−6 of visibility left is
// dropped), over the n_theta product quadrature. Lattice rays (n_theta and step_voxels unused)
// are taken where the voxels' sides differ by at most 10 %, March rays otherwise.
// The sky-independent half of sky_irradiance: each voxel's visibility moments V_m (voxels ×
// order² floats, voxel-major, each summed in double; V_0 = √4π and the others 0 where no medium
// lies within one voxel), so that a changed sky or sun re-projects them without marching again.
LargeVector<float> sky_visibility(const float* ext, const VolumeGrid& g, int order, int n_theta,
                                  float step_voxels, int threads, SkyRays rays = SkyRays::March);
// A drawable's physical light lattice, RGBA per voxel (`voxels` of them): A the diffuse sun, RGB
// the sky, from the diffusion's fluence `phi` (4 channels: sun, sky RGB; 1: sun; nullptr: no
// multiple scattering) and the sky irradiance `sky_e` (RGB; nullptr: no sky light):
//   A = G_sun·φ_sun, RGB = G_sky·(E_sky + φ_sky)   (E_sky alone without φ; 0 without either),
// G = 1 + (G∞ − 1)(1 − e^{−τc/τg}) per cell, τc = max(σt, 0)·cell, in double rounded to float
// (G∞ everywhere when τg = 0); the products in float.
LargeVector<float> physical_grid(const float* ext, std::size_t voxels, const float* phi,
                                 int phi_channels, const float* sky_e, double cell,
                                 double gain_depth, double sun_gain, double sky_gain, int threads);

// E_sky = max(0, Σ_m L_m V_m) per voxel (RGB interleaved) from sky_visibility's moments (each
// voxel's sum on one thread: the same on any thread count).
LargeVector<float> sky_irradiance_from(const float* visibility, std::size_t voxels,
                                       const float* sky_coeffs, int order, int threads = 1);
LargeVector<float> sky_irradiance(const float* ext, const VolumeGrid& g, const float* sky_coeffs,
                                  int order, int n_theta, float step_voxels, int threads,
                                  SkyRays rays = SkyRays::March);

// The diffusion's linear solver: conjugate gradients preconditioned by the diagonal (Jacobi)
// over the whole lattice, or by the modified incomplete Cholesky factor (MIC(0)) over the
// medium cells only.
enum class DiffusionSolver { jacobi, mic };

struct DiffusionParams {
  float albedo = 0.99f;       // ϖ
  float mean_cosine = 0.6f;   // ḡ of the phase function
  int max_iterations = 5000;  // conjugate-gradient iterations per channel, at most
  float tolerance = 1e-5f;    // on the residual relative to the source
  DiffusionSolver solver = DiffusionSolver::mic;
};

// The collided sources per cell (`channels` per voxel, interleaved): channel 0 the sun's
// (unit irradiance), 1..3 the sky's (when sky_e is not null). A cell of extinction σ whose
// centre sees the light with transmittance T removes T·(e^{x/2} − e^{−x/2})/ℓ of a unit beam
// per unit volume (x = σℓ, ℓ its thickness along the light: h_x h_y h_z / Σ_a |d_a| A_a for the
// sun, 2h/3 — the mean chord — for the sky), the albedo's share of which scatters:
// Q = ϖ·T·2 sinh(x/2)/ℓ (→ ϖσT for thin cells), so coarse cells keep the light's energy.
// Threads over z-slices (the values do not depend on the thread count).
LargeVector<float> diffusion_sources(const float* ext, const VolumeGrid& g, const float* sun_t,
                                     glm::vec3 to_sun, const float* sky_e, float albedo,
                                     int threads = 1);

// Adds to the sun's channel of `q` (`channels` per voxel) the forward-scattered sun's flux
// source −∇·(3D·Q1), Q1 = ϖσ·T·ḡ·ŝ the first moment of the collided source (ŝ the way the light
// travels; Ishimaru 1978, §9.2, the diffusion equation with the reduced intensity's flux), times
// `weight`, on the faces between medium cells only: it moves the source along the light
// (deeper into the cloud) and leaves its sum unchanged. weight 0: nothing is added.
void add_sun_flux_source(LargeVector<float>& q, int channels, const float* ext, const VolumeGrid& g,
                         const float* sun_t, glm::vec3 to_sun, float albedo, float mean_cosine,
                         float weight);

// φ (the collided fluence, `channels` per voxel) of the diffusion problem above.
LargeVector<float> diffusion_fluence(const float* ext, const VolumeGrid& g, const float* source,
                                     int channels, const DiffusionParams& p, int threads);

// The anisotropy r = 3E/φ of channel 0 of a diffusion solution `phi` (`channels` per voxel, as
// diffusion_fluence returns it), 3 per voxel (x, y, z): E = −D∇φ the diffuse flux, from the
// same face fluxes as the solve (between medium cells −D_face·Δφ/h, through a face to an empty
// cell or the lattice's edge Marshak's 2Dφ/(h + 4D) outward), averaged over a cell's two faces
// on each axis. The diffuse radiance is (φ + 3E·ω)/4π (P1), and light scattered towards ω is
// φ·(1 + ḡ·r·ω)/4π. |r| ≤ 3 (|E| ≤ φ); empty cells next to the medium hold the mean of their
// medium neighbours' (as the fluence's boundary values), the rest 0.
// With `sun_t` (the diffusion's sun transmittance, as add_sun_flux_source takes it) and a
// forward weight, E also holds the forward-scattered flux that source carries, weight·3D·Q1 on
// the faces between medium cells (E = −D∇φ + 3D·Q1, the P1 flux with a first-moment source):
// where the collided light has not yet diffused — thin strands, the first mean free paths — it
// streams on along the light.
LargeVector<float> diffusion_anisotropy(const float* ext, const VolumeGrid& g, const float* phi,
                                        int channels, const DiffusionParams& p, int threads,
                                        const float* sun_t = nullptr,
                                        glm::vec3 to_sun = glm::vec3(0.0f, 1.0f, 0.0f),
                                        float forward = 0.0f);

}  // namespace cumuli
