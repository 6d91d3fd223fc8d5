// The corotational model's local force queries (sim/model/corotational_local_query.cpp) against
// references: the tet-wise exact query against the whole-body internal forces at the same positions
// (a second method: every tet, scattered; a fresh model and the same model, to round-off),
// and against itself asked one vertex at a time (each tet
// is evaluated once per query, and a vertex's sum must not depend on what else is asked); the frozen
// query with lazily extracted rotations against the same query after the model's full pass at the
// state advance left (bitwise: the same rotations), over several steps (no stale cache entry).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "sim/mesh/box_mesh.h"
#include "sim/model/corotational_fem.h"
#include "support/vec_compare.h"

namespace pliant {
namespace {

Material material(double E, double nu) {
  Material m;
  m.young_modulus = E;
  m.poisson_ratio = nu;
  m.density = 1000.0;
  m.mass_damping = 0.0;
  m.stiffness_damping = 0.01;
  return m;
}

// A cantilever of 20 x 2 x 2 cells sagging under gravity: strained and rotated elements.
struct SaggingBeam {
  TetMeshPtr mesh = make_box_mesh({Vec3(0.5, 0.05, 0.05), 20, 2, 2});
  Material m = material(1e5, 0.45);
  size_t n = static_cast<size_t>(mesh->vertex_count());
  std::vector<double> masses = mesh->lumped_masses(m.density);
  std::vector<char> fixed = std::vector<char>(n, 0);
  std::vector<Vec3> ext = std::vector<Vec3>(n);
  std::vector<Vec3> x = mesh->rest_positions(), v = std::vector<Vec3>(n, Vec3::Zero());
  SaggingBeam() {
    for (size_t i = 0; i < n; ++i) {
      fixed[i] = x[i].x() < -0.25 + 1e-12 ? 1 : 0;
      ext[i] = masses[i] * Vec3(0, 0, -9.81);
    }
  }
  void step(DeformationModel& model, std::vector<Vec3>& xs, std::vector<Vec3>& vs) {
    model.advance(xs, vs, {masses, fixed, ext, 1e-2});
  }
  /// Surface vertices of the top face near the tip (a contact patch: neighbours share tets).
  std::vector<int> patch() const {
    std::vector<int> out;
    for (int i : mesh->surface_vertices()) {
      const Vec3& p = mesh->rest_positions()[static_cast<size_t>(i)];
      if (p.x() > 0.15 && p.z() > 0.025 - 1e-9) out.push_back(i);
    }
    return out;
  }
};

bool bitwise_equal(std::span<const Vec3> a, std::span<const Vec3> b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].x() != b[i].x() || a[i].y() != b[i].y() || a[i].z() != b[i].z()) return false;
  }
  return true;
}

TEST(CorotationalLocalQuery, TetWiseExactQueryEqualsTheWholeBodyForcesAtContactEditedPositions) {
  SaggingBeam beam;
  CorotationalFem model(beam.mesh, beam.m, {});
  for (int s = 0; s < 8; ++s) beam.step(model, beam.x, beam.v);
  const std::vector<int> patch = beam.patch();
  ASSERT_GE(patch.size(), 12u);
  std::vector<Vec3> x = beam.x;
  for (size_t k = 0; k < patch.size(); ++k) {  // a contact edit: the patch pushed down, unevenly
    x[static_cast<size_t>(patch[k])] += Vec3(1e-4 * static_cast<double>(k % 3), 0.0, -2e-3 - 1e-4 * static_cast<double>(k));
  }
  std::vector<Vec3> local(patch.size());
  model.internal_forces_at(x, patch, local);
  // One vertex at a time (no tet shared within a query): the same sums, bit for bit (asked
  // before any whole-body pass: the queries warm-start from the rotations advance left).
  std::vector<Vec3> single(1), one_by_one(patch.size());
  for (size_t k = 0; k < patch.size(); ++k) {
    model.internal_forces_at(x, std::span<const int>(&patch[k], 1), single);
    one_by_one[k] = single[0];
  }
  EXPECT_TRUE(bitwise_equal(local, one_by_one));
  // Whole body, by a fresh model (every tet once, scattered in tet order).
  CorotationalFem fresh(beam.mesh, beam.m, {});
  std::vector<Vec3> whole(beam.n);
  fresh.internal_forces(x, whole);
  std::vector<Vec3> reference(patch.size());
  for (size_t k = 0; k < patch.size(); ++k) reference[k] = whole[static_cast<size_t>(patch[k])];
  ASSERT_GT(max_norm(reference), 0.0);
  EXPECT_LT(max_difference(local, reference), 1e-10 * max_norm(reference));
  // The same model's whole-body pass at x (its warm starts are the query's: the rotations advance
  // left): the same tet forces, -V P g_j against -V P Dm^-T's columns: round-off.
  model.internal_forces(x, whole);
  for (size_t k = 0; k < patch.size(); ++k) reference[k] = whole[static_cast<size_t>(patch[k])];
  EXPECT_LT(max_difference(local, reference), 1e-13 * max_norm(reference));
}

TEST(CorotationalLocalQuery, FrozenQueryWithLazyRotationsIsTheQueryAfterTheFullPass) {
  SaggingBeam beam;
  // Two models stepped alike: `lazy` answers the frozen query from the state advance deferred,
  // `full` after a full pass at that state (what the query did before: the whole body's rotations).
  CorotationalFem lazy(beam.mesh, beam.m, {}), full(beam.mesh, beam.m, {});
  std::vector<Vec3> x_full = beam.x, v_full = beam.v;
  const std::vector<int> patch = beam.patch();
  std::vector<Vec3> f_lazy(patch.size()), f_full(patch.size()), forces(beam.n);
  // A tet in the middle of the beam (far from the patch, x > 0.15 m), rotating as the beam sags.
  int far_tet = 0;
  double nearest = 1.0;
  for (int t = 0; t < beam.mesh->tet_count(); ++t) {
    double cx = 0.0;
    for (int i : beam.mesh->tets()[static_cast<size_t>(t)]) cx += 0.25 * beam.x[static_cast<size_t>(i)].x();
    if (std::abs(cx + 0.05) < nearest) {
      nearest = std::abs(cx + 0.05);
      far_tet = t;
    }
  }
  for (int s = 0; s < 6; ++s) {
    beam.step(lazy, beam.x, beam.v);
    beam.step(full, x_full, v_full);
    ASSERT_TRUE(bitwise_equal(beam.x, x_full)) << s;
    const Mat3 far_before = lazy.element_rotation(far_tet);
    full.internal_forces(x_full, forces);  // the full pass at x_{n+1}
    for (int k = 0; k < 3; ++k) {  // three searched positions in a step
      std::vector<Vec3> x = beam.x;
      for (int i : patch) x[static_cast<size_t>(i)] += Vec3(0.0, 0.0, -1e-4 * (k + 1));
      lazy.internal_forces_at_frozen_rotations(x, patch, f_lazy);
      full.internal_forces_at_frozen_rotations(x, patch, f_full);
      EXPECT_TRUE(bitwise_equal(f_lazy, f_full)) << "step " << s << " query " << k;
    }
    // The lazy model did not evaluate the far tet: its stored rotation is still x_n's.
    EXPECT_EQ(lazy.element_rotation(far_tet), far_before) << s;
    EXPECT_NE(full.element_rotation(far_tet), far_before) << s;  // (it did rotate: the check can fail)
    // The next step starts both from the same positions: the lazy model's first user (here the
    // whole-body query) makes the full pass.
    lazy.internal_forces(beam.x, forces);
  }
}

// The nearby-rotation query (session 5) against the exact query at the same positions: after an
// exact query at a contact edit (which remembers each tet's rotation), positions moved by a small
// extra push reuse those rotations where |dF| <= tolerance; the stress R S(sym(R^T F)) then differs
// from the exact one by the rotation error (about |dF| / 2) times the stress, plus second order:
// bound tolerance x the largest force (the first-order term with a factor 2 of margin). A large
// push re-extracts every rotation: the exact query bit for bit; tolerance 0 is the exact query.
TEST(CorotationalLocalQuery, NearbyRotationQueryIsTheExactQueryWithinTheTolerancesBound) {
  SaggingBeam beam;
  CorotationalFem model(beam.mesh, beam.m, {});
  for (int s = 0; s < 8; ++s) beam.step(model, beam.x, beam.v);
  const std::vector<int> patch = beam.patch();
  auto pushed = [&](double dz) {
    std::vector<Vec3> x = beam.x;
    for (size_t k = 0; k < patch.size(); ++k) {
      x[static_cast<size_t>(patch[k])] += Vec3(1e-4 * static_cast<double>(k % 3), 0.0, dz - 1e-4 * static_cast<double>(k));
    }
    return x;
  };
  const double tolerance = 1e-3;
  std::vector<Vec3> exact(patch.size()), nearby(patch.size());
  const std::vector<Vec3> x0 = pushed(-2e-3);
  model.internal_forces_at(x0, patch, exact);  // remembers the rotations at x0
  // 2 um more on 25 mm cells: |dF| ~ 1e-4 < tolerance: every rotation reused.
  const std::vector<Vec3> x1 = pushed(-2.002e-3);
  model.internal_forces_at_nearby_rotations(x1, patch, nearby, tolerance);
  model.internal_forces_at(x1, patch, exact);
  ASSERT_GT(max_norm(exact), 0.0);
  const double error = max_difference(nearby, exact);
  std::printf("nearby query: error %.3g of the largest force\n", error / max_norm(exact));
  EXPECT_GT(error, 0.0) << "no rotation was reused";
  EXPECT_LT(error, tolerance * max_norm(exact));
  // 5 mm more (|dF| ~ 0.2): every touched tet re-extracted from the stored warm start: exact.
  const std::vector<Vec3> x2 = pushed(-7e-3);
  model.internal_forces_at_nearby_rotations(x2, patch, nearby, tolerance);
  model.internal_forces_at(x2, patch, exact);
  EXPECT_TRUE(bitwise_equal(nearby, exact));
  // Tolerance 0: the exact query.
  model.internal_forces_at_nearby_rotations(x1, patch, nearby, 0.0);
  model.internal_forces_at(x1, patch, exact);
  EXPECT_TRUE(bitwise_equal(nearby, exact));
}

// Session 6: K' d from the last advance's assembled blocks at a few rows (the linearised contact
// search), against two references. (1) The whole-body product of the same step's stiffness
// (apply_stiffness after advance: matrix-free, element by element from the rotations of x_n), which
// with K' reuse off is the same matrix: round-off; with the default reuse the blocks' rotations lag
// by at most 1e-3 rad, so each block is off by at most ~2e-3 of its size. (2) The exact forces by
// finite differences: f(x1 + d) - f(x1) = -K' d to first order, up to the rotation change between
// x_n and x1 (the contact edit's) times the stress.
TEST(CorotationalLocalQuery, StiffnessProductIsTheStepsStiffnessAtTheAskedRows) {
  SaggingBeam beam;
  const std::vector<int> patch = beam.patch();
  std::vector<Vec3> d(patch.size()), y(patch.size()), full_d(beam.n, Vec3::Zero()), full_y(beam.n);
  for (size_t k = 0; k < patch.size(); ++k) {
    d[k] = Vec3(2e-6 * static_cast<double>(k % 3), -1e-6, -1e-5 - 1e-6 * static_cast<double>(k));
    full_d[static_cast<size_t>(patch[k])] = d[k];
  }
  for (const double tolerance : {0.0, kDefaultStiffnessRotationTolerance}) {
    CorotationalFem model(beam.mesh, beam.m, {});
    model.set_stiffness_rotation_tolerance(tolerance);
    std::vector<Vec3> x = beam.x, v = beam.v;
    EXPECT_FALSE(model.stiffness_product_at(patch, d, patch, y, 1.0)) << "no step yet: no K'";
    for (int s = 0; s < 8; ++s) beam.step(model, x, v);
    ASSERT_TRUE(model.stiffness_product_at(patch, d, patch, y, 1.0));
    // The moves change F by ~1e-3 (26 um on 25 mm cells): refused below that.
    EXPECT_FALSE(model.stiffness_product_at(patch, d, patch, y, 1e-4));
    ASSERT_TRUE(model.stiffness_product_at(patch, d, patch, y, 1e-2));
    model.apply_stiffness(full_d, full_y);
    std::vector<Vec3> reference(patch.size());
    for (size_t k = 0; k < patch.size(); ++k) reference[k] = full_y[static_cast<size_t>(patch[k])];
    ASSERT_GT(max_norm(reference), 0.0);
    const double error = max_difference(y, reference) / max_norm(reference);
    std::printf("K' product at tolerance %g: %.3g of the largest entry\n", tolerance, error);
    EXPECT_LT(error, tolerance > 0.0 ? 4.0 * tolerance : 1e-12) << tolerance;
    // Asked twice, and for fewer rows: the same numbers (the scratch is cleared after each use).
    std::vector<Vec3> again(patch.size());
    ASSERT_TRUE(model.stiffness_product_at(patch, d, std::span<const int>(patch.data(), 3), again, 1.0));
    for (size_t k = 0; k < 3; ++k) EXPECT_EQ(again[k], y[k]) << k;
    // After a full pass the blocks no longer belong to the state: no product.
    std::vector<Vec3> forces(beam.n);
    model.internal_forces(x, forces);
    EXPECT_FALSE(model.stiffness_product_at(patch, d, patch, y, 1.0));
  }
}

TEST(CorotationalLocalQuery, StiffnessProductIsTheExactForceChangeToFirstOrder) {
  SaggingBeam beam;
  CorotationalFem model(beam.mesh, beam.m, {});
  for (int s = 0; s < 8; ++s) beam.step(model, beam.x, beam.v);
  const std::vector<int> patch = beam.patch();
  // x1: the patch dented 0.4 mm (h / 60 on 25 mm cells, the size of a first search step); then
  // moved by up to 0.1 mm more (the later search steps).
  std::vector<Vec3> x1 = beam.x, d(patch.size());
  for (size_t k = 0; k < patch.size(); ++k) {
    x1[static_cast<size_t>(patch[k])] += Vec3(0.0, 0.0, -4e-4 - 1e-5 * static_cast<double>(k % 4));
    d[k] = Vec3(1e-5 * static_cast<double>(k % 3), 0.0, -1e-4 + 1e-5 * static_cast<double>(k % 5));
  }
  std::vector<Vec3> x2 = x1;
  for (size_t k = 0; k < patch.size(); ++k) x2[static_cast<size_t>(patch[k])] += d[k];
  std::vector<Vec3> f1(patch.size()), f2(patch.size()), product(patch.size()), change(patch.size()),
      predicted(patch.size());
  ASSERT_TRUE(model.stiffness_product_at(patch, d, patch, product, 1.0));
  model.internal_forces_at(x1, patch, f1);
  model.internal_forces_at(x2, patch, f2);
  for (size_t k = 0; k < patch.size(); ++k) {
    change[k] = f2[k] - f1[k];
    predicted[k] = -product[k];
  }
  ASSERT_GT(max_norm(change), 0.0);
  const double error = max_difference(predicted, change) / max_norm(change);
  std::printf("f(x1 + d) - f(x1) against -K' d: %.3g of the largest change\n", error);
  // The frozen law's error is about the rotation between the rotations K' was built from (x_n's)
  // and x1's: the dent's, 0.4 mm over 25 mm cells ~ 0.016 rad (measured 0.0064).
  EXPECT_LT(error, 0.016);
}

}  // namespace
}  // namespace pliant
