// The haptic thread beside a scene's physics (SceneHaptics, `pliant run --realtime`):
//   - the device track extrapolates the physics positions linearly, at most one interval ahead;
//   - on a VirtualClock (ticks called by hand, deterministic), the force sent at a refresh is the
//     physics force F0 exactly, and between refreshes it is the local linear model
//     F0 - K (x - x0) at the extrapolated position (predict_force on a snapshot, computed here
//     independently); the torque column holds the last physics torque;
//   - `pliant run --realtime` on the probe scene writes haptic_forces.csv (finite, within the
//     10 N clamp, in contact for part of the run) and the tick statistics in summary.json; a
//     non-realtime run writes neither (no timings are asserted);
//   - the scene's "haptics" object: parsed limits (max_force_rate / rate_hz per tick), errors
//     with their JSON path, and `pliant run --realtime` sending at most the scene's maximum,
//     changing by at most its rate per tick, or no haptic thread when "enabled" is false.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "interaction/clock.h"
#include "interaction/scene/scene.h"
#include "sim/input_error.h"
#include "interaction/scene/scene_haptics.h"
#include "support/run_cli.h"

namespace pliant {
namespace {

TEST(DeviceTrack, ExtrapolatesLinearlyAtMostOneIntervalAhead) {
  DeviceTrack track;
  EXPECT_EQ(track.position_at(5.0), Vec3::Zero());
  track.push(1.0, Vec3(1, 2, 3), Vec3(0, 0, 7));
  EXPECT_EQ(track.position_at(2.0), Vec3(1, 2, 3));  // one push: hold
  track.push(3.0, Vec3(3, 2, 1), Vec3(0, 0, 8));
  EXPECT_EQ(track.position_at(3.0), Vec3(3, 2, 1));
  EXPECT_EQ(track.position_at(2.5), Vec3(3, 2, 1));  // before the last push: no going back
  EXPECT_TRUE(track.position_at(4.0).isApprox(Vec3(4, 2, 0), 1e-15));  // half an interval ahead
  EXPECT_TRUE(track.position_at(9.0).isApprox(Vec3(5, 2, -1), 1e-15));  // capped at one interval
  EXPECT_EQ(track.torque(), Vec3(0, 0, 8));
}

TEST(SceneHaptics, SendsThePhysicsForceAtARefreshAndTheLinearModelBetween) {
  Scene scene = load_scene(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/probe_coarse.json");
  SceneRunner runner(scene);
  VirtualClock clock;
  HapticSettings settings;
  settings.limits.max_force = 100.0;
  settings.limits.max_delta = 100.0;  // no limiting: what is sent is the model
  SceneHaptics haptics(clock, runner, settings, 1.0, false);
  const double physics_wall = 3e-3;  // s of clock per physics step (slower than the haptic rate)
  Vec3 previous = runner.readings()[0].position;
  int checked = 0;
  for (int step = 0; step < 320; ++step) {
    previous = runner.readings()[0].position;
    ASSERT_TRUE(runner.tick()) << runner.fault();
    const double t_refresh = (step + 1) * physics_wall;
    clock.sleep_until(t_refresh);
    haptics.refresh(runner, t_refresh);
    const InstrumentReading reading = runner.readings()[0];
    const LinearContactModel model = haptics.model(0).snapshot();
    for (int k = 0; k < 3; ++k) {
      const double t = t_refresh + k * 1e-3;
      clock.sleep_until(t);
      haptics.tick(t);
      const HapticRecord r = haptics.records().back();
      EXPECT_EQ(r.time, t);
      EXPECT_EQ(r.torque, reading.torque);
      const Vec3 x = reading.position + (k * 1e-3 / physics_wall) * (reading.position - previous);
      const Vec3 expected = predict_force(model, x);
      EXPECT_TRUE((r.force - expected).norm() <= 1e-12 * (1.0 + expected.norm())) << "step " << step << " k " << k;
      if (k == 0) {
        EXPECT_EQ(r.force, reading.force) << "step " << step;
      }
      if (reading.force.norm() > 0.0 && k > 0) ++checked;
    }
  }
  EXPECT_GT(checked, 100);  // the probe was in contact for many of those steps
  EXPECT_EQ(haptics.records().size(), 320u * 3u);
  EXPECT_EQ(haptics.stats().faults, 0);
}

// Reads a CSV with a header into rows of fields.
std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& path, std::string* header) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  std::getline(in, *header);
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::stringstream s(line);
    std::string f;
    while (std::getline(s, f, ',')) fields.push_back(f);
    rows.push_back(fields);
  }
  return rows;
}

TEST(RealtimeRun, WritesHapticForcesAndTickStatistics) {
  const auto out = std::filesystem::temp_directory_path() / "pliant_realtime_haptics_test";
  std::filesystem::remove_all(out);
  const auto result = testing::run_cli(std::string("run ") + PLIANT_SOURCE_DIR +
                                       "/assets/scenes/probe_coarse.json --realtime --no-rt-priority --steps 300 "
                                       "--no-frames --quiet --out " + out.string());
  ASSERT_EQ(result.exit_code, 0) << result.output;
  std::string header;
  const auto rows = read_csv(out / "haptic_forces.csv", &header);
  EXPECT_EQ(header, "time,instrument,fx,fy,fz,tx,ty,tz");
  ASSERT_GT(rows.size(), 100u);
  int in_contact = 0;
  double previous_t = -1.0;
  for (const auto& row : rows) {
    ASSERT_EQ(row.size(), 8u);
    EXPECT_EQ(row[1], "probe");
    const double t = std::stod(row[0]);
    EXPECT_GT(t, previous_t);
    previous_t = t;
    const Vec3 f(std::stod(row[2]), std::stod(row[3]), std::stod(row[4]));
    ASSERT_TRUE(f.allFinite());
    EXPECT_LE(f.norm(), 10.0 + 1e-9);
    if (f.z() > 0.0) ++in_contact;
  }
  EXPECT_GT(in_contact, 0);
  std::ifstream summary_file(out / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  const auto& h = summary.at("haptics");
  EXPECT_EQ(h.at("ticks").get<long>(), static_cast<long>(rows.size()));
  EXPECT_EQ(h.at("rate_hz").get<double>(), 1000.0);
  EXPECT_EQ(h.at("faults").get<long>(), 0);
  for (const char* key : {"period_jitter_ms", "lateness_ms", "tick_duration_ms"}) {
    EXPECT_GE(h.at(key).at("p99").get<double>(), h.at(key).at("p50").get<double>()) << key;
  }
  EXPECT_TRUE(h.contains("deadline_misses"));
  EXPECT_FALSE(h.at("realtime_priority").get<bool>());

  // Not realtime: no haptic thread, no file, "haptics": null.
  std::filesystem::remove_all(out);
  const auto plain = testing::run_cli(std::string("run ") + PLIANT_SOURCE_DIR +
                                      "/assets/scenes/probe_coarse.json --steps 20 --no-frames --quiet --out " +
                                      out.string());
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_FALSE(std::filesystem::exists(out / "haptic_forces.csv"));
  std::ifstream plain_summary(out / "summary.json");
  EXPECT_TRUE(nlohmann::json::parse(plain_summary).at("haptics").is_null());
  std::filesystem::remove_all(out);
}

nlohmann::json probe_coarse_json() {
  std::ifstream in(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/probe_coarse.json");
  return nlohmann::json::parse(in);
}

TEST(SceneFormat, HapticsSectionSetsTheDeviceLimits) {
  nlohmann::json j = probe_coarse_json();
  const Scene plain = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_TRUE(plain.haptics.enabled);  // defaults: the HapticLimits defaults, 50 N/s at 1 kHz
  EXPECT_EQ(plain.haptics.limits.max_force, 10.0);
  EXPECT_NEAR(plain.haptics.limits.max_delta, 0.05, 1e-15);
  EXPECT_EQ(plain.haptics.limits.rate_hz, 1000.0);
  EXPECT_EQ(plain.haptics.threads, 1);
  j["haptics"] = {{"enabled", false}, {"max_force", 2.5}, {"max_force_rate", 20.0}, {"rate_hz", 500.0}, {"threads", 2}};
  const Scene set = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_FALSE(set.haptics.enabled);
  EXPECT_EQ(set.haptics.limits.max_force, 2.5);
  EXPECT_NEAR(set.haptics.limits.max_delta, 20.0 / 500.0, 1e-15);  // N per tick
  EXPECT_EQ(set.haptics.limits.rate_hz, 500.0);
  EXPECT_EQ(set.haptics.threads, 2);

  auto error_of = [](const nlohmann::json& haptics) {
    nlohmann::json scene = probe_coarse_json();
    scene["haptics"] = haptics;
    try {
      parse_scene(scene, "probe_coarse.json", ".");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of({{"max_force", -1.0}}).find("/haptics/max_force"), std::string::npos);
  EXPECT_NE(error_of({{"max_force_rate", 0.0}}).find("/haptics/max_force_rate"), std::string::npos);
  EXPECT_NE(error_of({{"rate_hz", 20000.0}}).find("/haptics/rate_hz"), std::string::npos);
  EXPECT_NE(error_of({{"enabled", "yes"}}).find("/haptics/enabled"), std::string::npos);
  for (const nlohmann::json& bad : {nlohmann::json(0), nlohmann::json(kMaxHapticThreads + 1), nlohmann::json(1.5),
                                    nlohmann::json("two")}) {
    EXPECT_NE(error_of({{"threads", bad}}).find("/haptics/threads"), std::string::npos) << bad;
  }
  EXPECT_NE(error_of({{"max_delta", 0.1}}).find("/haptics/max_delta"), std::string::npos);  // unknown key
  EXPECT_NE(error_of(nlohmann::json::array()).find("/haptics"), std::string::npos);
}

// Writes probe_coarse.json with a "haptics" object into `dir` and returns its path.
std::string scene_with_haptics(const std::filesystem::path& dir, const nlohmann::json& haptics) {
  nlohmann::json j = probe_coarse_json();
  j["haptics"] = haptics;
  std::filesystem::create_directories(dir);
  const auto path = dir / "probe_coarse_haptics.json";
  std::ofstream(path) << j.dump(2);
  return path.string();
}

TEST(RealtimeRun, SendsAtMostTheScenesMaximumForceAtTheScenesRate) {
  const auto dir = std::filesystem::temp_directory_path() / "pliant_scene_haptics_limits_test";
  std::filesystem::remove_all(dir);
  const double max_force = 0.05, max_force_rate = 5.0;  // N, N/s: 0.005 N per 1 kHz tick
  // Two haptic threads: the limits hold across sends made by either (one filter, one claim per tick).
  const std::string scene =
      scene_with_haptics(dir, {{"max_force", max_force}, {"max_force_rate", max_force_rate}, {"threads", 2}});
  const auto out = dir / "out";
  const auto result = testing::run_cli("run " + scene + " --realtime --no-rt-priority --steps 300 --no-frames --quiet --out " +
                                       out.string());
  ASSERT_EQ(result.exit_code, 0) << result.output;
  std::string header;
  const auto rows = read_csv(out / "haptic_forces.csv", &header);
  ASSERT_GT(rows.size(), 100u);
  Vec3 previous = Vec3::Zero();  // the filter starts from zero
  double largest = 0.0;
  for (const auto& row : rows) {
    const Vec3 f(std::stod(row[2]), std::stod(row[3]), std::stod(row[4]));
    ASSERT_TRUE(f.allFinite());
    // 17 significant digits in the file: the bounds hold to round-off.
    EXPECT_LE(f.norm(), max_force * (1.0 + 1e-12));
    EXPECT_LE((f - previous).norm(), max_force_rate / 1000.0 * (1.0 + 1e-9));
    largest = std::max(largest, f.norm());
    previous = f;
  }
  std::ifstream summary_file(out / "summary.json");
  const nlohmann::json summary = nlohmann::json::parse(summary_file);
  // The probe pushes harder than 0.05 N within 300 steps, so the limits acted.
  EXPECT_GT(summary.at("haptics").at("limited_ticks").get<long>(), 0);
  EXPECT_GT(largest, 0.0);
  const auto by_thread = summary.at("haptics").at("ticks_by_thread").get<std::vector<long>>();
  ASSERT_EQ(by_thread.size(), 2u);
  EXPECT_EQ(by_thread[0] + by_thread[1], summary.at("haptics").at("ticks").get<long>());

  // "enabled": false: --realtime runs no haptic thread.
  const std::string off = scene_with_haptics(dir, {{"enabled", false}});
  std::filesystem::remove_all(out);
  const auto run_off = testing::run_cli("run " + off + " --realtime --no-rt-priority --steps 20 --no-frames --quiet --out " +
                                        out.string());
  ASSERT_EQ(run_off.exit_code, 0) << run_off.output;
  EXPECT_FALSE(std::filesystem::exists(out / "haptic_forces.csv"));
  std::ifstream off_summary(out / "summary.json");
  EXPECT_TRUE(nlohmann::json::parse(off_summary).at("haptics").is_null());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace pliant
