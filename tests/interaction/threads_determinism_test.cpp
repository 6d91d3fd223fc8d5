// Determinism across thread counts (DESIGN.md "Testing strategy"; STYLE.md 11; docs/threads.md):
// a scene stepped with "threads" 1, 2 and 3 must leave the same bits, step by step, in every
// body's positions and velocities, in the contacts found (depth, direction), in the step report's
// reaction forces and energies, and in the instruments' forces. The reference is the serial step
// (threads 1: no executor, the code every other test runs); the probe scene's threads-1 run is also
// byte-compared with main's tool_forces.csv outside this test (docs/threads.md).
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "interaction/scene/scene.h"
#include "interaction/scene/scene_runner.h"
#include "interaction/tbb_task_executor.h"
#include "sim/input_error.h"

namespace pliant {
namespace {

nlohmann::json scene_json(const std::string& relative) {
  std::ifstream in(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/" + relative);
  return nlohmann::json::parse(in);
}

/// FNV-1a over raw bytes: equal digests for equal bits (the comparison is of bits, not values).
struct Digest {
  std::uint64_t h = 1469598103934665603ull;
  void add(const void* data, size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
  void add(double x) { add(&x, sizeof x); }
  void add(const Vec3& v) { add(v.data(), 3 * sizeof(double)); }
};

/// The digest of everything a step leaves: state, contacts, report forces and energies, readings.
std::uint64_t step_digest(const SceneRunner& runner) {
  Digest d;
  for (const Body* b : runner.world().bodies()) {
    if (b == nullptr) continue;
    for (const Vec3& x : b->positions) d.add(x);
    for (const Vec3& v : b->velocities) d.add(v);
  }
  for (const VertexContact& c : runner.world().contacts()) {
    d.add(c.penetration_depth);
    d.add(c.penetration_direction);
  }
  const StepReport& r = runner.report();
  for (const auto& reaction : r.reactions) {
    d.add(reaction.force);
    d.add(reaction.torque);
  }
  for (const auto& pair : r.pair_forces) {
    d.add(pair.force_on_a);
    d.add(pair.elastic_on_a);
    d.add(pair.elastic_on_b);
  }
  d.add(r.energy.kinetic);
  d.add(r.energy.elastic);
  d.add(r.energy.gravitational);
  d.add(r.max_residual_overlap);
  d.add(static_cast<double>(r.solver_iterations_max));
  for (const auto& reading : runner.readings()) d.add(reading.force);
  return d.h;
}

struct SceneRun {
  std::vector<std::uint64_t> digests;
  int steps_with_contacts = 0;
};

SceneRun run_scene(nlohmann::json json, const std::string& name, int threads, int steps) {
  json["threads"] = threads;
  const Scene scene = parse_scene(json, name, std::string(PLIANT_SOURCE_DIR) + "/assets/scenes");
  SceneRunner runner(scene);
  EXPECT_EQ(runner.world().executor() != nullptr, threads > 1);
  SceneRun run;
  for (int i = 0; i < steps; ++i) {
    EXPECT_TRUE(runner.tick()) << runner.fault();
    run.digests.push_back(step_digest(runner));
    run.steps_with_contacts += runner.world().contacts().empty() ? 0 : 1;
  }
  return run;
}

void expect_same_bits(const SceneRun& serial, const SceneRun& parallel, int threads) {
  ASSERT_EQ(serial.digests.size(), parallel.digests.size());
  for (size_t i = 0; i < serial.digests.size(); ++i) {
    ASSERT_EQ(serial.digests[i], parallel.digests[i]) << threads << " threads: first difference at step " << i;
  }
}

// The probe scene (one 1,014-vertex tissue, the per-element loops run on threads): 420 steps of
// 1 ms, the probe touching the tissue from about 0.21 s.
TEST(ThreadsDeterminism, ProbeSceneIsBitIdenticalForOneTwoAndThreeThreads) {
  const nlohmann::json json = scene_json("probe.json");
  const SceneRun serial = run_scene(json, "probe.json", 1, 420);
  EXPECT_GT(serial.steps_with_contacts, 100);  // the comparison covers steps with contact
  for (int threads : {2, 3}) expect_same_bits(serial, run_scene(json, "probe.json", threads, 420), threads);
}

// Three cubes falling on a floor and on each other (several deformable bodies: they integrate side
// by side, and their energies are summed in slot order).
TEST(ThreadsDeterminism, ThreeCubesAreBitIdenticalForOneTwoAndThreeThreads) {
  const nlohmann::json json = scene_json("paper/three_cubes.json");
  const SceneRun serial = run_scene(json, "three_cubes.json", 1, 500);
  EXPECT_GT(serial.steps_with_contacts, 50);
  for (int threads : {2, 3}) {
    expect_same_bits(serial, run_scene(json, "three_cubes.json", threads, 500), threads);
  }
}

// The fruit dish's first steps: 138 bodies, one per chunk; the first fruits reach the floor at
// step 27, so detection's pass 2 runs in chunks of bodies on two threads in the later steps.
TEST(ThreadsDeterminism, FruitDishIsBitIdenticalForOneAndTwoThreads) {
  const nlohmann::json json = scene_json("paper/fruit_dish.json");
  const SceneRun serial = run_scene(json, "fruit_dish.json", 1, 40);
  EXPECT_GT(serial.steps_with_contacts, 5);
  expect_same_bits(serial, run_scene(json, "fruit_dish.json", 2, 40), 2);
}

// The executor runs every chunk exactly once, the chunks being fixed by count and size only.
TEST(ThreadsDeterminism, ExecutorRunsEachChunkOnce) {
  for (int threads : {1, 2, 3}) {
    TbbTaskExecutor executor(threads);
    std::vector<int> hits(1000, 0);
    std::vector<std::pair<size_t, size_t>> chunks(1000 / 64 + 1);
    auto body = [&](size_t begin, size_t end) {
      chunks[begin / 64] = {begin, end};
      for (size_t i = begin; i < end; ++i) hits[i]++;
    };
    executor.for_each_chunk(1000, 64, ChunkFunction(body));
    for (int h : hits) EXPECT_EQ(h, 1);
    for (size_t k = 0; k < chunks.size(); ++k) {
      EXPECT_EQ(chunks[k].first, k * 64);
      EXPECT_EQ(chunks[k].second, std::min<size_t>(1000, k * 64 + 64));
    }
  }
}

// "threads" must be a whole number >= 1; the error names the file and the JSON path.
TEST(ThreadsDeterminism, BadThreadsKeyNamesItsPath) {
  for (const nlohmann::json& bad : {nlohmann::json(0), nlohmann::json(-2), nlohmann::json(1.5), nlohmann::json("2")}) {
    nlohmann::json json = scene_json("probe_coarse.json");
    json["threads"] = bad;
    try {
      parse_scene(json, "probe_coarse.json", std::string(PLIANT_SOURCE_DIR) + "/assets/scenes");
      ADD_FAILURE() << "accepted threads = " << bad.dump();
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("probe_coarse.json"), std::string::npos) << what;
      EXPECT_NE(what.find("threads"), std::string::npos) << what;
    }
  }
}

}  // namespace
}  // namespace pliant
