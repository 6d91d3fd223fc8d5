// Faults inside a step (issue 9, item 4; docs/reliability.md): a NaN applied force on one vertex
// makes World::step report a non-finite fault and restore the state from before the step bit for
// bit; with the NaN removed the next step runs, and the run then matches a run that never saw the
// fault (the reference: the same world stepped without the injection). Both deformation models,
// with contact against a kinematic floor. A bad dt is refused without touching the state.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "sim/mesh/box_mesh.h"
#include "sim/world.h"
#include "support/fp_traps.h"

namespace pliant {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDt = 2e-3;  // s

struct Scenario {
  std::unique_ptr<World> world;
  BodyId tissue;
};

// A soft block dropping onto a kinematic floor slab it starts 1 mm above: contact within steps.
Scenario make_scenario(ModelKind model) {
  WorldSettings settings;
  settings.contact.method = ContactMethod::contact_surface;
  Scenario s;
  s.world = std::make_unique<World>(settings);
  BodyDef floor;
  floor.name = "floor";
  floor.mesh = make_box_mesh({Vec3(0.2, 0.2, 0.02), 2, 2, 1});
  floor.motion = BodyMotion::kinematic;
  floor.pose.translation = Vec3(0, 0, -0.01);
  s.world->add_body(floor);
  BodyDef block;
  block.name = "tissue";
  block.mesh = make_box_mesh({Vec3(0.04, 0.04, 0.02), 3, 3, 2});
  block.material.young_modulus = 2e4;
  block.material.mass_damping = 1.0;
  block.model = model;
  // Converged CG, so the warm start (reset after an undone step) does not change the result.
  block.model_settings.accuracy = {.max_solver_iterations = 400, .solver_tolerance = 1e-12};
  block.pose.translation = Vec3(0, 0, 0.011);
  block.initial_velocity = Vec3(0, 0, -0.5);
  s.tissue = s.world->add_body(block);
  return s;
}

std::vector<std::vector<Vec3>> positions_of(const World& world) {
  std::vector<std::vector<Vec3>> all;
  for (const Body* b : world.bodies()) all.push_back(b->positions);
  return all;
}
std::vector<std::vector<Vec3>> velocities_of(const World& world) {
  std::vector<std::vector<Vec3>> all;
  for (const Body* b : world.bodies()) all.push_back(b->velocities);
  return all;
}

// Bitwise equality (operator== on doubles would also pass for -0 vs 0; memcmp would not).
bool bit_identical(const std::vector<std::vector<Vec3>>& a, const std::vector<std::vector<Vec3>>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].size() != b[i].size()) return false;
    if (!a[i].empty() && std::memcmp(a[i].data(), b[i].data(), a[i].size() * sizeof(Vec3)) != 0) return false;
  }
  return true;
}

double max_difference(const std::vector<std::vector<Vec3>>& a, const std::vector<std::vector<Vec3>>& b) {
  double d = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    for (size_t v = 0; v < a[i].size(); ++v) d = std::max(d, (a[i][v] - b[i][v]).norm());
  }
  return d;
}

class FaultInjection : public ::testing::TestWithParam<ModelKind> {};

TEST_P(FaultInjection, NaNForceIsReportedRestoredAndSurvived) {
  Scenario faulty = make_scenario(GetParam());
  Scenario clean = make_scenario(GetParam());
  const int before = 15, after = 15;
  int contact_steps = 0;
  for (int i = 0; i < before; ++i) {
    ASSERT_EQ(faulty.world->step(kDt).fault, StepFault::none);
    ASSERT_EQ(clean.world->step(kDt).fault, StepFault::none);
    contact_steps += faulty.world->last_report().colliding_vertices > 0 ? 1 : 0;
  }
  ASSERT_GT(contact_steps, 0) << "the block should touch the floor before the fault";

  const auto positions = positions_of(*faulty.world);
  const auto velocities = velocities_of(*faulty.world);
  const double time = faulty.world->time();
  const long steps = faulty.world->step_count();
  Body& body = faulty.world->body(faulty.tissue);
  {
    testing::ScopedFpTrapsOff traps_off;  // the NaN is on purpose
    body.applied_forces[5] = Vec3(kNaN, 0.0, 0.0);
    const StepReport& r = faulty.world->step(kDt);
    EXPECT_EQ(r.fault, StepFault::non_finite) << r.fault_message;
    EXPECT_FALSE(r.all_finite);
    EXPECT_FALSE(r.fault_message.empty());
  }
  EXPECT_TRUE(bit_identical(positions_of(*faulty.world), positions)) << "positions not restored bit for bit";
  EXPECT_TRUE(bit_identical(velocities_of(*faulty.world), velocities)) << "velocities not restored bit for bit";
  EXPECT_EQ(faulty.world->time(), time);
  EXPECT_EQ(faulty.world->step_count(), steps);

  // Fault removed: the run goes on, finite, and follows the run that never saw it.
  body.applied_forces[5] = Vec3::Zero();
  for (int i = 0; i < after; ++i) {
    const StepReport& r = faulty.world->step(kDt);
    ASSERT_EQ(r.fault, StepFault::none) << "step " << i << " after the fault: " << r.fault_message;
    ASSERT_TRUE(r.all_finite);
    ASSERT_EQ(clean.world->step(kDt).fault, StepFault::none);
  }
  EXPECT_DOUBLE_EQ(faulty.world->time(), clean.world->time());
  // The CG warm start is reset after the undone step, so equality is to the (converged) solver
  // tolerance, far below the millimetres the block moved.
  EXPECT_LT(max_difference(positions_of(*faulty.world), positions_of(*clean.world)), 1e-9);
}

TEST_P(FaultInjection, NaNPositionOfAFreeVertexIsCaughtAtTheNextStep) {
  Scenario s = make_scenario(GetParam());
  for (int i = 0; i < 5; ++i) ASSERT_EQ(s.world->step(kDt).fault, StepFault::none);
  Body& body = s.world->body(s.tissue);
  const Vec3 good = body.positions[7];
  testing::ScopedFpTrapsOff traps_off;
  body.positions[7].x() = kNaN;  // state corrupted between steps by a caller
  const StepReport& r = s.world->step(kDt);
  EXPECT_NE(r.fault, StepFault::none);
  EXPECT_FALSE(r.all_finite);
  // The state before the step is what gets restored (here: the corrupted one); repairing it lets
  // the world go on.
  body.positions[7] = good;
  for (int i = 0; i < 5; ++i) EXPECT_EQ(s.world->step(kDt).fault, StepFault::none);
}

TEST_P(FaultInjection, BadTimeStepIsRefusedWithoutTouchingTheState) {
  Scenario s = make_scenario(GetParam());
  ASSERT_EQ(s.world->step(kDt).fault, StepFault::none);
  const auto positions = positions_of(*s.world);
  testing::ScopedFpTrapsOff traps_off;
  for (double dt : {0.0, -kDt, kNaN, std::numeric_limits<double>::infinity()}) {
    EXPECT_EQ(s.world->step(dt).fault, StepFault::diverged) << dt;
    EXPECT_TRUE(bit_identical(positions_of(*s.world), positions)) << dt;
  }
  EXPECT_EQ(s.world->step(kDt).fault, StepFault::none);
}

// Two deformable blocks in contact (the lower one on the floor): a NaN force on the upper one puts
// non-finite positions into detection before the report can see them. The spatial hash once sized
// its occupancy bitmap from such bounds (a negative cell count cast to size_t: std::bad_alloc out of
// World::step). Now the step stops before detection, reports the fault (saying it arose in the
// integration) and restores the state bit for bit, for a NaN and for an infinite force, and goes
// on once the force is removed.
TEST_P(FaultInjection, NonFiniteForceOnABodyTouchingAnotherDeformableBodyIsReportedAndRestored) {
  Scenario s = make_scenario(GetParam());
  BodyDef upper;
  upper.name = "upper";
  upper.mesh = make_box_mesh({Vec3(0.03, 0.03, 0.02), 3, 3, 2});
  upper.material.young_modulus = 2e4;
  upper.material.mass_damping = 1.0;
  upper.model = GetParam();
  upper.pose.translation = Vec3(0, 0, 0.0315);  // 0.5 mm above the lower block's top face
  upper.initial_velocity = Vec3(0, 0, -0.5);
  const BodyId upper_id = s.world->add_body(upper);
  int touching = 0;
  for (int i = 0; i < 20; ++i) {
    ASSERT_EQ(s.world->step(kDt).fault, StepFault::none);
    touching += s.world->last_report().colliding_vertices > 0 ? 1 : 0;
  }
  ASSERT_GT(touching, 0);
  Body& body = s.world->body(upper_id);
  for (double bad : {kNaN, std::numeric_limits<double>::infinity()}) {
    const auto positions = positions_of(*s.world);
    const auto velocities = velocities_of(*s.world);
    const long steps = s.world->step_count();
    {
      testing::ScopedFpTrapsOff traps_off;  // the non-finite force is on purpose
      for (int v = 0; v < body.vertex_count(); v += 3) body.applied_forces[static_cast<size_t>(v)] = Vec3(bad, 0.0, bad);
      const StepReport& r = s.world->step(kDt);
      EXPECT_EQ(r.fault, StepFault::non_finite) << bad;
      EXPECT_FALSE(r.all_finite) << bad;
      // Said where it arose: the integration (the contact stages did not run on it).
      EXPECT_NE(r.fault_message.find("integration"), std::string::npos) << r.fault_message;
    }
    EXPECT_TRUE(bit_identical(positions_of(*s.world), positions)) << bad;
    EXPECT_TRUE(bit_identical(velocities_of(*s.world), velocities)) << bad;
    EXPECT_EQ(s.world->step_count(), steps);
    std::fill(body.applied_forces.begin(), body.applied_forces.end(), Vec3::Zero());
    for (int i = 0; i < 5; ++i) ASSERT_EQ(s.world->step(kDt).fault, StepFault::none) << bad;
  }
}

INSTANTIATE_TEST_SUITE_P(Models, FaultInjection,
                         ::testing::Values(ModelKind::corotational_fem, ModelKind::teschner_explicit),
                         [](const auto& info) {
                           return info.param == ModelKind::corotational_fem ? std::string("CorotationalFem")
                                                                            : std::string("TeschnerExplicit");
                         });

}  // namespace
}  // namespace pliant
