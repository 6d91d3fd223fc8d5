// The scene's contact.implicit_correction key (docs/scene-format.md): "off" | "stiff_partners" |
// "all" reach the World's ContactSettings; session 6's booleans still read (true: "all", as then);
// another string or type is an InputError naming the key's JSON path. The opt-in
// contact.linearised_search key (a boolean, default true since session 8) reaches it the same way.
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

TEST(SceneFormat, ContactImplicitCorrectionReachesTheWorld) {
  nlohmann::json j = probe_coarse_json();
  EXPECT_EQ(parse_scene(j, "probe_coarse.json", ".").world.contact.implicit_correction,
            ImplicitCorrection::off);
  const std::pair<nlohmann::json, ImplicitCorrection> cases[] = {
      {"off", ImplicitCorrection::off}, {"stiff_partners", ImplicitCorrection::stiff_partners},
      {"all", ImplicitCorrection::all}, {"coupled", ImplicitCorrection::coupled}, {true, ImplicitCorrection::all},
      {false, ImplicitCorrection::off},
  };
  for (const auto& [value, expected] : cases) {
    j["contact"]["implicit_correction"] = value;
    const Scene scene = parse_scene(j, "probe_coarse.json", ".");
    EXPECT_EQ(scene.world.contact.implicit_correction, expected) << value;
    EXPECT_EQ(instantiate_scene(scene).world->settings().contact.implicit_correction, expected) << value;
  }
  for (const nlohmann::json& bad : {nlohmann::json("stiff"), nlohmann::json(1), nlohmann::json::array()}) {
    j["contact"]["implicit_correction"] = bad;
    try {
      parse_scene(j, "probe_coarse.json", ".");
      ADD_FAILURE() << "no error for " << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("/contact/implicit_correction"), std::string::npos) << e.what();
    }
  }
}

TEST(SceneFormat, ContactLinearisedSearchReachesTheWorld) {
  nlohmann::json j = probe_coarse_json();
  EXPECT_TRUE(instantiate_scene(parse_scene(j, "probe_coarse.json", ".")).world->settings().contact.linearised_search);
  j["contact"]["linearised_search"] = false;
  EXPECT_FALSE(instantiate_scene(parse_scene(j, "probe_coarse.json", ".")).world->settings().contact.linearised_search);
  j["contact"]["linearised_search"] = "yes";
  try {
    parse_scene(j, "probe_coarse.json", ".");
    ADD_FAILURE() << "no error for a string";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/contact/linearised_search"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pliant
