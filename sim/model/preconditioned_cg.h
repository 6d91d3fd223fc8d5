// The preconditioned conjugate-gradient loop shared by the corotational FEM's block-Jacobi solve and
// its filtered (constrained) solve (Baraff & Witkin 1998 sec. 5.3; Saad, Iterative Methods for
// Sparse Linear Systems, alg. 9.1). Design note: the caller owns the vectors and has set the warm
// start dv, its residual r and the relative residual |r| / reference; the loop is parameterised by
//   product(p, q) -> p . q   (q = A p, filtered by the caller where constraints apply), and
//   precondition(i) -> z_i   (from r_i, filtered likewise).
// The arithmetic and its order are the block-Jacobi loop's as it was written before (bit for bit).
#pragma once

#include <cmath>
#include <span>

#include "sim/math_types.h"

namespace pliant {

/// Iterations run and the final relative residual of a preconditioned CG loop.
struct PcgOutcome {
  int iterations = 0;
  double residual = 0.0;
};

/// Runs PCG from the warm start in dv (r its residual, `residual` = |r| / reference) until the
/// relative residual <= tolerance or max_iterations; p, q, z are scratch of dv's size.
template <class Product, class Precondition>
PcgOutcome preconditioned_cg(std::span<Vec3> dv, std::span<Vec3> r, std::span<Vec3> p, std::span<Vec3> q,
                             std::span<Vec3> z, double residual, double reference, double tolerance,
                             int max_iterations, Product&& product, Precondition&& precondition) {
  const size_t n = dv.size();
  double rz = 0.0;
  for (size_t i = 0; i < n; ++i) {
    p[i] = z[i] = precondition(i);
    rz += r[i].dot(z[i]);
  }
  int it = 0;
  while (residual > tolerance && it < max_iterations) {
    const double pq = product(p, q);
    if (!(pq > 0.0) || !(rz > 0.0)) break;
    const double a = rz / pq;
    double rr_next = 0.0, rz_next = 0.0;
    for (size_t i = 0; i < n; ++i) {
      dv[i] += a * p[i];
      r[i] -= a * q[i];
      z[i] = precondition(i);
      rr_next += r[i].squaredNorm();
      rz_next += r[i].dot(z[i]);
    }
    ++it;
    residual = std::sqrt(rr_next) / reference;
    if (residual <= tolerance) break;
    const double b = rz_next / rz;
    rz = rz_next;
    for (size_t i = 0; i < n; ++i) p[i] = z[i] + b * p[i];
  }
  return {it, residual};
}

}  // namespace pliant
