// The body's "model_settings" object reads fused_sweeps, coarse_aggregate_size and
// stiffness_rotation_tolerance (docs/scene-format.md), each reaching the model; fused_sweeps reaches
// the corotational FEM's SSOR sweeps (the AVX2/FMA kernels where the CPU has them, or the exact
// sweeps), and a value of the wrong type is an error naming its JSON path.
#include <gtest/gtest.h>

#include <fstream>
#include <initializer_list>
#include <string>
#include <nlohmann/json.hpp>

#include "interaction/scene/scene.h"
#include "sim/input_error.h"
#include "sim/model/corotational_fem.h"
#include "sim/model/fused_ssor_kernels.h"
#include "sim/world.h"

namespace pliant {
namespace {

nlohmann::json probe_coarse_json() {
  std::ifstream in(std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/probe_coarse.json");
  return nlohmann::json::parse(in);
}

/// The first deformable body's corotational FEM in an instantiated scene (null if none).
const CorotationalFem* first_fem(const SceneInstance& instance) {
  for (BodyId id : instance.bodies) {
    const Body& body = instance.world->body(id);
    if (const auto* fem = dynamic_cast<const CorotationalFem*>(body.model.get())) return fem;
  }
  return nullptr;
}

/// Each of `bad` as the tissue's model_settings[key] is an InputError naming its JSON path.
void expect_errors_name_the_path(nlohmann::json j, size_t tissue, const std::string& key,
                                 std::initializer_list<nlohmann::json> bad) {
  for (const nlohmann::json& value : bad) {
    j["bodies"][tissue]["model_settings"][key] = value;
    try {
      parse_scene(j, "probe_coarse.json", ".");
      ADD_FAILURE() << "no error for " << key << " = " << value;
    } catch (const InputError& e) {
      const std::string path = "/bodies/" + std::to_string(tissue) + "/model_settings/" + key;
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
}

TEST(SceneFormat, ModelSettingsFusedSweepsReachesTheModel) {
  nlohmann::json j = probe_coarse_json();
  auto& bodies = j["bodies"];
  size_t tissue = 0;
  while (tissue < bodies.size() && bodies[tissue].value("kinematic", false)) ++tissue;
  ASSERT_LT(tissue, bodies.size());

  // Default: on where the CPU has AVX2/FMA (session 8), off elsewhere.
  const Scene default_scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_TRUE(default_scene.bodies[tissue].model_settings.fused_sweeps);
  const SceneInstance default_instance = instantiate_scene(default_scene);
  const CorotationalFem* fem = first_fem(default_instance);
  ASSERT_NE(fem, nullptr);
  EXPECT_EQ(fem->fused_sweeps(), fused_sweeps_available());

  // false: the exact sweeps.
  j["bodies"][tissue]["model_settings"]["fused_sweeps"] = false;
  const Scene exact_scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_FALSE(exact_scene.bodies[tissue].model_settings.fused_sweeps);
  const SceneInstance exact_instance = instantiate_scene(exact_scene);
  fem = first_fem(exact_instance);
  ASSERT_NE(fem, nullptr);
  EXPECT_FALSE(fem->fused_sweeps());

  // A non-boolean names its path.
  expect_errors_name_the_path(j, tissue, "fused_sweeps", {nlohmann::json(1), nlohmann::json("on")});
}

// "coarse_aggregate_size" (session 13): default 0 (no coarse correction), an integer reaches the
// model, and a negative or non-integer value names its JSON path.
TEST(SceneFormat, ModelSettingsCoarseAggregateSizeReachesTheModel) {
  nlohmann::json j = probe_coarse_json();
  size_t tissue = 0;
  while (tissue < j["bodies"].size() && j["bodies"][tissue].value("kinematic", false)) ++tissue;
  ASSERT_LT(tissue, j["bodies"].size());
  const Scene default_scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_EQ(default_scene.bodies[tissue].model_settings.coarse_aggregate_size, 0);
  const SceneInstance default_instance = instantiate_scene(default_scene);
  const CorotationalFem* fem = first_fem(default_instance);
  ASSERT_NE(fem, nullptr);
  EXPECT_EQ(fem->coarse_aggregate_size(), 0);

  j["bodies"][tissue]["model_settings"]["coarse_aggregate_size"] = 56;
  const Scene coarse_scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_EQ(coarse_scene.bodies[tissue].model_settings.coarse_aggregate_size, 56);
  const SceneInstance coarse_instance = instantiate_scene(coarse_scene);
  fem = first_fem(coarse_instance);
  ASSERT_NE(fem, nullptr);
  EXPECT_EQ(fem->coarse_aggregate_size(), 56);

  expect_errors_name_the_path(j, tissue, "coarse_aggregate_size",
                              {nlohmann::json(-1), nlohmann::json(2.5), nlohmann::json("56")});
}

// "stiffness_rotation_tolerance" (session 19): default the library's 1e-3 rad, a value (0 included:
// K' from the current rotations every step) reaches the model, and a negative or non-number value
// names its JSON path.
TEST(SceneFormat, ModelSettingsStiffnessRotationToleranceReachesTheModel) {
  nlohmann::json j = probe_coarse_json();
  size_t tissue = 0;
  while (tissue < j["bodies"].size() && j["bodies"][tissue].value("kinematic", false)) ++tissue;
  ASSERT_LT(tissue, j["bodies"].size());
  const Scene default_scene = parse_scene(j, "probe_coarse.json", ".");
  EXPECT_EQ(default_scene.bodies[tissue].model_settings.stiffness_rotation_tolerance,
            kDefaultStiffnessRotationTolerance);
  const SceneInstance default_instance = instantiate_scene(default_scene);
  const CorotationalFem* fem = first_fem(default_instance);
  ASSERT_NE(fem, nullptr);
  EXPECT_EQ(fem->stiffness_rotation_tolerance(), kDefaultStiffnessRotationTolerance);

  for (const double tolerance : {0.0, 0.01}) {
    j["bodies"][tissue]["model_settings"]["stiffness_rotation_tolerance"] = tolerance;
    const Scene scene = parse_scene(j, "probe_coarse.json", ".");
    EXPECT_EQ(scene.bodies[tissue].model_settings.stiffness_rotation_tolerance, tolerance);
    const SceneInstance instance = instantiate_scene(scene);
    fem = first_fem(instance);
    ASSERT_NE(fem, nullptr);
    EXPECT_EQ(fem->stiffness_rotation_tolerance(), tolerance);
  }

  expect_errors_name_the_path(j, tissue, "stiffness_rotation_tolerance",
                              {nlohmann::json(-1e-3), nlohmann::json("0.01"), nlohmann::json(true)});
}

}  // namespace
}  // namespace pliant
