#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "cumuli/large_buffer.hpp"

namespace cumuli {

// A symmetric positive definite 7-point system over a compact list of cells (the medium cells
// of a lattice, in lattice order): row k is diag[k]·x_k − Σ_a cond[k][a]·x_{nb[k][a]}, the
// neighbours ordered −x, −y, −z (earlier cells) then +x, +y, +z (later cells); a missing
// neighbour has cond 0 and index size() (a zero slot past the cells). The −x neighbour, when there
// is one, is the previous cell (k − 1) and the +x neighbour the next (k + 1): the solve's sweeps
// rely on it.
struct CellSystem {
  struct Row {
    std::array<std::int32_t, 6> nb{};
    std::array<float, 6> cond{};
    float diag = 1.0f;
  };
  LargeVector<Row> rows;
  std::size_t size() const { return rows.size(); }
};

// The modified incomplete Cholesky factor (MIC(0), no fill: Gustafsson 1978) M = L·Lᵀ of a
// CellSystem in its own order, kept as the coefficients of its two triangular sweeps: with
// p_k = 1/√e_k (e_k the pivot), forward y_k = p_k·r_k + Σ_lower lower[k][a]·y_j and backward
// z_k = p_k·y_k + Σ_upper upper[k][a]·z_j, lower[k][a] = c_kj·p_j·p_k, upper[k][a] = c_kj·p_k².
struct MicFactor {
  LargeVector<float> inv_sqrt;              // p_k
  LargeVector<std::array<float, 3>> lower;  // a = −x, −y, −z
  LargeVector<std::array<float, 3>> upper;  // a = +x, +y, +z
};

// MIC(0) of `s`: the dropped fill-in moved to the diagonal with weight `tau` (row sums kept at
// tau = 1); a pivot below `safety`·diag falls back to the diagonal.
MicFactor mic_factor(const CellSystem& s, float tau = 0.97f, float safety = 0.25f);

// Solves s·x = b by conjugate gradients preconditioned with `f`, on one thread (each step in
// the cells' order: the result does not depend on anything else), from x's values (size()+1
// entries, the last 0) until |r| ≤ tolerance·|b| or max_iterations. Returns the iterations.
int solve_mic(const CellSystem& s, const MicFactor& f, const LargeVector<double>& b,
              LargeVector<double>& x, double tolerance, int max_iterations);

}  // namespace cumuli
