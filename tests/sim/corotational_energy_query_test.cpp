// The elastic energy query is read-only (session 6): before, elastic_energy(x) re-linearised the
// model's cached state at x, so a query between or inside steps changed the warm starts, the
// cached forces and the next step. References: (1) a twin model that is never queried, advanced
// through the same steps: the queried model's positions and velocities must equal the twin's bit
// for bit after every step; (2) each value must equal what the old query returned from the same
// state (a copy of the model re-linearised at the query's positions: internal_forces(x), then the
// cached energy), bit for bit. All three paths of the query are exercised: the state's own
// positions, a few vertices moved (the tets around them re-evaluated), and a full pass (positions
// far from the state, or the state deferred by advance: kept aside, adopted by the next step).
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "sim/model/corotational_fem.h"
#include "support/clamped_beam.h"

namespace pliant {
namespace {

bool same_bits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

/// Swings sideways and sags (rotations change every step, so warm starts matter).
struct SwingingBeam : ClampedBeam {
  SwingingBeam() : ClampedBeam(12, [](const Vec3&, double m) { return Vec3(m * Vec3(0.0, 4.0, -9.81)); }) {}
};

/// The value the old query returned from `model`'s state: re-linearise a copy at x, read its cache.
double old_query(const CorotationalFem& model, const std::vector<Vec3>& x) {
  CorotationalFem copy = model;
  std::vector<Vec3> f(x.size());
  copy.internal_forces(x, f);
  return copy.elastic_energy(x);  // at the state's own positions: the cached energy
}

TEST(CorotationalEnergyQuery, QueriesBetweenAndInsideStepsLeaveTheRunBitForBit) {
  SwingingBeam queried, twin;
  CorotationalFem a(queried.mesh, queried.material, ModelSettings{});
  CorotationalFem b(twin.mesh, twin.material, ModelSettings{});
  int checked = 0;
  auto check = [&](const std::vector<Vec3>& at) {
    const double reference = old_query(a, at);
    const double energy = a.elastic_energy(at);
    EXPECT_TRUE(same_bits(energy, reference)) << energy << " vs " << reference << " check " << checked;
    EXPECT_GT(energy, 0.0);
    ++checked;
  };
  for (int step = 0; step < 12; ++step) {
    a.advance(queried.x, queried.v, queried.input());
    b.advance(twin.x, twin.v, twin.input());
    ASSERT_TRUE(same_bits(queried.x, twin.x)) << "step " << step;
    ASSERT_TRUE(same_bits(queried.v, twin.v)) << "step " << step;
    // Positions a contact stage might make (a few vertices pushed) and positions far away.
    std::vector<Vec3> few = queried.x;
    for (size_t i = 0; i < few.size(); i += 37) few[i] += Vec3(1e-4, -2e-4, 3e-4);
    std::vector<Vec3> many = queried.x;
    for (auto& p : many) p += Vec3(0.0, 1e-3, 0.0) * p.x();
    if (step % 3 == 1) {
      // A force query evaluated the state at x: the few-vertex path, then the cached one.
      std::vector<Vec3> f(queried.x.size());
      a.internal_forces(queried.x, f);
      check(few);
      check(queried.x);
    } else {
      // The state is deferred: full passes far away, then at the step's end (kept aside for the
      // next advance), then the same again (the kept pass answers).
      check(many);
      check(queried.x);
      check(queried.x);
    }
  }
  EXPECT_EQ(checked, 4 * 2 + 8 * 3);
}

}  // namespace
}  // namespace pliant
