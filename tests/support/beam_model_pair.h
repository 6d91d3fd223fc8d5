// Two copies of the tip-pushed beam (clamped_beam.h), each advanced by its own corotational model
// with the same input: the harness of the tests that compare a model option against the code before
// it, step by step and bit for bit.
#pragma once

#include <cstring>
#include <span>
#include <vector>

#include "sim/model/corotational_fem.h"
#include "support/clamped_beam.h"

namespace pliant {

/// Beam `a` advanced by model `first`, beam `b` by model `second`, from the same state. A test sets
/// the option under test on one model and changes a's masses or fixed flags between steps.
struct BeamModelPair {
  TipPushedBeam a, b;
  CorotationalFem first{a.mesh, a.material, ModelSettings{}};
  CorotationalFem second{b.mesh, b.material, ModelSettings{}};
  size_t n = static_cast<size_t>(a.mesh->vertex_count());

  /// One advance of both with the same input: time step dt, a's masses and fixed flags (copied to
  /// b), and the constraints if given.
  void advance_both(double dt, std::span<const Vec3> constraint_normals = {},
                    std::span<const double> constraint_velocities = {}) {
    b.masses = a.masses;
    b.fixed = a.fixed;
    IntegrationInput ia = a.input(), ib = b.input();
    ia.dt = ib.dt = dt;
    ia.constraint_normals = ib.constraint_normals = constraint_normals;
    ia.constraint_normal_velocities = ib.constraint_normal_velocities = constraint_velocities;
    first.advance(a.x, a.v, ia);
    second.advance(b.x, b.v, ib);
  }

  bool same_positions() const { return bitwise_equal(a.x, b.x); }
  bool same_velocities() const { return bitwise_equal(a.v, b.v); }

 private:
  static bool bitwise_equal(const std::vector<Vec3>& p, const std::vector<Vec3>& q) {
    return p.size() == q.size() && std::memcmp(p.data(), q.data(), p.size() * sizeof(Vec3)) == 0;
  }
};

}  // namespace pliant
