// SPDX-License-Identifier: MIT
#include "machine/affine_flow.hpp"

#include <algorithm>
#include <cmath>

namespace lbpkit::model::machine {

namespace {

constexpr std::size_t kBlock = 2 * kMaxFlowDimension;
using Block = std::array<std::array<double, kBlock>, kBlock>;

void multiply(const Block& a, const Block& b, Block& out, std::size_t m) {
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = 0; j < m; ++j) {
      double v = 0.0;
      for (std::size_t k = 0; k < m; ++k) v += a[i][k] * b[k][j];
      out[i][j] = v;
    }
}

}  // namespace

AffineFlow AffineFlow::over(const FlowMatrix& a, std::size_t n, double seconds) {
  AffineFlow f;
  f.n = std::min(n, kMaxFlowDimension);
  const std::size_t m = 2 * f.n;
  // The block [[A t, I t], [0, 0]] and its infinity norm.
  Block b{};
  double norm = 0.0;
  for (std::size_t i = 0; i < f.n; ++i) {
    double row = seconds;
    for (std::size_t j = 0; j < f.n; ++j) {
      b[i][j] = a[i][j] * seconds;
      row += std::abs(b[i][j]);
    }
    b[i][f.n + i] = seconds;
    norm = std::max(norm, row);
  }
  int squarings = 0;
  if (norm > 0.5) squarings = static_cast<int>(std::ceil(std::log2(norm / 0.5)));
  const double scale = std::ldexp(1.0, -squarings);
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = 0; j < m; ++j) b[i][j] *= scale;
  // e^B = I + B + B^2/2! + ... (Horner: I + B (I + B/2 (I + B/3 (...)))).
  constexpr int kTerms = 14;
  Block e{}, t{};
  for (std::size_t i = 0; i < m; ++i) e[i][i] = 1.0;
  for (int k = kTerms; k >= 1; --k) {
    multiply(b, e, t, m);
    for (std::size_t i = 0; i < m; ++i)
      for (std::size_t j = 0; j < m; ++j) e[i][j] = (i == j ? 1.0 : 0.0) + t[i][j] / k;
  }
  for (int s = 0; s < squarings; ++s) {
    multiply(e, e, t, m);
    e = t;
  }
  for (std::size_t i = 0; i < f.n; ++i)
    for (std::size_t j = 0; j < f.n; ++j) {
      f.phi[i][j] = e[i][j];
      f.psi[i][j] = e[i][f.n + j];
    }
  return f;
}

FlowVector AffineFlow::solve(const FlowMatrix& a, std::size_t n, const FlowVector& x, const FlowVector& c,
                             double seconds) {
  n = std::min(n, kMaxFlowDimension);
  double norm = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    double row = 0.0;
    for (std::size_t j = 0; j < n; ++j) row += std::abs(a[i][j]);
    norm = std::max(norm, row);
  }
  // A stiff piece (a drive's loop far faster than the span) would need many
  // substeps: the flow's squarings reach it in a logarithmic number.
  constexpr double kMostSubsteps = 32.0;
  const double needed = std::ceil(norm * seconds / 0.5);
  if (!(needed <= kMostSubsteps)) return over(a, n, seconds).apply(x, c);
  const int substeps = std::max(1, static_cast<int>(needed));
  const double h = seconds / substeps;
  FlowVector out = x;
  for (int s = 0; s < substeps; ++s) {
    // term_1 = h (A x + c), term_k = (h / k) A term_(k-1).
    FlowVector term{}, next{};
    for (std::size_t i = 0; i < n; ++i) {
      double v = c[i];
      for (std::size_t j = 0; j < n; ++j) v += a[i][j] * out[j];
      term[i] = h * v;
    }
    FlowVector sum = out;
    for (int k = 1;; ++k) {
      for (std::size_t i = 0; i < n; ++i) sum[i] += term[i];
      if (k == 14) break;
      for (std::size_t i = 0; i < n; ++i) {
        double v = 0.0;
        for (std::size_t j = 0; j < n; ++j) v += a[i][j] * term[j];
        next[i] = v * h / (k + 1);
      }
      term = next;
    }
    out = sum;
  }
  return out;
}

}  // namespace lbpkit::model::machine
