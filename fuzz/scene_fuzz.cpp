// libFuzzer target: scene JSON text through parse_json_text + parse_scene. Relative mesh files
// resolve against assets/scenes (so seeds may name ../meshes/...); nothing is instantiated.
#include "fuzz/fuzz_guard.h"
#include "interaction/json_reader.h"
#include "interaction/scene/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  pliant::fuzz::expect_only_input_errors("scene_fuzz", [&] {
    const nlohmann::json root = pliant::parse_json_text(pliant::fuzz::as_text(data, size), "fuzz.json");
    pliant::parse_scene(root, "fuzz.json", PLIANT_SOURCE_DIR "/assets/scenes");
  });
  return 0;
}
