#include "interaction/tool_script.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "interaction/instrument.h"

namespace pliant {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

Vec3 unit_axis(const JsonReader& j) {
  const Vec3 a = j.vec3();
  const double n = a.norm();
  if (!(n > 1e-12)) j.fail(InputErrorKind::bad_value, "axis must not be zero");
  return a / n;
}

bool contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::string format_time(double t) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.9g", t);
  return buffer;
}

}  // namespace

const char* to_string(ScriptOp op) {
  switch (op) {
    case ScriptOp::move: return "move";
    case ScriptOp::press_depth: return "press";
    case ScriptOp::press_force: return "press";
    case ScriptOp::hold: return "hold";
    case ScriptOp::slide: return "slide";
    case ScriptOp::rotate: return "rotate";
    case ScriptOp::jaws: return "jaws";
  }
  return "unknown";
}

std::vector<ScriptKeyframe> ToolScript::for_instrument(const std::string& name) const {
  std::vector<ScriptKeyframe> out;
  for (const ScriptKeyframe& k : keyframes) {
    if (k.instrument == name) out.push_back(k);
  }
  return out;
}

double ToolScript::end_time() const {
  double t = 0.0;
  for (const ScriptKeyframe& k : keyframes) t = std::max(t, k.time);
  return t;
}

ToolScript parse_tool_script(const JsonReader& j, const std::vector<std::string>& instrument_names,
                             const std::vector<std::string>& grasper_names) {
  if (!j.is_array()) j.fail(InputErrorKind::wrong_type, "expected an array of keyframes");
  ToolScript script;
  std::map<std::string, double> last_time;
  for (size_t i = 0; i < j.size(); ++i) {
    const JsonReader kj = j.at(i);
    if (!kj.is_object()) kj.fail(InputErrorKind::wrong_type, "expected a keyframe object");
    ScriptKeyframe k;
    k.json_path = kj.path();
    const std::string op = kj.at("op").choice({"move", "press", "hold", "slide", "rotate", "jaws"});

    // Which keys each operation takes.
    if (op == "move") {
      kj.expect_keys({"t", "instrument", "op", "position", "orientation"});
    } else if (op == "press") {
      kj.expect_keys({"t", "instrument", "op", "axis", "depth", "force", "speed", "max_depth", "ramp"});
    } else if (op == "hold") {
      kj.expect_keys({"t", "instrument", "op"});
    } else if (op == "slide") {
      kj.expect_keys({"t", "instrument", "op", "path"});
    } else if (op == "rotate") {
      kj.expect_keys({"t", "instrument", "op", "axis", "angle_deg"});
    } else {
      kj.expect_keys({"t", "instrument", "op", "opening_deg"});
    }

    k.instrument = kj.at("instrument").string();
    if (!contains(instrument_names, k.instrument)) {
      std::string list;
      for (const auto& n : instrument_names) list += (list.empty() ? "" : ", ") + n;
      kj.at("instrument").fail(InputErrorKind::bad_value,
                               "unknown instrument '" + k.instrument + "' (scene has: " + list + ")");
    }
    const JsonReader tj = kj.at("t");
    k.time = tj.non_negative_number();
    auto last = last_time.find(k.instrument);
    if (last != last_time.end() && !(k.time > last->second)) {
      tj.fail(InputErrorKind::bad_value, "keyframe times must increase: t = " + format_time(k.time) +
                                             " is not after the previous keyframe of '" + k.instrument +
                                             "' at t = " + format_time(last->second));
    }
    last_time[k.instrument] = k.time;

    if (op == "move") {
      k.op = ScriptOp::move;
      k.position = kj.at("position").vec3();
      if (auto q = kj.find("orientation")) {
        k.has_orientation = true;
        k.orientation = read_quaternion(*q);
      }
    } else if (op == "press") {
      k.axis = unit_axis(kj.at("axis"));
      const bool by_depth = kj.has("depth"), by_force = kj.has("force");
      if (by_depth == by_force) kj.fail(InputErrorKind::bad_value, "press needs exactly one of 'depth' or 'force'");
      if (by_depth) {
        k.op = ScriptOp::press_depth;
        for (const char* key : {"speed", "max_depth", "ramp"}) {
          if (kj.has(key)) kj.at(key).fail(InputErrorKind::unknown_key, "only used with 'force'");
        }
        k.depth = kj.at("depth").positive_number();
      } else {
        k.op = ScriptOp::press_force;
        k.force = kj.at("force").positive_number();
        k.speed = kj.positive_number_or("speed", k.speed);
        k.max_depth = kj.positive_number_or("max_depth", k.max_depth);
        k.ramp = kj.positive_number_or("ramp", k.ramp);
      }
    } else if (op == "hold") {
      k.op = ScriptOp::hold;
    } else if (op == "slide") {
      k.op = ScriptOp::slide;
      const JsonReader pj = kj.at("path");
      if (!pj.is_array() || pj.size() == 0) pj.fail(InputErrorKind::wrong_type, "expected a non-empty array of points");
      for (size_t p = 0; p < pj.size(); ++p) k.path.push_back(pj.at(p).vec3());
    } else if (op == "rotate") {
      k.op = ScriptOp::rotate;
      k.axis = unit_axis(kj.at("axis"));
      k.angle = kj.at("angle_deg").number() * kDegree;
    } else {
      k.op = ScriptOp::jaws;
      k.jaw_opening = kj.at("opening_deg").non_negative_number() * kDegree;
      if (!grasper_names.empty() && !contains(grasper_names, k.instrument)) {
        kj.at("op").fail(InputErrorKind::bad_value, "'jaws' needs a grasper; '" + k.instrument + "' is not one");
      }
    }
    script.keyframes.push_back(std::move(k));
  }
  return script;
}

ToolScript load_tool_script_file(const std::string& path, const std::vector<std::string>& instrument_names,
                                  const std::vector<std::string>& grasper_names) {
  const nlohmann::json root = load_json_file(path);
  const JsonReader r(root, path);
  if (r.is_object()) {
    r.expect_keys({"script"});
    return parse_tool_script(r.at("script"), instrument_names, grasper_names);
  }
  return parse_tool_script(r, instrument_names, grasper_names);
}

}  // namespace pliant
