#include "interaction/instrument.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "interaction/instrument_meshes.h"

namespace pliant {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// Rotation of jaw `sign` (+1 = A, -1 = B) about the hinge axis (local y) for an opening angle.
Quat jaw_rotation(int sign, double opening) {
  return Quat(Eigen::AngleAxisd(-sign * 0.5 * opening, Vec3::UnitY()));
}

Pose compose(const Pose& a, const Quat& local_rotation) {
  Pose p;
  p.translation = a.translation;
  p.rotation = (a.rotation * local_rotation).normalized();
  return p;
}

// Shaft above z = z0 along +z; empty when length is 0.
void add_shaft(std::vector<RawTetMesh>& parts, double radius, double length, double z0, int resolution) {
  if (length <= 0.0) return;
  const double cell = 2.0 * radius / resolution;
  parts.push_back(cylinder_tets(radius, length, resolution, cells_along(length, 2.0 * cell), z0));
}

}  // namespace

const char* to_string(InstrumentKind kind) {
  switch (kind) {
    case InstrumentKind::probe: return "probe";
    case InstrumentKind::shaft: return "shaft";
    case InstrumentKind::grasper: return "grasper";
    case InstrumentKind::spatula: return "spatula";
  }
  return "unknown";
}

Quat read_quaternion(const JsonReader& j) {
  if (!j.is_array() || j.size() != 4) j.fail(InputErrorKind::wrong_type, "expected [qw, qx, qy, qz]");
  const Quat q(j.at(0).number(), j.at(1).number(), j.at(2).number(), j.at(3).number());
  const double n = q.norm();
  if (!(n > 1e-12)) j.fail(InputErrorKind::bad_value, "quaternion must not be zero");
  return q.normalized();
}

InstrumentSpec parse_instrument_spec(const JsonReader& j) {
  if (!j.is_object()) j.fail(InputErrorKind::wrong_type, "expected an instrument object");
  InstrumentSpec s;
  s.name = j.at("name").string();
  if (s.name.empty()) j.at("name").fail(InputErrorKind::bad_value, "instrument name must not be empty");
  const std::string type = j.at("type").choice({"probe", "shaft", "grasper", "spatula"});
  if (type == "probe") {
    s.kind = InstrumentKind::probe;
    j.expect_keys({"name", "type", "position", "orientation", "resolution", "friction", "tip_radius",
                   "shaft_radius", "shaft_length"});
    s.tip_radius = j.at("tip_radius").positive_number();
    s.shaft_radius = j.positive_number_or("shaft_radius", 0.5 * s.tip_radius);
    s.shaft_length = j.non_negative_number_or("shaft_length", 10.0 * s.tip_radius);
    if (s.shaft_radius > s.tip_radius) {
      j.at("shaft_radius").fail(InputErrorKind::bad_value, "must not exceed tip_radius");
    }
  } else if (type == "shaft") {
    s.kind = InstrumentKind::shaft;
    j.expect_keys({"name", "type", "position", "orientation", "resolution", "friction", "radius", "length"});
    s.radius = j.at("radius").positive_number();
    s.length = j.at("length").positive_number();
  } else if (type == "grasper") {
    s.kind = InstrumentKind::grasper;
    j.expect_keys({"name", "type", "position", "orientation", "resolution", "friction", "jaw_length", "jaw_width",
                   "jaw_thickness", "shaft_radius", "shaft_length", "jaw_opening_deg", "max_jaw_opening_deg"});
    s.jaw_length = j.at("jaw_length").positive_number();
    s.jaw_width = j.at("jaw_width").positive_number();
    s.jaw_thickness = j.at("jaw_thickness").positive_number();
    s.shaft_radius = j.positive_number_or("shaft_radius", 0.5 * s.jaw_width);
    s.shaft_length = j.non_negative_number_or("shaft_length", 5.0 * s.jaw_length);
    s.max_jaw_opening = j.positive_number_or("max_jaw_opening_deg", 60.0) * kDegree;
    if (s.max_jaw_opening > std::numbers::pi) {
      j.at("max_jaw_opening_deg").fail(InputErrorKind::bad_value, "must not exceed 180");
    }
    s.jaw_opening = j.non_negative_number_or("jaw_opening_deg", 0.0) * kDegree;
    if (s.jaw_opening > s.max_jaw_opening) {
      j.at("jaw_opening_deg").fail(InputErrorKind::bad_value, "exceeds max_jaw_opening_deg");
    }
  } else {
    s.kind = InstrumentKind::spatula;
    j.expect_keys({"name", "type", "position", "orientation", "resolution", "friction", "blade_length",
                   "blade_width", "blade_thickness", "shaft_radius", "shaft_length"});
    s.blade_length = j.at("blade_length").positive_number();
    s.blade_width = j.at("blade_width").positive_number();
    s.blade_thickness = j.at("blade_thickness").positive_number();
    s.shaft_radius = j.positive_number_or("shaft_radius", 0.25 * s.blade_width);
    s.shaft_length = j.non_negative_number_or("shaft_length", 5.0 * s.blade_length);
  }
  s.pose.translation = j.vec3_or("position", Vec3::Zero());
  if (auto q = j.find("orientation")) s.pose.rotation = read_quaternion(*q);
  s.resolution = j.integer_or("resolution", 4);
  if (s.resolution < 2 || s.resolution > 32) {
    j.at("resolution").fail(InputErrorKind::bad_value, "expected an integer in [2, 32]");
  }
  s.friction = j.non_negative_number_or("friction", 0.0);
  return s;
}

Instrument Instrument::create(World& world, const InstrumentSpec& spec) {
  Instrument tool;
  tool.spec_ = spec;
  tool.command_.pose = spec.pose;
  tool.command_.jaw_opening = spec.kind == InstrumentKind::grasper ? spec.jaw_opening : 0.0;
  const int n = std::max(spec.resolution, 2);
  const std::string source = "instrument '" + spec.name + "'";

  auto add_part = [&](const std::string& part, RawTetMesh raw, int jaw_sign) {
    BodyDef def;
    def.name = spec.name + "/" + part;
    def.mesh = build_instrument_mesh(std::move(raw), source + " " + part);
    def.motion = BodyMotion::kinematic;
    def.instrument = true;  // a tool, not a fixture: what it touches stays awake (sim/sleep)
    def.material.friction = spec.friction;
    InstrumentPart p{part, BodyId{}, jaw_sign};
    def.pose = tool.part_pose(p, tool.command_);
    p.body = world.add_body(std::move(def));
    tool.parts_.push_back(p);
  };

  switch (spec.kind) {
    case InstrumentKind::probe: {
      std::vector<RawTetMesh> parts{ball_tets(spec.tip_radius, n)};
      // The shaft starts where its radius meets the sphere, so the outline is closed.
      const double z0 = std::sqrt(std::max(0.0, spec.tip_radius * spec.tip_radius - spec.shaft_radius * spec.shaft_radius));
      add_shaft(parts, spec.shaft_radius, spec.shaft_length, z0, n);
      add_part("tip", merge(parts), 0);
      break;
    }
    case InstrumentKind::shaft: {
      const double cell = 2.0 * spec.radius / n;
      add_part("shaft", cylinder_tets(spec.radius, spec.length, n, cells_along(spec.length, cell)), 0);
      break;
    }
    case InstrumentKind::grasper: {
      if (spec.shaft_length > 0.0) {
        std::vector<RawTetMesh> parts;
        add_shaft(parts, spec.shaft_radius, spec.shaft_length, 0.0, n);
        add_part("shaft", merge(parts), 0);
      }
      const double t = spec.jaw_thickness, w = spec.jaw_width, l = spec.jaw_length;
      const double cell = std::min(w, l) / n;
      const int nx = std::max(1, cells_along(t, cell)), ny = cells_along(w, cell), nz = cells_along(l, cell);
      add_part("jaw_a", box_tets(Vec3(0.0, -0.5 * w, -l), Vec3(t, 0.5 * w, 0.0), nx, ny, nz), +1);
      add_part("jaw_b", box_tets(Vec3(-t, -0.5 * w, -l), Vec3(0.0, 0.5 * w, 0.0), nx, ny, nz), -1);
      break;
    }
    case InstrumentKind::spatula: {
      const double t = spec.blade_thickness, w = spec.blade_width, l = spec.blade_length;
      const double cell = std::min(w, l) / n;
      std::vector<RawTetMesh> parts{box_tets(Vec3(-0.5 * w, -0.5 * t, 0.0), Vec3(0.5 * w, 0.5 * t, l),
                                             cells_along(w, cell), 1, cells_along(l, cell))};
      add_shaft(parts, spec.shaft_radius, spec.shaft_length, l, n);
      add_part("blade", merge(parts), 0);
      break;
    }
  }
  return tool;
}

Pose Instrument::part_pose(const InstrumentPart& part, const InstrumentCommand& cmd) const {
  if (part.jaw_sign == 0) return compose(cmd.pose, Quat::Identity());
  return compose(cmd.pose, jaw_rotation(part.jaw_sign, cmd.jaw_opening));
}

Vec3 Instrument::jaw_tip_local(int jaw_sign, double opening) const {
  return jaw_rotation(jaw_sign, opening) * Vec3(0.0, 0.0, -spec_.jaw_length);
}

void Instrument::apply(World& world, const InstrumentCommand& cmd) {
  command_ = cmd;
  command_.pose.rotation.normalize();
  const bool jaws = spec_.kind == InstrumentKind::grasper && std::isfinite(cmd.jaw_opening);
  command_.jaw_opening = jaws ? std::clamp(cmd.jaw_opening, 0.0, spec_.max_jaw_opening) : 0.0;
  for (const InstrumentPart& part : parts_) world.set_kinematic_pose(part.body, part_pose(part, command_));
}

Vec3 Instrument::force(const StepReport& r) const {
  Vec3 f = Vec3::Zero();
  for (const KinematicReaction& reaction : r.reactions) {
    for (const InstrumentPart& part : parts_) {
      if (reaction.body == static_cast<int>(part.body.index)) f += reaction.force;
    }
  }
  return f;
}

Vec3 Instrument::torque(const StepReport& r) const {
  Vec3 t = Vec3::Zero();
  for (const KinematicReaction& reaction : r.reactions) {
    for (const InstrumentPart& part : parts_) {
      if (reaction.body == static_cast<int>(part.body.index)) t += reaction.torque;
    }
  }
  return t;
}

std::vector<BodyId> Instrument::bodies() const {
  std::vector<BodyId> ids;
  for (const InstrumentPart& part : parts_) ids.push_back(part.body);
  return ids;
}

}  // namespace pliant
