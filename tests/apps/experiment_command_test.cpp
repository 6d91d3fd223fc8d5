// `pliant experiment` and `pliant bench` end to end on the smallest paper scene: the files and
// fields they promise, both methods' series, the contact surface leaving less overlap than the
// penalty springs, and bad input -> exit code 2. Skipped when the pliant binary is not built.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "support/run_cli.h"

namespace pliant {
namespace {

namespace fs = std::filesystem;

using testing::CliResult;
using testing::pliant_binary;
using testing::run_cli;

long count_lines(const fs::path& file) {
  std::ifstream in(file);
  long lines = 0;
  for (std::string line; std::getline(in, line);) ++lines;
  return lines;
}

nlohmann::json read_json(const fs::path& file) {
  std::ifstream in(file);
  return nlohmann::json::parse(in);
}

fs::path scratch(const std::string& name) { return testing::scratch_dir("experiment_test", name); }

TEST(ExperimentCommand, SphereSqueezeWritesBothMethodsAndTheSummary) {
  if (!fs::exists(pliant_binary())) GTEST_SKIP() << "pliant binary not built at " << pliant_binary();
  const fs::path out = scratch("squeeze");
  const std::string scene = std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/sphere_squeeze.json";
  const CliResult r = run_cli("experiment " + scene + " --out " + out.string() + " --duration 0.06 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* m : {"surface", "penalty"}) {
    EXPECT_EQ(count_lines(out / m / "steps.csv"), 1 + 1 + 60) << m;  // header, t = 0, 60 steps
  }
  EXPECT_TRUE(fs::exists(out / "report.md"));
  const nlohmann::json s = read_json(out / "summary.json");
  EXPECT_EQ(s["name"], "sphere_squeeze");
  EXPECT_EQ(s["vertices"], 92);
  EXPECT_EQ(s["surface_triangles"], 170);
  EXPECT_EQ(s["paper"]["vertices"], 95);
  EXPECT_DOUBLE_EQ(s["paper"]["response_ms"].get<double>(), 0.9);
  const auto& surface = s["methods"]["surface"];
  const auto& penalty = s["methods"]["penalty"];
  EXPECT_EQ(surface["steps"], 60);
  EXPECT_EQ(penalty["steps"], 60);
  EXPECT_TRUE(surface["fault"].is_null());
  EXPECT_TRUE(penalty["fault"].is_null());
  // Both start 5 mm deep; the contact surface (with the finishing projection of the shipped
  // scenes) leaves nothing, the penalty springs leave a positive overlap.
  EXPECT_NEAR(surface["max_penetration_before_m"].get<double>(), 0.005, 0.001);
  EXPECT_LT(surface["resting_residual_overlap_m"].get<double>(), 1e-9);
  EXPECT_GT(penalty["resting_residual_overlap_m"].get<double>(), 1e-5);
  EXPECT_GT(surface["initial_energy_J"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(surface["initial_energy_J"].get<double>(), penalty["initial_energy_J"].get<double>());
}

// `--threads 2` (session 22): the step's loops on two threads give the serial run's series bit for
// bit (every column but the timings), and the summary and report say how many threads ran.
TEST(ExperimentCommand, ThreadsGiveTheSerialSeriesAndAreRecorded) {
  if (!fs::exists(pliant_binary())) GTEST_SKIP() << "pliant binary not built at " << pliant_binary();
  const std::string scene = std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/three_cubes.json";
  const fs::path one = scratch("threads1"), two = scratch("threads2");
  for (const auto& [out, threads] : {std::pair{one, 1}, std::pair{two, 2}}) {
    const CliResult r = run_cli("experiment " + scene + " --out " + out.string() + " --duration 0.2 --no-frames --quiet --threads " +
                                std::to_string(threads));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(read_json(out / "summary.json")["threads"], threads);
  }
  std::ifstream report(two / "report.md");
  const std::string text((std::istreambuf_iterator<char>(report)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("on 2 threads"), std::string::npos);
  for (const char* m : {"surface", "penalty"}) {
    std::ifstream a(one / m / "steps.csv"), b(two / m / "steps.csv");
    std::string header, la, lb;
    ASSERT_TRUE(std::getline(a, header));
    std::getline(b, lb);
    ASSERT_EQ(header, lb);
    // The timing columns are the ones named *_ms; every other field must be the same text.
    std::vector<bool> timing;
    for (size_t begin = 0;;) {
      const size_t end = header.find(',', begin);
      const std::string name = header.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
      timing.push_back(name.size() > 3 && name.compare(name.size() - 3, 3, "_ms") == 0);
      if (end == std::string::npos) break;
      begin = end + 1;
    }
    ASSERT_GT(std::count(timing.begin(), timing.end(), true), 0) << header;
    long rows = 0, rows_in_contact = 0;
    while (std::getline(a, la)) {
      ASSERT_TRUE(std::getline(b, lb)) << m << " row " << rows;
      size_t ia = 0, ib = 0;
      for (size_t column = 0; column < timing.size(); ++column) {
        const size_t ea = la.find(',', ia), eb = lb.find(',', ib);
        if (column == 7) rows_in_contact += la.substr(ia, ea - ia) != "0" ? 1 : 0;  // colliding_vertices
        if (!timing[column]) {
          EXPECT_EQ(la.substr(ia, ea - ia), lb.substr(ib, eb - ib)) << m << " row " << rows << " column " << column;
        }
        ia = ea + 1;
        ib = eb + 1;
      }
      ++rows;
    }
    EXPECT_EQ(rows, 201) << m;           // t = 0 and 200 steps
    EXPECT_GT(rows_in_contact, 100) << m;  // the cubes land on the membrane within them
  }
}

// PNG width and height from the IHDR chunk (bytes 16-23, big-endian).
std::pair<int, int> png_size(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  unsigned char h[24] = {};
  in.read(reinterpret_cast<char*>(h), sizeof(h));
  if (!in || h[1] != 'P' || h[2] != 'N' || h[3] != 'G') return {-1, -1};
  auto be32 = [&](int at) { return (h[at] << 24) | (h[at + 1] << 16) | (h[at + 2] << 8) | h[at + 3]; };
  return {be32(16), be32(20)};
}

TEST(ExperimentCommand, SideBySideFramesOnePerFrameIntervalTwoPanelsWide) {
  if (!fs::exists(pliant_binary())) GTEST_SKIP() << "pliant binary not built at " << pliant_binary();
  const fs::path out = scratch("frames");
  const std::string scene = std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/sphere_squeeze.json";
  const CliResult r = run_cli("experiment " + scene + " --out " + out.string() + " --duration 0.1 --frame-rate 50");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  if (r.output.find("PLIANT_RENDER=OFF") != std::string::npos) GTEST_SKIP() << "built without the renderer";
  // Frames at t = 0, 0.02, ..., 0.1 s: six, numbered from 0, each two 480 x 360 panels side by side.
  long pngs = 0;
  for (const auto& entry : fs::directory_iterator(out / "frames")) pngs += entry.path().extension() == ".png";
  EXPECT_EQ(pngs, 6);
  for (int k = 0; k < 6; ++k) {
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%06d.png", k);
    EXPECT_EQ(png_size(out / "frames" / name), std::make_pair(960, 360)) << name;
  }
  EXPECT_EQ(read_json(out / "summary.json")["frames"], 6);
  // --no-frames writes none.
  const fs::path none = scratch("no_frames");
  ASSERT_EQ(run_cli("experiment " + scene + " --out " + none.string() + " --duration 0.01 --no-frames --quiet").exit_code, 0);
  EXPECT_FALSE(fs::exists(none / "frames"));
}

TEST(BenchCommand, OneRowPerSceneAndFrictionVariant) {
  if (!fs::exists(pliant_binary())) GTEST_SKIP() << "pliant binary not built at " << pliant_binary();
  const fs::path out = scratch("bench");
  fs::create_directories(out);
  const CliResult r = run_cli("bench sphere_squeeze three_cubes --steps 3 --warm-up 1 --json " +
                              (out / "b.json").string() + " --csv " + (out / "b.csv").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json b = read_json(out / "b.json");
  ASSERT_EQ(b["rows"].size(), 4u);  // both scenes have friction: a friction-off row each
  EXPECT_EQ(b["rows"][0]["scene"], "sphere_squeeze");
  EXPECT_EQ(b["rows"][1]["variant"], "friction off");
  EXPECT_EQ(b["rows"][2]["vertices"], 323);
  EXPECT_EQ(b["rows"][2]["tets"], 744);
  for (const auto& row : b["rows"]) {
    EXPECT_EQ(row["steps"], 3);
    EXPECT_GE(row["step_ms_p99"].get<double>(), row["step_ms_p50"].get<double>());
  }
  EXPECT_EQ(count_lines(out / "b.csv"), 1 + 4);
}

// --window K: one profile entry per K timed steps, back to back in simulated time (dt = 1 ms), each
// with K steps and at most every deformable body awake (the sphere is the squeeze's only one).
TEST(BenchCommand, WindowProfileCoversTheTimedStepsInOrder) {
  if (!fs::exists(pliant_binary())) GTEST_SKIP() << "pliant binary not built at " << pliant_binary();
  const fs::path out = scratch("bench_window");
  fs::create_directories(out);
  const CliResult r = run_cli("bench sphere_squeeze --steps 6 --warm-up 2 --window 3 --no-variants --json " +
                              (out / "w.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json b = read_json(out / "w.json");
  ASSERT_EQ(b["rows"].size(), 1u);
  const auto& row = b["rows"][0];
  EXPECT_EQ(row["deformable_bodies"], 1);
  const auto& windows = row["windows"];
  ASSERT_EQ(windows.size(), 2u);
  // Warm-up steps end at 2 ms; the windows are 2-5 ms and 5-8 ms.
  EXPECT_NEAR(windows[0]["time_begin_s"].get<double>(), 0.002, 1e-9);
  EXPECT_NEAR(windows[0]["time_end_s"].get<double>(), 0.005, 1e-9);
  EXPECT_NEAR(windows[1]["time_begin_s"].get<double>(), 0.005, 1e-9);
  EXPECT_NEAR(windows[1]["time_end_s"].get<double>(), 0.008, 1e-9);
  for (const auto& w : windows) {
    EXPECT_EQ(w["steps"], 3);
    EXPECT_GE(w["awake_bodies"].get<int>(), 0);
    EXPECT_LE(w["awake_bodies"].get<int>(), 1);
  }
  EXPECT_NE(r.output.find("0.002-0.005"), std::string::npos) << r.output;
}

// --haptic takes the scene's "haptics" limits (as `run --realtime` does), not the defaults: a copy
// of probe_coarse with a 250 Hz thread, a 0.5 N clamp and 20 N/s reports those limits and ticks at
// 250 Hz (the period is 1 / rate_hz exactly); with "enabled": false the scene is skipped.
TEST(BenchCommand, HapticBenchUsesTheScenesHapticLimits) {
  if (!fs::exists(pliant_binary())) GTEST_SKIP() << "pliant binary not built at " << pliant_binary();
  const fs::path out = scratch("bench_haptic");
  fs::create_directories(out);
  nlohmann::json scene;
  {
    std::ifstream in(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/probe_coarse.json");
    scene = nlohmann::json::parse(in);
  }
  scene["haptics"] = {{"max_force", 0.5}, {"max_force_rate", 20.0}, {"rate_hz", 250.0}};
  std::ofstream(out / "limited.json") << scene.dump(2);
  scene["haptics"]["enabled"] = false;
  std::ofstream(out / "off.json") << scene.dump(2);
  const CliResult r = run_cli("bench --haptic --seconds 0.2 --warm-up 0 --no-rt-priority --json " +
                              (out / "h.json").string() + " " + (out / "limited.json").string() + " " +
                              (out / "off.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json b = read_json(out / "h.json");
  ASSERT_EQ(b["rows"].size(), 1u) << r.output;  // the disabled copy is skipped
  const auto& row = b["rows"][0];
  EXPECT_DOUBLE_EQ(row["haptic_limits"]["max_force_n"].get<double>(), 0.5);
  EXPECT_NEAR(row["haptic_limits"]["max_force_rate_n_per_s"].get<double>(), 20.0, 1e-12);
  EXPECT_DOUBLE_EQ(row["haptic_limits"]["rate_hz"].get<double>(), 250.0);
  EXPECT_NEAR(row["haptics"]["rate_hz"].get<double>(), 250.0, 1e-9);
  EXPECT_NE(r.output.find("enabled\": false}, skipped"), std::string::npos) << r.output;
}

TEST(ExperimentCommand, BadInputExitsWith2) {
  if (!fs::exists(pliant_binary())) GTEST_SKIP() << "pliant binary not built at " << pliant_binary();
  const fs::path out = scratch("bad");
  for (const auto& [args, message] :
       {std::pair<std::string, std::string>{"experiment no_such_scene --out " + out.string(),
                                            "no_such_scene"},
        {"experiment three_cubes --out " + out.string() + " --duration 0", "--duration"},
        {"bench no_such_scene", "no_such_scene"},
        {"bench --steps 0", "--steps"}}) {
    const CliResult r = run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << r.output;
  }
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

}  // namespace
}  // namespace pliant
