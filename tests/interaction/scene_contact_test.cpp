// The scene's "contact" object reads held_force_fraction (docs/scene-format.md): a value in [0, 1]
// reaches the World's ContactSettings; outside, or of the wrong type, the error names its path.
// Likewise deformable_pair_held_force_fraction (session 9; session 10: or "derived"), the boolean
// limit_friction_move, and held_linearised_final_strain (session 21).
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

// Parsing `j` fails with an InputError naming `path` (`what`: the bad value, for the message).
void expect_rejected(const nlohmann::json& j, const std::string& path, const std::string& what) {
  try {
    parse_scene(j, "probe_coarse.json", ".");
    ADD_FAILURE() << "no error for " << what;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

// A held-force fraction key: `value` (not the default) reaches the scene and the World; 1.5, -0.1
// and a string are errors naming /contact/<key>.
void expect_fraction_key(const char* key, double value, double ContactSettings::*member) {
  nlohmann::json j = probe_coarse_json();
  j["contact"][key] = value;
  const Scene scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_EQ(scene.world.contact.*member, value) << key;
  EXPECT_EQ(instantiate_scene(scene).world->settings().contact.*member, value) << key;
  for (const nlohmann::json& bad : {nlohmann::json(1.5), nlohmann::json(-0.1), nlohmann::json("all")}) {
    j["contact"][key] = bad;
    expect_rejected(j, std::string("/contact/") + key, bad.dump());
  }
}

TEST(SceneFormat, ContactHeldForceFractionReachesTheWorld) {
  // Library default: full strength (the contact's whole reaction is held); a scene may turn it off (0:
  // the paper's method, for comparison), so the test sets the value that differs from the default.
  EXPECT_EQ(parse_scene(probe_coarse_json(), "probe_coarse.json", ".").world.contact.held_force_fraction, 1.0);
  expect_fraction_key("held_force_fraction", 0.0, &ContactSettings::held_force_fraction);
}

// contact.limit_friction_move (docs/stability.md M6a): off by default; a scene may turn it on with
// returns excused (true, session 10), charged everywhere ("charge_returns", session 15) or charged
// unless a body's friction partners are all instruments ("charge_deformable_returns", session 16) or
// charged in the model's stiffness against the step's kinetic energy flow ("energy_flow", session 17);
// any other value names its path.
TEST(SceneFormat, ContactLimitFrictionMoveReachesTheWorld) {
  nlohmann::json j = probe_coarse_json();
  const ContactSettings defaults = parse_scene(j, "probe_coarse.json", ".").world.contact;
  EXPECT_FALSE(defaults.limit_friction_move);
  EXPECT_FALSE(defaults.limit_friction_move_charges_returns);
  EXPECT_FALSE(defaults.limit_friction_move_excuses_instrument_returns);
  j["contact"]["limit_friction_move"] = true;
  const Scene scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_TRUE(scene.world.contact.limit_friction_move);
  EXPECT_FALSE(scene.world.contact.limit_friction_move_charges_returns);
  EXPECT_TRUE(instantiate_scene(scene).world->settings().contact.limit_friction_move);
  j["contact"]["limit_friction_move"] = "charge_returns";
  const Scene charging = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_TRUE(charging.world.contact.limit_friction_move);
  EXPECT_TRUE(instantiate_scene(charging).world->settings().contact.limit_friction_move_charges_returns);
  EXPECT_FALSE(charging.world.contact.limit_friction_move_excuses_instrument_returns);
  j["contact"]["limit_friction_move"] = "charge_deformable_returns";
  const ContactSettings named = parse_scene(j, "probe_coarse.json", ".").world.contact;
  EXPECT_TRUE(named.limit_friction_move);
  EXPECT_TRUE(named.limit_friction_move_charges_returns);
  EXPECT_TRUE(named.limit_friction_move_excuses_instrument_returns);
  EXPECT_FALSE(named.limit_friction_move_energy_flow);
  EXPECT_FALSE(defaults.limit_friction_move_energy_flow);
  j["contact"]["limit_friction_move"] = "energy_flow";
  const Scene flowing = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_TRUE(flowing.world.contact.limit_friction_move);
  EXPECT_TRUE(instantiate_scene(flowing).world->settings().contact.limit_friction_move_energy_flow);
  for (const nlohmann::json& bad : {nlohmann::json(0.5), nlohmann::json("charge")}) {
    j["contact"]["limit_friction_move"] = bad;
    expect_rejected(j, "/contact/limit_friction_move", bad.dump());
  }
}

// The membrane stack ships the limit charging returns and the centre wake rule (session 15: with them
// it comes to rest at 1 ms without a churning bottom pair; docs/experiments.md, and the long test
// MembraneChurnLedger.LongTheStackRestsWhenTheMembraneLayerIsBelowCfl1 for the physics); the probe
// keeps the library default (the limit would change its tool force).
TEST(SceneFormat, MembraneStackShipsTheLimitChargingReturnsAndTheProbeDoesNot) {
  const Scene stack = load_scene(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/membrane_stack.json");
  EXPECT_TRUE(stack.world.contact.limit_friction_move);
  EXPECT_TRUE(stack.world.contact.limit_friction_move_charges_returns);
  EXPECT_TRUE(stack.world.sleep.wake_on_centre_motion);
  const Scene probe = load_scene(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/probe.json");
  EXPECT_FALSE(probe.world.contact.limit_friction_move);
  EXPECT_FALSE(probe.world.contact.limit_friction_move_charges_returns);
}

// contact.held_linearised_final_strain (session 21, docs/contact-surface.md "Response time, session
// 21"): 0 by default (the final evaluation exact under held forces); a non-negative number reaches the
// World; a negative one or a string names its path. Three cubes ships 3e-3 (the gate tested in
// Stability.SurfaceMilligramBodyWithASliverUnderTheHeldFinalGate); the other shipped scenes keep 0.
TEST(SceneFormat, ContactHeldLinearisedFinalStrainReachesTheWorld) {
  nlohmann::json j = probe_coarse_json();
  EXPECT_EQ(parse_scene(j, "probe_coarse.json", ".").world.contact.held_linearised_final_strain, 0.0);
  j["contact"]["held_linearised_final_strain"] = 2e-3;
  const Scene scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_EQ(scene.world.contact.held_linearised_final_strain, 2e-3);
  EXPECT_EQ(instantiate_scene(scene).world->settings().contact.held_linearised_final_strain, 2e-3);
  for (const nlohmann::json& bad : {nlohmann::json(-1e-3), nlohmann::json("3e-3")}) {
    j["contact"]["held_linearised_final_strain"] = bad;
    expect_rejected(j, "/contact/held_linearised_final_strain", bad.dump());
  }
  const std::string paper = std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/";
  EXPECT_EQ(load_scene(paper + "three_cubes.json").world.contact.held_linearised_final_strain, 3e-3);
  for (const char* name : {"sphere_squeeze.json", "membrane_stack.json", "fruit_dish.json"}) {
    EXPECT_EQ(load_scene(paper + name).world.contact.held_linearised_final_strain, 0.0) << name;
  }
}

// contact.deformable_pair_held_force_fraction (docs/contact-surface.md "Resting churn, session 9"):
// 1 by default (held_force_fraction everywhere), opt-in values in [0, 1].
TEST(SceneFormat, ContactDeformablePairHeldForceFractionReachesTheWorld) {
  EXPECT_EQ(parse_scene(probe_coarse_json(), "probe_coarse.json", ".").world.contact.deformable_pair_held_force_fraction,
            1.0);
  expect_fraction_key("deformable_pair_held_force_fraction", 0.8, &ContactSettings::deformable_pair_held_force_fraction);
}

// Session 10: the string "derived" turns on ContactSettings::deformable_pair_held_force_derived (off
// by default, and off for a number); another string names the path.
TEST(SceneFormat, ContactDeformablePairHeldForceDerivedReachesTheWorld) {
  nlohmann::json j = probe_coarse_json();
  EXPECT_FALSE(parse_scene(j, "probe_coarse.json", ".").world.contact.deformable_pair_held_force_derived);
  j["contact"]["deformable_pair_held_force_fraction"] = 0.8;
  EXPECT_FALSE(parse_scene(j, "probe_coarse.json", ".").world.contact.deformable_pair_held_force_derived);
  j["contact"]["deformable_pair_held_force_fraction"] = "derived";
  const Scene scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_TRUE(scene.world.contact.deformable_pair_held_force_derived);
  EXPECT_EQ(scene.world.contact.deformable_pair_held_force_fraction, 1.0);
  EXPECT_TRUE(instantiate_scene(scene).world->settings().contact.deformable_pair_held_force_derived);
  j["contact"]["deformable_pair_held_force_fraction"] = "derive";
  expect_rejected(j, "/contact/deformable_pair_held_force_fraction", "\"derive\"");
}

}  // namespace
}  // namespace pliant
