// Runtime choice of the SIMD width used by the core's bulk loops (fBm first of all; Jiménez de
// Parga & Gómez Palomo 2018, eq. 1, evaluated 8 or 16 points at a time).
//
// One binary runs on any x86-64: the wide paths are compiled with GCC/Clang `target` attributes
// (AVX2, AVX-512F) next to the baseline (SSE2) code and picked at run time from what the CPU and
// the OS support. Every path performs the same float32 operations in the same order (no FMA, no
// reassociation), so their results are bit-identical; the level only changes speed.
//
// The level in use is, in order of precedence: the last set_simd_level(), else the environment
// variable CUMULI_SIMD (scalar | avx2 | avx512 | auto) read at first use — a level the machine
// lacks falls back to the widest one it has below it —, else the widest supported level.
#pragma once

#include <string>

namespace cumuli {

enum class SimdLevel : int { Scalar = 0, Avx2 = 1, Avx512 = 2 };

// "scalar", "avx2" or "avx512".
const char* simd_name(SimdLevel level);
// The level of a name (as simd_name writes it); throws std::invalid_argument otherwise.
SimdLevel parse_simd_level(const std::string& name);
// Whether this build has the level's code and this CPU (and OS) can run it.
bool simd_supported(SimdLevel level);
// The widest supported level.
SimdLevel simd_best();
// The level the core's bulk loops use now.
SimdLevel simd_level();
// Use `level` from now on (all threads). Throws std::invalid_argument if it is not supported.
void set_simd_level(SimdLevel level);
// Back to the default: CUMULI_SIMD if set, else the widest supported level.
void reset_simd_level();

// How the wide fBm kernels read a cell's 2×2×2 lattice values. All give the same bits; they
// differ in speed, which depends on the CPU:
//   Gather: the four rows' (x0, x1) pairs with 64-bit gather instructions from the 1.1 MB padded
//           lattice (fast on Intel; micro-coded and slow on AMD Zen 2/3);
//   Loads:  the same pairs with plain 64-bit loads from the indices stored to memory;
//   Cells:  one 32-byte load per point, the cell's eight corners, from a table that stores every
//           cell whole (four times the memory: 4.4 MB at size 64; lattices above 64 have no
//           table and read as Loads).
// The default is the CPU's preferred fetch (simd_fetch_preferred: Cells on AMD, Gather
// elsewhere, as measured by bench_noise), unless CUMULI_SIMD_FETCH (gather | loads | cells |
// auto), read at first use, or set_simd_fetch() says otherwise.
enum class SimdFetch : int { Gather = 0, Loads = 1, Cells = 2 };

// "gather", "loads" or "cells".
const char* simd_fetch_name(SimdFetch fetch);
// The fetch of a name (as simd_fetch_name writes it); throws std::invalid_argument otherwise.
SimdFetch parse_simd_fetch(const std::string& name);
// The fetch this CPU runs fastest where measured: Cells on AMD, Gather elsewhere.
SimdFetch simd_fetch_preferred();
// The fetch the wide kernels use now.
SimdFetch simd_fetch();
// Use `fetch` from now on (all threads).
void set_simd_fetch(SimdFetch fetch);
// Back to the default: CUMULI_SIMD_FETCH if set, else simd_fetch_preferred().
void reset_simd_fetch();

}  // namespace cumuli
