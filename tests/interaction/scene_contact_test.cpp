// The scene's "contact" object reads held_force_fraction (docs/scene-format.md): a value in [0, 1]
// reaches the World's ContactSettings; outside, or of the wrong type, the error names its path.
// Likewise the boolean limit_friction_move.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "interaction/scene/scene.h"
#include "sim/input_error.h"

namespace pliant {
namespace {

nlohmann::json probe_coarse_json() {
  std::ifstream in(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/probe_coarse.json");
  return nlohmann::json::parse(in);
}

TEST(SceneFormat, ContactHeldForceFractionReachesTheWorld) {
  nlohmann::json j = probe_coarse_json();
  // Library default: full strength (the contact's whole reaction is held); a scene may turn it off (0:
  // the paper's method, for comparison), so the test sets the value that differs from the default.
  EXPECT_EQ(parse_scene(j, "probe_coarse.json", ".").world.contact.held_force_fraction, 1.0);
  j["contact"]["held_force_fraction"] = 0.0;
  const Scene scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_EQ(scene.world.contact.held_force_fraction, 0.0);
  EXPECT_EQ(instantiate_scene(scene).world->settings().contact.held_force_fraction, 0.0);
  for (const nlohmann::json& bad : {nlohmann::json(1.5), nlohmann::json(-0.1), nlohmann::json("all")}) {
    j["contact"]["held_force_fraction"] = bad;
    try {
      parse_scene(j, "probe_coarse.json", ".");
      ADD_FAILURE() << "no error for " << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("/contact/held_force_fraction"), std::string::npos) << e.what();
    }
  }
}

// contact.limit_friction_move (docs/stability.md M6a): off by default, a scene may turn it on; a
// non-boolean names its path.
TEST(SceneFormat, ContactLimitFrictionMoveReachesTheWorld) {
  nlohmann::json j = probe_coarse_json();
  EXPECT_FALSE(parse_scene(j, "probe_coarse.json", ".").world.contact.limit_friction_move);
  j["contact"]["limit_friction_move"] = true;
  const Scene scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_TRUE(scene.world.contact.limit_friction_move);
  EXPECT_TRUE(instantiate_scene(scene).world->settings().contact.limit_friction_move);
  j["contact"]["limit_friction_move"] = 0.5;
  try {
    parse_scene(j, "probe_coarse.json", ".");
    ADD_FAILURE() << "no error for 0.5";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/contact/limit_friction_move"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pliant
