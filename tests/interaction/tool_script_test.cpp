// Tool scripts: keyframes reached exactly, C1 motion (finite-difference velocity has no jumps),
// press-until-force stops on the fed-back force, and bad scripts name their JSON path.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "interaction/script_pose_source.h"
#include "interaction/tool_script.h"

namespace pliant {
namespace {

using nlohmann::json;

ToolScript parse(const json& j, std::vector<std::string> names = {"probe", "grasper"}) {
  return parse_tool_script(JsonReader(j, "scene.json", "/script"), names, {"grasper"});
}

const json kScript = json::parse(R"([
  {"t": 0.5, "instrument": "probe", "op": "move", "position": [0.01, 0.02, 0.05]},
  {"t": 1.0, "instrument": "probe", "op": "press", "axis": [0, 0, -1], "depth": 0.01},
  {"t": 1.2, "instrument": "probe", "op": "hold"},
  {"t": 2.0, "instrument": "probe", "op": "slide", "path": [[0.03, 0.02, 0.04], [0.03, 0.05, 0.04], [0.0, 0.0, 0.03]]},
  {"t": 2.5, "instrument": "probe", "op": "rotate", "axis": [0, 1, 0], "angle_deg": 45},
  {"t": 3.0, "instrument": "probe", "op": "move", "position": [0.0, 0.0, 0.06], "orientation": [0.7071067811865476, 0.7071067811865476, 0, 0]},
  {"t": 0.4, "instrument": "grasper", "op": "jaws", "opening_deg": 40},
  {"t": 0.9, "instrument": "grasper", "op": "jaws", "opening_deg": 5}
])");

TEST(ToolScript, KeyframesAreReachedExactly) {
  const ToolScript script = parse(kScript);
  ASSERT_EQ(script.keyframes.size(), 8u);
  EXPECT_DOUBLE_EQ(script.end_time(), 3.0);
  ScriptPoseSource src(script, "probe", InstrumentCommand{});
  const InstrumentFeedback fb;
  // Sample finely so every segment starts where the previous one ended.
  std::vector<std::pair<double, InstrumentCommand>> at_keys;
  for (int i = 0; i <= 3000; ++i) {
    const double t = i * 1e-3;
    const InstrumentCommand c = src.sample(t, fb);
    for (double k : {0.5, 1.0, 1.2, 2.0, 2.5, 3.0}) {
      if (t == k) at_keys.emplace_back(t, c);
    }
  }
  ASSERT_EQ(at_keys.size(), 6u);
  auto exactly = [](const Vec3& a, const Vec3& b) { return a.x() == b.x() && a.y() == b.y() && a.z() == b.z(); };
  EXPECT_TRUE(exactly(at_keys[0].second.pose.translation, Vec3(0.01, 0.02, 0.05)));
  // Press: start + depth * axis (the sum as the script defines it).
  EXPECT_TRUE(exactly(at_keys[1].second.pose.translation, Vec3(0.01, 0.02, 0.05) + 0.01 * Vec3(0, 0, -1)));
  EXPECT_TRUE(exactly(at_keys[2].second.pose.translation, at_keys[1].second.pose.translation));
  EXPECT_TRUE(exactly(at_keys[3].second.pose.translation, Vec3(0.0, 0.0, 0.03)));
  const Quat expected_rotation(Eigen::AngleAxisd(std::numbers::pi / 4, Vec3::UnitY()));
  EXPECT_NEAR(at_keys[4].second.pose.rotation.angularDistance(expected_rotation), 0.0, 1e-12);
  EXPECT_TRUE(exactly(at_keys[5].second.pose.translation, Vec3(0.0, 0.0, 0.06)));
  EXPECT_EQ(at_keys[5].second.pose.rotation.w(), Quat(0.7071067811865476, 0.7071067811865476, 0, 0).normalized().w());
  EXPECT_TRUE(src.finished(3.0));
  EXPECT_FALSE(src.finished(2.9));
}

// Largest change of the finite-difference velocity between successive samples, relative to the
// largest velocity: O(dt / T) for C1 motion, O(1) for a velocity jump.
double relative_velocity_jump(const std::vector<Eigen::VectorXd>& x, double dt) {
  double max_v = 0.0, max_dv = 0.0;
  for (size_t i = 0; i + 2 < x.size(); ++i) {
    const Eigen::VectorXd v0 = (x[i + 1] - x[i]) / dt;
    const Eigen::VectorXd v1 = (x[i + 2] - x[i + 1]) / dt;
    max_v = std::max(max_v, v0.norm());
    max_dv = std::max(max_dv, (v1 - v0).norm());
  }
  return max_dv / max_v;
}

TEST(ToolScript, MotionIsC1AcrossKeyframes) {
  const ToolScript script = parse(kScript);
  ScriptPoseSource probe(script, "probe", InstrumentCommand{});
  ScriptPoseSource grasper(script, "grasper", InstrumentCommand{});
  const double dt = 2e-5;
  std::vector<Eigen::VectorXd> position, rotation, jaw;
  Quat previous = Quat::Identity();
  for (int i = 0; i <= static_cast<int>(3.2 / dt); ++i) {
    const double t = i * dt;
    const InstrumentCommand c = probe.sample(t, {});
    position.push_back(c.pose.translation);
    Quat q = c.pose.rotation;
    if (q.dot(previous) < 0) q.coeffs() = -q.coeffs();  // same hemisphere: q and -q are one rotation
    previous = q;
    rotation.push_back(q.coeffs());
    jaw.push_back(Eigen::VectorXd::Constant(1, grasper.sample(t, {}).jaw_opening));
  }
  // Quintic easing: max acceleration / max velocity = (10/sqrt(3)) / (15/8) / T ~ 3 / T.
  EXPECT_LT(relative_velocity_jump(position, dt), 0.01);
  EXPECT_LT(relative_velocity_jump(rotation, dt), 0.01);
  EXPECT_LT(relative_velocity_jump(jaw, dt), 0.01);

  // Control: a linear (C0) interpolation of the same keyframes has O(1) velocity jumps.
  std::vector<Eigen::VectorXd> linear;
  for (int i = 0; i <= static_cast<int>(1.0 / dt); ++i) {
    const double t = i * dt;
    linear.push_back(t < 0.5 ? Vec3(Vec3(0.01, 0.02, 0.05) * (t / 0.5))
                             : Vec3(Vec3(0.01, 0.02, 0.05) + (t - 0.5) / 0.5 * Vec3(0, 0, -0.01)));
  }
  EXPECT_GT(relative_velocity_jump(linear, dt), 0.5);

  // Velocity is (near) zero right at every keyframe time: the segments meet at rest.
  ScriptPoseSource again(script, "probe", InstrumentCommand{});
  Vec3 last = Vec3::Zero();
  for (int i = 0; i <= static_cast<int>(3.0 / dt); ++i) {
    const double t = i * dt;
    const Vec3 x = again.sample(t, {}).pose.translation;
    for (double k : {0.5, 1.0, 1.2, 2.0, 2.5}) {
      if (std::abs(t - k) < 0.5 * dt) {
        EXPECT_LT((x - last).norm() / dt, 1e-6) << t;
      }
    }
    last = x;
  }
}

TEST(ToolScript, PressUntilForceStopsWhenTheForceIsReached) {
  // A linear spring floor at z = 0: force on the probe k * penetration, along +z.
  const double k = 200.0, target = 1.0, speed = 0.01, ramp = 0.02;
  const ToolScript script = parse(json::parse(R"([
    {"t": 3.0, "instrument": "probe", "op": "press", "axis": [0, 0, -1], "force": 1.0, "speed": 0.01,
     "max_depth": 0.02, "ramp": 0.02},
    {"t": 3.5, "instrument": "probe", "op": "move", "position": [0, 0, 0.01]}])"));
  InstrumentCommand start;
  start.pose.translation = Vec3(0.0, 0.0, 0.002);
  ScriptPoseSource src(script, "probe", start);
  const double dt = 1e-3;
  InstrumentFeedback fb;
  double trigger_depth = -1.0;
  std::vector<double> z;
  for (int i = 0; i <= 3000; ++i) {
    const double t = i * dt;
    const InstrumentCommand c = src.sample(t, fb);
    if (trigger_depth < 0 && src.force_reached_time() >= 0) trigger_depth = start.pose.translation.z() - z.back();
    z.push_back(c.pose.translation.z());
    fb.time = t;
    fb.force = Vec3(0, 0, k * std::max(0.0, -c.pose.translation.z()));  // the "physics" of this tick
  }
  ASSERT_GE(src.force_reached_time(), 0.0);
  // Force reached at penetration target / k = 5 mm, i.e. z = -5 mm (first tick at or past it).
  const double z_at_trigger = start.pose.translation.z() - trigger_depth;
  EXPECT_LE(z_at_trigger, -target / k + 1e-12);
  EXPECT_GT(z_at_trigger, -target / k - speed * dt - 1e-12);
  // Then it decelerates over `ramp` from `speed`: stops speed * ramp / 2 further, and holds.
  const double z_stop = z[2999];
  EXPECT_NEAR(z_stop, z_at_trigger - speed * dt - speed * ramp / 2, speed * dt);
  EXPECT_GT(z_stop, start.pose.translation.z() - 0.02);  // well before max_depth
  const auto stop_index = static_cast<size_t>(std::lround(src.force_reached_time() / dt + ramp / dt)) + 1;
  for (size_t i = stop_index; i < 3000; ++i) EXPECT_EQ(z[i], z_stop) << i;
  // And the next keyframe starts from where the press stopped and ends exactly at its target.
  EXPECT_EQ(src.sample(3.5, fb).pose.translation.z(), 0.01);
}

TEST(ToolScript, PressUntilForceWithoutForceStopsExactlyAtMaxDepth) {
  const ToolScript script = parse(json::parse(R"([
    {"t": 3.0, "instrument": "probe", "op": "press", "axis": [1, 0, 0], "force": 5.0, "speed": 0.01,
     "max_depth": 0.005, "ramp": 0.05}])"));
  ScriptPoseSource src(script, "probe", InstrumentCommand{});
  double previous = 0.0, max_step = 0.0;
  for (int i = 0; i <= 3000; ++i) {
    const double x = src.sample(i * 1e-3, InstrumentFeedback{}).pose.translation.x();
    EXPECT_GE(x, previous);  // monotone, never overshoots
    max_step = std::max(max_step, x - previous);
    previous = x;
  }
  EXPECT_NEAR(previous, 0.005, 1e-12);
  EXPECT_LE(max_step, 0.01 * 1e-3 * (1 + 1e-9));  // never faster than `speed`
  EXPECT_LT(src.force_reached_time(), 0.0);
}

void expect_script_error(const json& j, const std::string& path, InputErrorKind kind, const std::string& words = "") {
  try {
    parse(j);
    ADD_FAILURE() << "no error for " << j.dump();
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("scene.json: " + path), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << what;
    EXPECT_EQ(e.kind(), kind) << what;
  }
}

TEST(ToolScript, BadScriptsNameTheirJsonPath) {
  expect_script_error(json::parse(R"([{"t": 1, "instrument": "probe", "op": "hold"},
                                      {"t": 1, "instrument": "probe", "op": "hold"}])"),
                      "/script/1/t", InputErrorKind::bad_value, "must increase");
  expect_script_error(json::parse(R"([{"t": 2, "instrument": "probe", "op": "hold"},
                                      {"t": 1, "instrument": "probe", "op": "hold"}])"),
                      "/script/1/t", InputErrorKind::bad_value, "must increase");
  json nan_script = json::parse(R"([{"t": 1, "instrument": "probe", "op": "move", "position": [0, 0, 0]}])");
  nan_script[0]["position"][1] = std::nan("");
  expect_script_error(nan_script, "/script/0/position/1", InputErrorKind::non_finite);
  json nan_time = json::parse(R"([{"t": 1, "instrument": "probe", "op": "hold"}])");
  nan_time[0]["t"] = std::nan("");
  expect_script_error(nan_time, "/script/0/t", InputErrorKind::non_finite);
  expect_script_error(json::parse(R"([{"t": 1, "instrument": "probe", "op": "teleport"}])"), "/script/0/op",
                      InputErrorKind::bad_value, "teleport");
  expect_script_error(json::parse(R"([{"t": 1, "instrument": "scalpel", "op": "hold"}])"), "/script/0/instrument",
                      InputErrorKind::bad_value, "unknown instrument 'scalpel'");
  expect_script_error(json::parse(R"([{"t": 1, "instrument": "probe", "op": "move"}])"), "/script/0",
                      InputErrorKind::bad_value, "position");
  expect_script_error(json::parse(R"([{"t": 1, "instrument": "probe", "op": "press", "axis": [0, 0, 1]}])"),
                      "/script/0", InputErrorKind::bad_value, "exactly one of");
  expect_script_error(json::parse(R"([{"t": 1, "instrument": "probe", "op": "hold", "speed": 3}])"),
                      "/script/0/speed", InputErrorKind::unknown_key);
  expect_script_error(json::parse(R"([{"t": 1, "instrument": "probe", "op": "jaws", "opening_deg": 3}])"),
                      "/script/0/op", InputErrorKind::bad_value, "grasper");
  expect_script_error(json::parse(R"([{"t": 1, "instrument": "probe", "op": "rotate", "axis": [0, 0, 0], "angle_deg": 3}])"),
                      "/script/0/axis", InputErrorKind::bad_value, "zero");
  expect_script_error(json::parse(R"({"t": 1})"), "/script", InputErrorKind::wrong_type);
}

}  // namespace
}  // namespace pliant
