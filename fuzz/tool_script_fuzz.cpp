// libFuzzer target: tool-script JSON (the keyframe array) through parse_tool_script, with a probe
// and a grasper in the scene. A parsed script is also evaluated along time by a ScriptPoseSource
// per instrument, since bad numbers that pass parsing would show up there.
#include "fuzz/fuzz_guard.h"
#include "interaction/json_reader.h"
#include "interaction/script_pose_source.h"
#include "interaction/tool_script.h"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  pliant::fuzz::expect_only_input_errors("tool_script_fuzz", [&] {
    const nlohmann::json root = pliant::parse_json_text(pliant::fuzz::as_text(data, size), "fuzz.json");
    const pliant::ToolScript script =
        pliant::parse_tool_script(pliant::JsonReader(root, "fuzz.json"), {"probe", "grasper"}, {"grasper"});
    const double end = script.end_time();
    for (const char* name : {"probe", "grasper"}) {
      pliant::ScriptPoseSource source(script, name, pliant::InstrumentCommand{});
      for (int k = 0; k <= 8; ++k) source.sample(end * k / 8.0, pliant::InstrumentFeedback{});
    }
  });
  return 0;
}
