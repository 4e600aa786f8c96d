#include "cumuli/light/cell_system.hpp"

#include <cmath>

namespace cumuli {

MicFactor mic_factor(const CellSystem& s, float tau, float safety) {
  const std::size_t m = s.size();
  MicFactor f;
  f.inv_sqrt.assign(m + 1, 0.0f);
  f.lower.assign(m, {0.0f, 0.0f, 0.0f});
  f.upper.assign(m, {0.0f, 0.0f, 0.0f});
  for (std::size_t k = 0; k < m; ++k) {
    const CellSystem::Row& row = s.rows[k];
    double e = row.diag;
    for (int a = 0; a < 3; ++a) {
      const std::int32_t j = row.nb[a];
      if (row.cond[a] == 0.0f) continue;
      const double pj = f.inv_sqrt[j], c = row.cond[a];
      const CellSystem::Row& rj = s.rows[j];
      double other = 0.0;  // j's couplings to its later neighbours but k
      for (int b = 0; b < 3; ++b)
        if (b != a) other += rj.cond[3 + b];
      e -= (c * pj) * (c * pj) + tau * c * other * pj * pj;
    }
    if (!(e >= safety * row.diag)) e = row.diag;
    f.inv_sqrt[k] = static_cast<float>(1.0 / std::sqrt(e));
  }
  for (std::size_t k = 0; k < m; ++k) {
    const CellSystem::Row& row = s.rows[k];
    const double pk = f.inv_sqrt[k];
    for (int a = 0; a < 3; ++a) {
      f.lower[k][a] = static_cast<float>(row.cond[a] * pk * f.inv_sqrt[row.nb[a]]);
      f.upper[k][a] = static_cast<float>(row.cond[3 + a] * pk * pk);
    }
  }
  f.inv_sqrt.resize(m);
  return f;
}

namespace {

// One cell of the forward sweep of z = M⁻¹·r. The −x neighbour, when there is one, is the
// previous cell: its value comes in a register (`prev`, with a coefficient of 0 where there is
// none), added last, so that the chain from cell to cell is one multiply and one add.
inline double forward_at(const CellSystem& s, const MicFactor& f, double r,
                         const LargeVector<double>& z, std::size_t k, double prev) {
  const auto& nb = s.rows[k].nb;
  const auto& l = f.lower[k];
  return (f.inv_sqrt[k] * r + l[1] * z[nb[1]] + l[2] * z[nb[2]]) + l[0] * prev;
}

// The backward sweep of z = M⁻¹·r over the forward sweep's values (in z), with Σ r·z; the +x
// neighbour is the next cell (as above).
double backward(const CellSystem& s, const MicFactor& f, const LargeVector<double>& r,
                LargeVector<double>& z) {
  double rz = 0.0, next = 0.0;
  for (std::size_t k = s.size(); k-- > 0;) {
    const auto& nb = s.rows[k].nb;
    const auto& u = f.upper[k];
    next = (f.inv_sqrt[k] * z[k] + u[1] * z[nb[4]] + u[2] * z[nb[5]]) + u[0] * next;
    z[k] = next;
    rz += r[k] * next;
  }
  return rz;
}

double apply_row(const CellSystem::Row& row, const LargeVector<double>& x, std::size_t k) {
  const auto& nb = row.nb;
  const auto& c = row.cond;
  return row.diag * x[k] - (c[0] * x[nb[0]] + c[1] * x[nb[1]] + c[2] * x[nb[2]] + c[3] * x[nb[3]] +
                            c[4] * x[nb[4]] + c[5] * x[nb[5]]);
}

}  // namespace

int solve_mic(const CellSystem& s, const MicFactor& f, const LargeVector<double>& b,
              LargeVector<double>& x, double tolerance, int max_iterations) {
  const std::size_t m = s.size();
  x.resize(m + 1);
  x[m] = 0.0;
  LargeVector<double> r(m + 1, 0.0), z(m + 1, 0.0), p(m + 1, 0.0), Ap(m, 0.0);
  double bb = 0.0;
  for (std::size_t k = 0; k < m; ++k) {
    r[k] = b[k] - apply_row(s.rows[k], x, k);
    bb += b[k] * b[k];
  }
  const double bnorm = std::sqrt(bb);
  if (!(bnorm > 0.0)) {
    x.assign(m + 1, 0.0);
    return 0;
  }
  double prev = 0.0;
  for (std::size_t k = 0; k < m; ++k) prev = z[k] = forward_at(s, f, r[k], z, k, prev);
  double rz = backward(s, f, r, z);
  for (std::size_t k = 0; k < m; ++k) p[k] = z[k];
  int it = 0;
  while (it < max_iterations) {
    ++it;
    double pAp = 0.0;
    for (std::size_t k = 0; k < m; ++k) {
      Ap[k] = apply_row(s.rows[k], p, k);
      pAp += p[k] * Ap[k];
    }
    if (!(pAp > 0.0)) break;
    const double alpha = rz / pAp;
    // The update, |r|² and the forward sweep of the preconditioner in one pass.
    double rr = 0.0;
    prev = 0.0;
    for (std::size_t k = 0; k < m; ++k) {
      x[k] += alpha * p[k];
      r[k] -= alpha * Ap[k];
      rr += r[k] * r[k];
      prev = z[k] = forward_at(s, f, r[k], z, k, prev);
    }
    if (std::sqrt(rr) <= tolerance * bnorm) break;
    const double rz_next = backward(s, f, r, z);
    const double beta = rz_next / rz;
    rz = rz_next;
    for (std::size_t k = 0; k < m; ++k) p[k] = z[k] + beta * p[k];
  }
  return it;
}

}  // namespace cumuli
