// The implicit step with prescribed normal velocities: filtered (modified) preconditioned CG,
// Baraff & Witkin, "Large steps in cloth simulation" (SIGGRAPH 1998), section 5.3. Design note:
// - A constrained vertex i has a unit normal n_i and a prescribed v_{n+1} . n_i = c_i, i.e.
//   dv_i . n_i = c_i - v_i . n_i; its tangential components are free. With the filter
//   S_i = I - n_i n_i^T (S_i = I for a free vertex), dv = z + y with z the prescribed part and y in
//   the range of S; CG runs on S A S y = S (rhs - A z), which is symmetric positive definite on that
//   subspace, so the prescribed components are never touched by the iterations (exact, not to
//   solver tolerance).
// - Preconditioner: block-Jacobi filtered the same way, S D_i^-1 S. SSOR is not used with
//   constraints (its sweeps would mix constrained components in; a filtered SSOR that stays
//   symmetric is left for later).
// - Warm start: the dv in the scratch (the unconstrained solve of the same step, when the contact
//   stage re-solves), filtered and given the prescribed part; zero if that is worse than zero.
// - Unilateral contact: after a solve the constraint force of vertex i is f_i = (A dv - rhs)_i / h
//   (N, along n_i once converged). A constraint whose force pulls (f_i . n_i < 0, adhesion) is
//   released and the step solved again, at most kReleasePasses times; a pull left after the last
//   pass stays (its force is reported as it is).
#include <algorithm>
#include <cmath>

#include "sim/model/corotational_fem.h"
#include "sim/model/preconditioned_cg.h"

namespace pliant {
namespace {

/// Solves after the first in which pulling constraints are released (an active-set loop). Measured
/// on the drop of a nu 0.499 block at CFL 4-13 (tests/sim/contact_implicit_correction_test.cpp):
/// 2 passes left 65 pulling constraints over the sweep, 4 left 2, 8 none; most steps need none.
constexpr int kReleasePasses = 8;

}  // namespace

CorotationalFem::CgOutcome CorotationalFem::solve_constrained(std::span<const Vec3> v, double mass_scale,
                                                              double stiffness_scale,
                                                              const IntegrationInput& in) {
  const size_t n = dv_.size();
  const double h = in.dt;
  constraint_normal_.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const bool free = in.fixed[i] != 0 || i >= in.constraint_normals.size();
    constraint_normal_[i] = free ? Vec3::Zero() : in.constraint_normals[i];
  }
  // S_i a: a without its component along the vertex's active normal.
  auto filter = [&](size_t i, const Vec3& a) {
    const Vec3& normal = constraint_normal_[i];
    return Vec3(a - normal * normal.dot(a));
  };
  // The prescribed part z_i = n_i (c_i - v_i . n_i).
  auto prescribed = [&](size_t i) {
    const Vec3& normal = constraint_normal_[i];
    if (normal.isZero()) return Vec3(Vec3::Zero());
    return Vec3(normal * (in.constraint_normal_velocities[i] - v[i].dot(normal)));
  };
  auto precondition = [&](size_t i) {
    return in.fixed[i] != 0 ? Vec3(Vec3::Zero()) : filter(i, preconditioner_[i] * filter(i, r_[i]));
  };

  CgOutcome outcome;
  for (int pass = 0;; ++pass) {
    // Reduced right-hand side S (rhs - A z) from a zero free part: its norm is the reference of the
    // stopping rule (kv_ is free scratch once the right-hand side is built).
    for (size_t i = 0; i < n; ++i) p_[i] = prescribed(i);
    multiply_system(p_, q_, mass_scale, stiffness_scale, in.masses, in.fixed);
    double reference_sq = 0.0;
    for (size_t i = 0; i < n; ++i) {
      kv_[i] = filter(i, rhs_[i] - q_[i]);
      reference_sq += kv_[i].squaredNorm();
    }
    const double reference = std::sqrt(reference_sq);
    // Warm start: the scratch's dv, filtered, plus z.
    for (size_t i = 0; i < n; ++i) {
      const Vec3 start = in.fixed[i] != 0 || !dv_[i].allFinite() ? Vec3::Zero() : filter(i, dv_[i]);
      dv_[i] = start + p_[i];
    }
    double residual = 0.0;
    if (reference == 0.0) {
      std::copy(p_.begin(), p_.end(), dv_.begin());  // y = 0 solves the reduced system exactly
      std::fill(r_.begin(), r_.end(), Vec3::Zero());
    } else {
      multiply_system(dv_, q_, mass_scale, stiffness_scale, in.masses, in.fixed);
      double rr = 0.0;
      for (size_t i = 0; i < n; ++i) {
        r_[i] = filter(i, rhs_[i] - q_[i]);
        rr += r_[i].squaredNorm();
      }
      residual = std::sqrt(rr) / reference;
      if (residual > 1.0) {  // the warm start is worse than zero
        std::copy(p_.begin(), p_.end(), dv_.begin());
        std::copy(kv_.begin(), kv_.end(), r_.begin());
        residual = 1.0;
      }
    }
    // Filtered block-Jacobi PCG on the free components.
    const PcgOutcome o = preconditioned_cg(
        dv_, r_, p_, q_, z_, residual, reference, accuracy_.solver_tolerance, accuracy_.max_solver_iterations,
        [&](std::span<const Vec3> p, std::span<Vec3> q) {
          multiply_system(p, q, mass_scale, stiffness_scale, in.masses, in.fixed);
          double pq = 0.0;
          for (size_t i = 0; i < n; ++i) {
            q[i] = filter(i, q[i]);
            pq += p[i].dot(q[i]);
          }
          return pq;
        },
        precondition);
    outcome.iterations += o.iterations;
    outcome.residual = o.residual;

    // Constraint forces (A dv - rhs) / h along n; release the ones that pull.
    multiply_system(dv_, q_, mass_scale, stiffness_scale, in.masses, in.fixed);
    int released = 0;
    for (size_t i = 0; i < n; ++i) {
      const Vec3& normal = constraint_normal_[i];
      if (normal.isZero()) continue;
      const double force = normal.dot(q_[i] - rhs_[i]) / h;
      if (force < 0.0 && pass < kReleasePasses) {
        constraint_normal_[i].setZero();
        ++released;
      }
    }
    if (released == 0 || pass == kReleasePasses) break;
  }
  if (!in.constraint_forces.empty()) {
    for (size_t i = 0; i < n; ++i) {
      const Vec3& normal = constraint_normal_[i];
      in.constraint_forces[i] = normal * (normal.dot(q_[i] - rhs_[i]) / h);
    }
  }
  return outcome;
}

}  // namespace pliant
