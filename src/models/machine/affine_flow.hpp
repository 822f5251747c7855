// SPDX-License-Identifier: MIT
// The exact solution of a small linear system with a constant input,
//
//   x' = A x + c   over a span t:   x(t) = Phi x(0) + Psi c,
//   Phi = e^(A t),  Psi = integral from 0 to t of e^(A s) ds,
//
// which is what an axis and its drives' velocity loops are between two
// events (servo_motion.hpp). Phi and Psi depend on A and t only, so a plant
// that keeps them for its usual span pays one matrix-vector product per
// span, whatever the command (c) is.
//
// Both come from one matrix exponential, e^[[A t, I t], [0, 0]] =
// [[Phi, Psi], [0, I]], by scaling and squaring a truncated Taylor series:
// the block is scaled to a norm of at most 1/2, where 14 terms leave an
// error below the double's precision, then squared back.
#pragma once

#include <array>
#include <cstddef>

namespace lbpkit::model::machine {

inline constexpr std::size_t kMaxFlowDimension = 6;

using FlowVector = std::array<double, kMaxFlowDimension>;
using FlowMatrix = std::array<FlowVector, kMaxFlowDimension>;

struct AffineFlow {
  // The dimension used: the first n rows and columns (the rest is left
  // unset: a plant keeps several of these and makes them often).
  std::size_t n = 0;
  FlowMatrix phi;
  FlowMatrix psi;

  // The flow of x' = A x + c over `seconds` (>= 0), for the top-left n x n of `a`.
  static AffineFlow over(const FlowMatrix& a, std::size_t n, double seconds);

  // Where x goes over `seconds` under input c, without the matrices: the
  // same series on the vector, (A t)^k / k! applied to A x + c, in
  // substeps short enough that 14 terms reach the double's precision. A
  // few hundred operations for one span where the flow is not kept (an
  // event's search, a span of a length seen once), against a few thousand
  // for the flow; a piece so stiff that it would take more than 32
  // substeps is solved through the flow instead.
  static FlowVector solve(const FlowMatrix& a, std::size_t n, const FlowVector& x, const FlowVector& c,
                          double seconds);

  // Phi x + Psi c: where x goes over the span under input c.
  [[nodiscard]] FlowVector apply(const FlowVector& x, const FlowVector& c) const {
    FlowVector out{};
    for (std::size_t i = 0; i < n; ++i) {
      double v = 0.0;
      for (std::size_t j = 0; j < n; ++j) v += phi[i][j] * x[j] + psi[i][j] * c[j];
      out[i] = v;
    }
    return out;
  }
};

}  // namespace lbpkit::model::machine
