// Sleeping in the shipped instrument scenes (docs/scene-format.md "Instruments and fixtures"):
// the bodies a scene's instruments create are instruments, its kinematic dish or floor bodies are
// not, and with sleeping on (the shipped setting) the coarse probe scene's tissue never falls asleep
// under the probe while it presses and holds: the probe force is bit-identical, tick by tick, to
// the same scene with sleeping off. Before the instrument flag this scene's tissue fell asleep in
// the hold at t = 0.732 s and the force dropped to 0 N for the rest of the run.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "interaction/scene/scene.h"
#include "interaction/scene/scene_runner.h"
#include "sim/input_error.h"

namespace pliant {
namespace {

nlohmann::json scene_json(const std::string& relative) {
  std::ifstream in(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/" + relative);
  return nlohmann::json::parse(in);
}

TEST(SceneSleep, InstrumentsAreFlaggedAndDishesAreNot) {
  const Scene probe = parse_scene(scene_json("probe_coarse.json"), "probe_coarse.json", ".");
  EXPECT_TRUE(probe.world.sleep.enabled);  // the shipped setting
  const SceneInstance p = instantiate_scene(probe);
  int instrument_bodies = 0;
  for (const Body* b : p.world->bodies()) {
    if (b == nullptr) continue;
    EXPECT_EQ(b->instrument, b->is_kinematic()) << b->name;  // the only kinematic bodies: the probe's
    instrument_bodies += b->instrument ? 1 : 0;
  }
  EXPECT_GT(instrument_bodies, 0);
  const Scene dish = parse_scene(scene_json("paper/fruit_dish.json"), "fruit_dish.json", ".");
  const SceneInstance d = instantiate_scene(dish);
  int fixtures = 0;
  for (const Body* b : d.world->bodies()) {
    if (b == nullptr) continue;
    EXPECT_FALSE(b->instrument) << b->name;
    fixtures += b->is_kinematic() ? 1 : 0;
  }
  EXPECT_EQ(fixtures, 5);  // the dish: a floor and four walls
}

TEST(SceneSleep, CoarseProbeHoldsItsForceWithSleepingOnBitForBitAsWithItOff) {
  nlohmann::json off_json = scene_json("probe_coarse.json");
  off_json["sleep"]["enabled"] = false;
  const Scene on_scene = parse_scene(scene_json("probe_coarse.json"), "probe_coarse.json", ".");
  const Scene off_scene = parse_scene(off_json, "probe_coarse.json", ".");
  ASSERT_TRUE(on_scene.world.sleep.enabled);
  SceneRunner on(on_scene), off(off_scene);
  int touching = 0;
  for (int i = 0; i < 900; ++i) {  // t = 0.9 s: pressing from about 0.21 s, then holding
    ASSERT_TRUE(on.tick()) << on.fault();
    ASSERT_TRUE(off.tick()) << off.fault();
    ASSERT_EQ(on.report().sleeping_bodies, 0) << "t = " << on.time();
    ASSERT_EQ(on.readings().size(), off.readings().size());
    for (size_t k = 0; k < on.readings().size(); ++k) {
      const Vec3 a = on.readings()[k].force, b = off.readings()[k].force;
      for (int c = 0; c < 3; ++c) {
        ASSERT_EQ(std::memcmp(&a[c], &b[c], sizeof(double)), 0)
            << "t = " << on.time() << ": " << a.transpose() << " vs " << b.transpose();
      }
    }
    if (on.readings()[0].force.norm() > 0.0) {
      ++touching;
    } else {
      ASSERT_EQ(touching, 0) << "the probe force dropped to 0 at t = " << on.time();
    }
  }
  EXPECT_GT(touching, 600);
}

// sleep.wake_on_centre_motion (session 12, opt-in; the fruit dish ships it on): absent it is false
// (the old wake rule bit for bit), true reaches the world, and a value that is not a boolean is an
// error naming the file and its JSON path.
TEST(SceneSleep, WakeOnCentreMotionReachesTheWorldAndABadValueNamesItsPath) {
  nlohmann::json j = scene_json("paper/fruit_dish.json");
  EXPECT_TRUE(parse_scene(j, "fruit_dish.json", ".").world.sleep.wake_on_centre_motion);
  j["sleep"].erase("wake_on_centre_motion");
  EXPECT_FALSE(parse_scene(j, "fruit_dish.json", ".").world.sleep.wake_on_centre_motion);
  j["sleep"]["wake_on_centre_motion"] = true;
  EXPECT_TRUE(parse_scene(j, "fruit_dish.json", ".").world.sleep.wake_on_centre_motion);
  j["sleep"]["wake_on_centre_motion"] = "centre";
  try {
    parse_scene(j, "fruit_dish.json", ".");
    ADD_FAILURE() << "a string was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/sleep/wake_on_centre_motion"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("fruit_dish.json"), std::string::npos) << e.what();
  }
}

// sleep.rest_by_centre_when_supported (session 14, opt-in): absent it is false (the old rest rule
// bit for bit), true reaches the world, and a value that is not a boolean is an error naming the
// file and its JSON path.
TEST(SceneSleep, RestByCentreWhenSupportedReachesTheWorldAndABadValueNamesItsPath) {
  nlohmann::json j = scene_json("paper/membrane_stack.json");
  if (!j.contains("sleep")) j["sleep"] = nlohmann::json::object();
  j["sleep"].erase("rest_by_centre_when_supported");
  EXPECT_FALSE(parse_scene(j, "membrane_stack.json", ".").world.sleep.rest_by_centre_when_supported);
  j["sleep"]["rest_by_centre_when_supported"] = true;
  EXPECT_TRUE(parse_scene(j, "membrane_stack.json", ".").world.sleep.rest_by_centre_when_supported);
  j["sleep"]["rest_by_centre_when_supported"] = 1;
  try {
    parse_scene(j, "membrane_stack.json", ".");
    ADD_FAILURE() << "a number was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/sleep/rest_by_centre_when_supported"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("membrane_stack.json"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pliant
