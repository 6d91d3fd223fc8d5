// Tool scripts (issue 6, item 3): keyframes over time that drive instruments.
//
// API:
//   ToolScript s = parse_tool_script(JsonReader(scene["script"], file, "/script"), {"probe", ...});
//   ToolScript s = load_tool_script_file("press.json", names);   // root is the array
//   ScriptPoseSource src(s, "probe", initial_command);            // see script_pose_source.h
//
// JSON: an array of keyframe objects. Each keyframe names an instrument and an operation that
// runs from the instrument's previous keyframe time (0 for its first) to its own time "t" (s).
// Per instrument, times must strictly increase (the first may be 0: an instant set at start).
// Every operation starts and ends at rest (quintic easing), so motion is C1 across keyframes.
//   {"t": 1.0, "instrument": "probe", "op": "move", "position": [x,y,z], "orientation": [qw,qx,qy,qz]}
//        move to a pose (orientation optional: keep the current one); rotation by slerp.
//   {"t": 2.0, "instrument": "probe", "op": "press", "axis": [0,0,-1], "depth": 0.004}
//        move along the world axis (normalised) by depth (m).
//   {"t": 2.0, "instrument": "probe", "op": "press", "axis": [0,0,-1], "force": 1.5,
//    "speed": 0.01, "max_depth": 0.01, "ramp": 0.02}
//        press until the measured force against the axis, -F.axis, reaches `force` (N): accelerate
//        smoothly to `speed` (m/s) over `ramp` (s), decelerate smoothly over `ramp` once the
//        force is reached (or to stop exactly at max_depth, or to be at rest by "t"), then hold.
//   {"t": 3.0, "instrument": "probe", "op": "hold"}
//   {"t": 4.0, "instrument": "probe", "op": "slide", "path": [[x,y,z], ...]}
//        through the polyline's points (world, m), each leg eased separately (at rest at every
//        corner, so the velocity never jumps), time shared in proportion to leg length.
//   {"t": 5.0, "instrument": "probe", "op": "rotate", "axis": [0,1,0], "angle_deg": 30}
//        rotate about a world axis through the instrument origin.
//   {"t": 6.0, "instrument": "grasper", "op": "jaws", "opening_deg": 40}
//        open or close the jaws to an angle (graspers only).
// Errors (InputError naming the JSON path, e.g. "scene.json: /script/3/t"): times not increasing,
// NaN, unknown operation, unknown instrument, missing or unknown fields.
#pragma once

#include <string>
#include <vector>

#include "interaction/json_reader.h"
#include "sim/math_types.h"

namespace pliant {

/// What a keyframe does.
enum class ScriptOp { move, press_depth, press_force, hold, slide, rotate, jaws };
/// "move", "press" (depth), "press" (force), "hold", "slide", "rotate", "jaws".
const char* to_string(ScriptOp op);

/// One keyframe: an operation that ends at `time`.
struct ScriptKeyframe {
  double time = 0.0;          ///< s, when the operation ends
  std::string instrument;
  ScriptOp op = ScriptOp::hold;
  std::string json_path;      ///< where it came from, for messages
  // move
  Vec3 position = Vec3::Zero();  ///< m (world)
  bool has_orientation = false;
  Quat orientation = Quat::Identity();
  // press / rotate
  Vec3 axis = Vec3::UnitZ();  ///< unit vector (world)
  double depth = 0.0;         ///< m (press_depth)
  double force = 0.0;         ///< N (press_force): target of -F.axis
  double speed = 0.01;        ///< m/s (press_force)
  double max_depth = 0.05;    ///< m (press_force)
  double ramp = 0.02;         ///< s (press_force): acceleration / deceleration time
  double angle = 0.0;         ///< rad (rotate)
  // slide
  std::vector<Vec3> path;     ///< m (world)
  // jaws
  double jaw_opening = 0.0;   ///< rad
};

/// Keyframes of all instruments, in file order.
struct ToolScript {
  std::vector<ScriptKeyframe> keyframes;
  /// Keyframes of one instrument, in time order.
  std::vector<ScriptKeyframe> for_instrument(const std::string& name) const;
  /// Time of the last keyframe (s), 0 if empty.
  double end_time() const;
};

/// Reads a script: `j` is an array of keyframe objects. `instrument_names` are the scene's
/// instruments; a keyframe naming another is an error. A "jaws" keyframe needs the instrument to
/// be a grasper: pass `grasper_names` to check it (empty = not checked).
ToolScript parse_tool_script(const JsonReader& j, const std::vector<std::string>& instrument_names,
                             const std::vector<std::string>& grasper_names = {});

/// Reads a script file whose root is the keyframe array (or an object {"script": [...]}).
ToolScript load_tool_script_file(const std::string& path, const std::vector<std::string>& instrument_names,
                                 const std::vector<std::string>& grasper_names = {});

}  // namespace pliant
