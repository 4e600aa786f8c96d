#version 430
// The render pass of Jiménez de Parga & Gómez Palomo 2018 (Algorithms 1 and 3), exactly as
// RENDER_CONTRACT.md states it (the C++ reference marcher implements the same contract).
// One fragment = one pixel of a tile: camera ray, clouds front to back by their box entry,
// sorted candidate primitives, "paper" or "union" marching with the LOD step, eq. (2) gating,
// light-grid lighting with HG scattering, early exit, sky blend.

#include "marcher/density.glsl"
#include "marcher/lighting.glsl"
#include "marcher/occupancy.glsl"
#include "common/sky.glsl"
#include "common/solid.glsl"
#include "common/ground.glsl"
#include "common/jitter.glsl"
#ifdef PHYSICAL
// The physical lighting mode (RENDER_CONTRACT "Physical lighting"): union marching with a
// jittered start, σ = extinction·ρ, physical.glsl's shading; u_absorption, u_g and u_union are
// not used.
#include "common/physical.glsl"
layout(std430, binding = 2) readonly buffer Physical { PhysicalCloud phys[]; };
#endif

// Compile-time caps: the settings are validated against them on the CPU (cumuli/scene.py).
#define MAX_CANDIDATES 128
#define MAX_CLOUDS 64

// Candidate sort, chosen when the program is compiled (cumuli/renderer.py defines it from
// settings.candidate_sort): the paper's insertion sort, iterative quicksort, Batcher's odd-even
// mergesort (same order, other costs), or none (unsorted: a cost reference, wrong where
// candidates overlap).
#define SORT_INSERTION 0
#define SORT_QUICK 1
#define SORT_ODDEVEN 2
#define SORT_NONE 3
#ifndef CANDIDATE_SORT
#define CANDIDATE_SORT SORT_INSERTION
#endif

#include "common/camera.glsl"

uniform vec3 u_sun_dir;
uniform vec3 u_sun_radiance;

uniform int u_cloud_count;
uniform float u_absorption;   // φ of Δτ = exp(−φ·ρ·Δ/Δ_ref)
uniform float u_step_ref;     // Δ_ref
uniform float u_lod_a;        // A
uniform float u_lod_delta;    // δ
uniform float u_step_min;
uniform float u_step_max;
uniform float u_fixed_step;   // > 0 replaces the LOD step
uniform float u_g;            // HG asymmetry
uniform int u_max_steps;
uniform int u_max_candidates;
uniform bool u_union;         // march = "union"
uniform float u_min_t;        // the paper mode's early exit: stop once T < u_min_t
uniform bool u_jitter;        // the paper mode's samples at ξ·Δ (the pixel's jitter), not Δ/2
uniform int u_jitter_seed;    // its pattern's seed
uniform bool u_with_sky;      // false: the premultiplied layer (colour, 1 − T) for the compositor
// The physical mode's edge pass (cumuli.rendering.edges): the draw covers a compact list of the
// pixels to march, not the image; fragment (i, j) of the list marches the image pixel (row, col)
// in texel (j, i) of u_pixel_list, and a texel of row −1 (the list's padding) gives 0. Every
// fragment of the draw is a ray that counts: none waits on its neighbours' masked-out ones.
uniform bool u_listed;
uniform isampler2D u_pixel_list;

out vec4 frag;

// Candidate list of the current cloud (Algorithm 1, GETCANDIDATES + SORTCANDIDATES).
float cand_in[MAX_CANDIDATES];
float cand_out[MAX_CANDIDATES];
int cand_prim[MAX_CANDIDATES];

// Candidate order: by t_in, ties by primitive index (the order a stable insertion sort of the
// primitives gives). Every sort below produces exactly this order, so they differ only in speed.
bool cand_less(int a, int b) {
    return cand_in[a] < cand_in[b] || (cand_in[a] == cand_in[b] && cand_prim[a] < cand_prim[b]);
}

void cand_swap(int a, int b) {
    float ti = cand_in[a], to = cand_out[a];
    int tp = cand_prim[a];
    cand_in[a] = cand_in[b]; cand_out[a] = cand_out[b]; cand_prim[a] = cand_prim[b];
    cand_in[b] = ti; cand_out[b] = to; cand_prim[b] = tp;
}

#if CANDIDATE_SORT == SORT_QUICK
// Iterative quicksort (the alternative the paper tried, §4.1): explicit stack, the smaller part
// on top so the stack never holds more than log2(n) + 1 ranges.
void sort_candidates(int n) {
    int lo_stack[16];
    int hi_stack[16];
    int top = 0;
    if (n > 1) { lo_stack[0] = 0; hi_stack[0] = n - 1; top = 1; }
    for (int iter = 0; iter < 2 * MAX_CANDIDATES && top > 0; ++iter) {
        --top;
        int lo = lo_stack[top], hi = hi_stack[top];
        cand_swap((lo + hi) / 2, hi);  // middle element as pivot, parked at hi
        int store = lo;
        for (int m = lo; m < hi; ++m) {
            if (cand_less(m, hi)) { cand_swap(m, store); ++store; }
        }
        cand_swap(store, hi);
        int left = store - 1 - lo, right = hi - store - 1;  // sizes minus one
        bool left_first = left > right;                      // larger part pushed first
        if (left_first && left > 0) { lo_stack[top] = lo; hi_stack[top] = store - 1; ++top; }
        if (right > 0 && top < 16) { lo_stack[top] = store + 1; hi_stack[top] = hi; ++top; }
        if (!left_first && left > 0 && top < 16) {
            lo_stack[top] = lo; hi_stack[top] = store - 1; ++top;
        }
    }
}
#elif CANDIDATE_SORT == SORT_ODDEVEN
// Batcher's odd-even mergesort for any n (the network the paper suggests, §4.1).
void sort_candidates(int n) {
    for (int p = 1; p < n; p += p) {
        for (int k = p; k > 0; k /= 2) {
            for (int j = k % p; j + k < n; j += k + k) {
                for (int i = 0; i < k && i + j + k < n; ++i) {
                    if ((i + j) / (p + p) == (i + j + k) / (p + p) && cand_less(i + j + k, i + j))
                        cand_swap(i + j, i + j + k);
                }
            }
        }
    }
}
#endif

// Collect the primitives of cloud c hit by the ray (grown by the candidate scale), clipped to
// [t_min, t_max], and order them (Algorithm 1, GETCANDIDATES + SORTCANDIDATES). At most `cap`
// are kept: the nearest ones, except with SORT_NONE, which keeps the first found.
int collect_candidates(CloudData c, vec3 o, vec3 d, float t_min, float t_max, int cap) {
    float scale = c.box_lo.w;
    int count = 0;
    int first = c.info.x;
    int n = c.info.y;
    for (int jj = 0; jj < n; ++jj) {
        int j = first + jj;
        Primitive e = prims[j];
        vec2 iv;
        if (!intersect_ellipsoid(e.centre.xyz, e.radii.xyz * scale, e.ax0.xyz, e.ax1.xyz,
                                 e.ax2.xyz, o, d, iv)) continue;
        float t0 = max(iv.x, t_min);
        float t1 = min(iv.y, t_max);
        if (!(t1 > t0)) continue;
        int pos = count;
#if CANDIDATE_SORT == SORT_INSERTION
        // The paper's insertion sort, done as the candidates arrive.
        if (count == cap) {
            if (t0 >= cand_in[cap - 1]) continue;
            pos = cap - 1;
        } else {
            ++count;
        }
        while (pos > 0 && cand_in[pos - 1] > t0) {
            cand_in[pos] = cand_in[pos - 1];
            cand_out[pos] = cand_out[pos - 1];
            cand_prim[pos] = cand_prim[pos - 1];
            --pos;
        }
#elif CANDIDATE_SORT == SORT_NONE
        if (count == cap) continue;
        ++count;
#else
        if (count == cap) {  // full: replace the farthest if this one starts nearer
            pos = 0;
            for (int m = 1; m < cap; ++m) {
                if (cand_less(pos, m)) pos = m;
            }
            if (!(t0 < cand_in[pos])) continue;
        } else {
            ++count;
        }
#endif
        cand_in[pos] = t0;
        cand_out[pos] = t1;
        cand_prim[pos] = j;
    }
#if CANDIDATE_SORT == SORT_QUICK || CANDIDATE_SORT == SORT_ODDEVEN
    sort_candidates(count);
#endif
    return count;
}

// Union marching: the covering candidate (t_in ≤ s ≤ t_out) whose primitive is nearest in its
// unit frame; `fallback` when none covers s.
int attribute_sample(int n, float s, vec3 p, int fallback) {
    int best = fallback;
    float best_q = 1e30;
    for (int m = 0; m < n; ++m) {
        if (cand_in[m] > s) break;  // sorted by t_in
        if (s <= cand_out[m]) {
            float q = primitive_q(cand_prim[m], p);
            if (q < best_q) { best_q = q; best = m; }
        }
    }
    return best;
}

void main() {
    // Pixel (row i from the top, column j) of the whole image.
    ivec2 pixel = pixel_of_fragment();
    if (u_listed) {
        pixel = texelFetch(u_pixel_list, ivec2(pixel.y, pixel.x), 0).xy;
        if (pixel.x < 0) {
            frag = vec4(0.0);
            return;
        }
    }
    int i = pixel.x, j = pixel.y;
    vec3 dir = camera_ray(pixel);
    vec3 o = u_cam_pos;

    const float HUGE = 1e30;
    vec3 inv_d = vec3(dir.x != 0.0 ? 1.0 / dir.x : HUGE,
                      dir.y != 0.0 ? 1.0 / dir.y : HUGE,
                      dir.z != 0.0 ? 1.0 / dir.z : HUGE);

    // Clouds whose box the ray meets, sorted front to back by entry t (clipped to ≥ 0); ties keep
    // the scene order (stable insertion sort).
    int order[MAX_CLOUDS];
    float entry[MAX_CLOUDS];
    float leave[MAX_CLOUDS];
    int hits = 0;
    int n_clouds = min(u_cloud_count, MAX_CLOUDS);
    // Opaque solids: the ray is marched only up to the nearest one (+∞ without solids).
    int solid_index;
    float t_solid = nearest_solid(o, dir, solid_index);
    for (int c = 0; c < n_clouds; ++c) {
        vec2 tb;
        if (!intersect_box(clouds[c].box_lo.xyz, clouds[c].box_hi.xyz, o, inv_d, tb)) continue;
        float t0 = max(tb.x, 0.0);
        if (tb.y < t0) continue;  // box behind the camera
        if (!(t0 < t_solid)) continue;  // behind the solid
        tb.y = min(tb.y, t_solid);
        int pos = hits++;
        while (pos > 0 && entry[pos - 1] > t0) {
            order[pos] = order[pos - 1];
            entry[pos] = entry[pos - 1];
            leave[pos] = leave[pos - 1];
            --pos;
        }
        order[pos] = c;
        entry[pos] = t0;
        leave[pos] = tb.y;
    }

    float cos_theta = dot(dir, u_sun_dir);
#ifdef PHYSICAL
    float ow[MAX_OCTAVES];
    float ok[MAX_OCTAVES];
    int no = octave_terms(cos_theta, ow, ok);
    float xi = phys_jitter(i, j);
#else
    float phase = hg_phase(u_g, cos_theta);
    // Each sample at ξ·Δ into its step: Δ/2 as the paper, or the pixel's jitter.
    float xi = u_jitter ? ign_jitter(i, j, u_jitter_seed) : 0.5;
#endif
    int cap = clamp(u_max_candidates, 1, MAX_CANDIDATES);
    int max_steps = max(u_max_steps, 1);

    vec3 colour = vec3(0.0);
    float T = 1.0;
    float T_view = 1.0;  // the radiance's transmittance (the physical mode's δ-M view; else T)
    int samples = 0;
    bool done = false;
    for (int h = 0; h < hits && !done; ++h) {
        CloudData c = clouds[order[h]];
        int n = collect_candidates(c, o, dir, entry[h], leave[h], cap);
        float step = u_fixed_step > 0.0
            ? u_fixed_step
            : clamp(u_lod_a * exp(-u_lod_delta * length(o - c.centre.xyz)), u_step_min, u_step_max);
        float t_union = -HUGE;
#ifdef PHYSICAL
        PhysicalCloud pc = phys[order[h]];
        float offset = xi * step;
        float dt = step;  // the step now: coarser as the ray grows opaque
        int inside = 0;   // samples inside the cloud so far (the C++ marcher's queue)
        for (int k = 0; k < n && !done; ++k) {
            if (cand_out[k] <= t_union) continue;
            float t = max(t_union, cand_in[k]);
            while (t < cand_out[k]) {
                if (samples >= max_steps) { done = true; break; }
                float s = t + offset;
                if (!(s < t_solid)) break;  // a solid hides the rest of the ray
                vec3 p = o + s * dir;
                float t_safe;
                if (u_skip_empty && empty_cell(c, p, o, dir, t_safe)) {
                    // Pass over the lattice's samples in the empty cell (each one a step).
                    t_safe = min(t_safe, t_solid);
                    do { ++samples; t += dt; }
                    while (samples < max_steps && t < cand_out[k] && t + offset < t_safe);
                    continue;
                }
                ++samples;
                int a = c.info.z == 0 ? attribute_sample(n, s, p, k) : k;
                vec2 d = cloud_density(c, cand_prim[a], p);
                float rho = d.x;
                if (rho > 0.0) {
                    float sigma = u_phys_extinction * rho;
                    float at = exp(-sigma * dt);
                    // The radiance sees σ·u_phys_view (the δ-M view); each unit of σ emits S.
                    float av = exp(-sigma * u_phys_view * dt);
                    vec3 S = phys_source(pc, p, ow, ok, no, u_sun_radiance, u_exact);
                    colour += T_view * ((1.0 - av) / u_phys_view) * S;
                    T *= at;
                    T_view *= av;
                    // Stopped: opaque (no light from behind leaks through the rest: a sun
                    // disc or its aureole behind the cloud is brighter than the cloud itself).
                    if (T_view < u_phys_min_t) { T = 0.0; T_view = 0.0; done = true; break; }
                }
                t += dt;
                // γ > 0: inside the cloud (a sample the C++ marcher queues).
                if (d.y > 0.0 && ++inside % COARSEN_EVERY == 0) dt = step * phys_coarsening(T_view);
            }
            t_union = t;
        }
#else
        for (int k = 0; k < n && !done; ++k) {
            float t = cand_in[k];
            if (u_union) {
                if (cand_out[k] <= t_union) continue;
                t = max(t_union, cand_in[k]);
            }
            while (t < cand_out[k]) {
                if (samples >= max_steps) { done = true; break; }
                float s = t + xi * step;
                if (!(s < t_solid)) break;
                vec3 p = o + s * dir;
                float t_safe;
                if (u_skip_empty && empty_cell(c, p, o, dir, t_safe)) {
                    // Pass over the lattice's samples in the empty cell (each one a step).
                    t_safe = min(t_safe, t_solid);
                    do { ++samples; t += step; }
                    while (samples < max_steps && t < cand_out[k] && t + xi * step < t_safe);
                    continue;
                }
                ++samples;
                int a = u_union && c.info.z == 0 ? attribute_sample(n, s, p, k) : k;
                vec2 dg = cloud_density(c, cand_prim[a], p);
                if (dg.x > 0.0) {
                    float dtau = exp(-u_absorption * dg.x * step / u_step_ref);
                    float pL = light_lookup(c, p, u_exact);
                    vec3 aL = u_sun_radiance * pL;
                    vec3 sL = aL * phase * dg.y;
                    colour += (1.0 - dtau) * (aL + sL) * T;
                    T *= dtau;
                    if (T < u_min_t) {
                        // Early exit: the rest of the ray's light estimated by this sample's
                        // source (the medium taken as opaque beyond), as the C++ twin does.
                        colour += T * (aL + sL);
                        T = 0.0;
                        done = true;
                        break;
                    }
                }
                t += step;
            }
            t_union = t;
        }
#endif
    }
#ifdef PHYSICAL
    float T_behind = T_view;
#else
    float T_behind = T;
#endif
    vec3 rgb = u_with_sky ? colour + T_behind * background(o, dir, u_sun_dir, u_sun_radiance) : colour;
    frag = vec4(rgb, 1.0 - T);
}
