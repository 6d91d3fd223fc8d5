// Faults inside a step, seen from the interaction layer (issue 9, item 4; docs/reliability.md):
// SceneRunner retries a faulty step as two half steps and, when the fault persists, stops with a
// message and the world's last good state (bit-identical to before the tick); a transient fault
// that is gone by the retry is survived. The haptic output filter turns NaN or infinite input
// into zero force at once (never NaN) and then ramps back up at the rate limit (never a spike).
#include <gtest/gtest.h>

#include <cstring>
#include <limits>

#include "interaction/haptic_output_filter.h"
#include "interaction/scene/scene_runner.h"
#include "support/fp_traps.h"

namespace pliant {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// A small block with its base fixed and a probe pressing into it from above.
Scene probe_scene() {
  const nlohmann::json root = nlohmann::json::parse(R"({
    "name": "fault",
    "time_step": 0.002,
    "gravity": [0, 0, -9.81],
    "contact": {"method": "surface", "finishing_projection": true},
    "bodies": [{"name": "tissue",
                "mesh": {"shape": "box", "size": [0.06, 0.06, 0.02], "cells": [4, 4, 2]},
                "material": {"young_modulus": 5000, "mass_damping": 2},
                "fixed": [{"plane": {"point": [0, 0, -0.01], "normal": [0, 0, 1]}}]}],
    "instruments": [{"name": "probe", "type": "probe", "position": [0, 0, 0.021], "tip_radius": 0.008,
                     "shaft_radius": 0.003, "shaft_length": 0.04, "resolution": 3}],
    "script": [{"t": 0.1, "instrument": "probe", "op": "press", "axis": [0, 0, -1], "depth": 0.006}]
  })");
  return parse_scene(root, "fault.json", ".");
}

std::vector<Vec3> tissue_positions(SceneRunner& runner) {
  return runner.world().body(runner.instance().bodies[0]).positions;
}

// A vertex on the top face (largest z), free to move.
size_t free_top_vertex(const Body& body) {
  size_t best = 0;
  for (size_t i = 0; i < body.positions.size(); ++i) {
    if (body.fixed[i] == 0 && body.positions[i].z() > body.positions[best].z()) best = i;
  }
  return best;
}

bool bit_identical(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

TEST(SceneRunnerFault, PersistentNaNStopsCleanlyWithTheLastGoodState) {
  SceneRunner runner(probe_scene());
  for (int i = 0; i < 30; ++i) ASSERT_TRUE(runner.tick()) << runner.fault();
  ASSERT_GT(runner.report().colliding_vertices, 0) << "the probe should be in contact";
  const auto before = tissue_positions(runner);
  const double time = runner.time();
  Body& tissue = runner.world().body(runner.instance().bodies[0]);
  const size_t free_vertex = free_top_vertex(tissue);
  ASSERT_EQ(tissue.fixed[free_vertex], 0);

  testing::ScopedFpTrapsOff traps_off;  // the NaN is on purpose
  tissue.applied_forces[free_vertex] = Vec3(0.0, kNaN, 0.0);
  EXPECT_FALSE(runner.tick());
  EXPECT_EQ(runner.retried_steps(), 1);
  EXPECT_NE(runner.fault().find("failed"), std::string::npos) << runner.fault();
  EXPECT_NE(runner.fault().find("half dt"), std::string::npos) << runner.fault();
  EXPECT_TRUE(bit_identical(tissue_positions(runner), before));
  EXPECT_EQ(runner.time(), time);
  for (const Vec3& p : tissue_positions(runner)) ASSERT_TRUE(p.allFinite());
}

// A fault present only in the first attempt: the half-step retry succeeds, the run goes on.
class OneShotNaNProfiler final : public StepProfiler {
 public:
  explicit OneShotNaNProfiler(Body& body) : body_(body), vertex_(free_top_vertex(body)) {}
  void begin(StepStage stage) override {
    if (stage == StepStage::integrate && armed_) {
      body_.applied_forces[vertex_] = Vec3(kNaN, 0.0, 0.0);
      armed_ = false;
      injected_ = true;
    } else if (stage == StepStage::integrate && injected_) {
      body_.applied_forces[vertex_] = Vec3::Zero();  // gone by the retry
    }
  }
  void end(StepStage) override {}
  void arm() { armed_ = true; }

 private:
  Body& body_;
  size_t vertex_;
  bool armed_ = false;
  bool injected_ = false;
};

TEST(SceneRunnerFault, TransientNaNIsRetriedAtHalfDtAndSurvived) {
  SceneRunner runner(probe_scene());
  Body& tissue = runner.world().body(runner.instance().bodies[0]);
  OneShotNaNProfiler injector(tissue);
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(runner.tick(&injector));
  const double time = runner.time();
  {
    testing::ScopedFpTrapsOff traps_off;
    injector.arm();
    EXPECT_TRUE(runner.tick(&injector)) << runner.fault();
  }
  EXPECT_EQ(runner.retried_steps(), 1);
  EXPECT_TRUE(runner.fault().empty());
  EXPECT_DOUBLE_EQ(runner.time(), time + runner.scene().time_step);  // two half steps
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(runner.tick(&injector)) << runner.fault();
  for (const Vec3& p : tissue_positions(runner)) ASSERT_TRUE(p.allFinite());
  EXPECT_TRUE(runner.readings()[0].force.allFinite());
}

TEST(HapticOutputFilterFault, NonFiniteInputGivesZeroThenRampsBackAtTheRateLimit) {
  HapticLimits limits;
  limits.max_force = 4.0;
  limits.max_delta = 0.05;
  HapticOutputFilter filter(limits);
  const Vec3 steady(0.0, 0.0, 2.0);
  for (int i = 0; i < 100; ++i) filter.filter(steady);
  ASSERT_TRUE(filter.last().isApprox(steady));

  testing::ScopedFpTrapsOff traps_off;
  long faults = 0;
  for (const Vec3& bad : {Vec3(kNaN, 0, 0), Vec3(0, kInf, 0), Vec3(0, 0, -kInf), Vec3(kNaN, kNaN, kNaN)}) {
    for (int i = 0; i < 10; ++i) filter.filter(steady);  // back to some force first
    const Vec3 out = filter.filter(bad);
    ++faults;
    EXPECT_TRUE(filter.fault());
    EXPECT_EQ(filter.fault_count(), faults);
    EXPECT_TRUE(out.allFinite());
    EXPECT_EQ(out, Vec3::Zero());
  }
  // After the fault: never a jump larger than max_delta back to the steady force.
  Vec3 previous = filter.last();
  for (int i = 0; i < 100; ++i) {
    const Vec3 out = filter.filter(steady);
    EXPECT_FALSE(filter.fault());
    EXPECT_LE((out - previous).norm(), limits.max_delta * (1.0 + 1e-12));
    previous = out;
  }
  EXPECT_TRUE(previous.isApprox(steady));
  // A finite but absurd input (its norm overflows) is neither NaN nor above the clamp.
  const Vec3 huge(1e308, 1e308, 0.0);
  const Vec3 out = filter.filter(huge);
  EXPECT_TRUE(out.allFinite());
  EXPECT_LE(out.norm(), limits.max_force);
  EXPECT_LE((out - previous).norm(), limits.max_delta * (1.0 + 1e-12));
}

}  // namespace
}  // namespace pliant
