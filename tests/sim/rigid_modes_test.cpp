// Stage 5's rigid modes of a free body (sim/contact/contact_velocity_update.h): RigidModes::prepare
// against the code before session 15, which summed the inertia as Eigen's
// `inertia += m (|r|^2 I - r r^T)` over all nine entries and scanned every body for fixed vertices.
// The mass, centre and inverse inertia must be those bits exactly (the take-back's velocities and
// every later step depend on them).
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include <Eigen/Dense>

#include "sim/contact/contact_velocity_update.h"

namespace pliant {
namespace {

// The pre-session-15 body of RigidModes::prepare, verbatim.
RigidModes reference_prepare(const Body& body) {
  RigidModes r;
  r.ready = true;
  r.free = !body.is_kinematic() && !body.is_sleeping();
  for (char f : body.fixed) r.free = r.free && f == 0;
  if (!r.free) return r;
  for (size_t i = 0; i < body.positions.size(); ++i) {
    r.mass += body.masses[i];
    r.centre += body.masses[i] * body.positions[i];
  }
  r.centre /= r.mass;
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < body.positions.size(); ++i) {
    const Vec3 d = body.positions[i] - r.centre;
    inertia += body.masses[i] * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  }
  r.inverse_inertia = inertia.completeOrthogonalDecomposition().pseudoInverse();
  return r;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

TEST(RigidModesPrepare, IsEigensInertiaExpressionBitForBit) {
  std::mt19937 rng(15);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), mass(1e-6, 2.0);
  std::uniform_int_distribution<int> count(1, 120), kind(0, 5);
  int free_bodies = 0, rank_deficient = 0, exact_zero_offsets = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    Body body;
    const int k = kind(rng);
    const int n = k == 5 ? 27 : count(rng);
    for (int i = 0; i < n; ++i) {
      Vec3 x(unit(rng), unit(rng), unit(rng));
      if (k == 1) x = x.x() * Vec3(0.3, -0.2, 0.9);          // on a line: a singular inertia
      if (k == 2) x = Vec3(0.01 + 1e-9 * x.x(), 5.0, -3.0);  // a tiny, far-off cluster
      if (k == 5) x = Vec3(i % 3 - 1.0, (i / 3) % 3 - 1.0, i / 9 - 1.0);  // centred grid: exact zeros
      body.positions.push_back(x * (k == 3 ? 1e3 : 1.0));
      body.masses.push_back(k == 5 ? 0.25 : mass(rng));
      body.fixed.push_back(0);
    }
    if (k == 4 && trial % 3 == 0) body.fixed[static_cast<size_t>(n - 1)] = 1;  // anchored: not free
    if (k == 4 && trial % 3 == 1) body.motion = BodyMotion::kinematic;
    if (k == 4 && trial % 3 == 2) body.sleep.sleeping = true;

    RigidModes got;
    got.prepare(body);
    const RigidModes want = reference_prepare(body);
    ASSERT_TRUE(got.ready);
    ASSERT_EQ(got.free, want.free) << "trial " << trial;
    if (!want.free) continue;
    ++free_bodies;
    if (k == 1) ++rank_deficient;
    if (k == 5) ++exact_zero_offsets;
    ASSERT_TRUE(same_bits(got.mass, want.mass)) << "trial " << trial;
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(same_bits(got.centre[i], want.centre[i])) << "trial " << trial;
    for (int i = 0; i < 9; ++i) {
      ASSERT_TRUE(same_bits(got.inverse_inertia.data()[i], want.inverse_inertia.data()[i]))
          << "trial " << trial << " entry " << i << ": " << got.inverse_inertia.data()[i] << " vs "
          << want.inverse_inertia.data()[i];
    }
  }
  // Every kind of case occurred.
  EXPECT_GT(free_bodies, 2000);
  EXPECT_GT(rank_deficient, 300);
  EXPECT_GT(exact_zero_offsets, 300);
}

}  // namespace
}  // namespace pliant
