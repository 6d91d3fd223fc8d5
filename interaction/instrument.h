// Instruments (issue 6, item 2): kinematic bodies with their own tet meshes, moved by a pose.
//
// API (for scene loading and `pliant run`):
//   InstrumentSpec spec = parse_instrument_spec(JsonReader(scene["instruments"][i], file, "/instruments/i"));
//   Instrument tool = Instrument::create(world, spec);        // adds its kinematic bodies
//   tool.apply(world, InstrumentCommand{pose, jaw_opening});  // target of the next World::step
//   const StepReport& r = world.step(dt);
//   Vec3 f = tool.force(r), tau = tool.torque(r);             // tissue on instrument (N, N m)
//
// Local frames (metres; the pose maps local to world; each instrument's "tip" is its origin):
//   probe:   ball of tip_radius centred at the origin; shaft (shaft_radius) along +z above it.
//   shaft:   solid cylinder of `radius`, bottom end cap centred at the origin, extending +z.
//   grasper: hinge axis = local y through the origin; shaft along +z; two jaws (each its own
//            kinematic body) along -z, jaw_length long. Opening angle theta: jaw A is rotated by
//            -theta/2 about y (its tip swings to +x), jaw B by +theta/2 (to -x). The inner tip
//            points are at distance 2 jaw_length sin(theta/2). Closed (theta = 0) they touch at x = 0.
//   spatula: flat blade, width along x, thickness along y, from z = 0 (distal edge, centred at
//            the origin) to z = blade_length; shaft along +z above it.
// Every body's pose is the instrument pose times a rotation about the origin, so every body's
// reaction torque is about the instrument origin and they sum directly.
//
// JSON (one object of the scene's "instruments" array; lengths in m, angles in degrees):
//   {"name": "probe", "type": "probe" | "shaft" | "grasper" | "spatula",
//    "position": [x, y, z], "orientation": [qw, qx, qy, qz] (normalised; default identity),
//    "resolution": 4 (cells across the cross-section), "friction": 0.0 (Coulomb mu),
//    probe:   "tip_radius" (required), "shaft_radius" (tip_radius/2), "shaft_length" (10 tip_radius; 0 = none)
//    shaft:   "radius" (required), "length" (required)
//    grasper: "jaw_length", "jaw_width", "jaw_thickness" (required), "shaft_radius" (jaw_width/2),
//             "shaft_length" (5 jaw_length; 0 = none), "jaw_opening_deg" (0), "max_jaw_opening_deg" (60)
//    spatula: "blade_length", "blade_width", "blade_thickness" (required), "shaft_radius"
//             (blade_width/4), "shaft_length" (5 blade_length; 0 = none)}
#pragma once

#include <string>
#include <vector>

#include "interaction/json_reader.h"
#include "sim/math_types.h"
#include "sim/step_report.h"
#include "sim/world.h"

namespace pliant {

/// The kinds of instrument.
enum class InstrumentKind { probe, shaft, grasper, spatula };
/// "probe" / "shaft" / "grasper" / "spatula".
const char* to_string(InstrumentKind kind);

/// An instrument as described in a scene. Lengths in m, angles in rad.
struct InstrumentSpec {
  std::string name;
  InstrumentKind kind = InstrumentKind::probe;
  Pose pose;                 ///< initial pose (local -> world)
  int resolution = 4;        ///< cells across the cross-section (>= 2)
  double friction = 0.0;     ///< Coulomb mu of the instrument's surface
  // probe
  double tip_radius = 0.005;  ///< m
  // shaft (also the probe's/grasper's/spatula's shaft)
  double radius = 0.0025;       ///< m, of the "shaft" instrument
  double length = 0.05;         ///< m, of the "shaft" instrument
  double shaft_radius = 0.0025; ///< m
  double shaft_length = 0.05;   ///< m, 0 = no shaft
  // grasper
  double jaw_length = 0.02;     ///< m
  double jaw_width = 0.005;     ///< m
  double jaw_thickness = 0.002; ///< m
  double jaw_opening = 0.0;     ///< rad, initial opening angle
  double max_jaw_opening = 1.0471975511965976;  ///< rad (60 deg)
  // spatula
  double blade_length = 0.02;    ///< m
  double blade_width = 0.01;     ///< m
  double blade_thickness = 0.001;///< m
};

/// Reads one instrument object; errors name the JSON path (e.g. "/instruments/0/tip_radius").
InstrumentSpec parse_instrument_spec(const JsonReader& j);

/// Where an instrument should be after the next physics step.
struct InstrumentCommand {
  Pose pose;                 ///< local -> world
  double jaw_opening = 0.0;  ///< rad (grasper only; ignored otherwise)
};

/// What a pose source is told each tick: the last measured state of its instrument.
struct InstrumentFeedback {
  double time = 0.0;             ///< s, simulated time of the measurement
  Vec3 force = Vec3::Zero();     ///< N, force the tissue exerts on the instrument
  Vec3 torque = Vec3::Zero();    ///< N m, about the instrument origin
};

/// One body of an instrument and its rest rotation role.
struct InstrumentPart {
  std::string name;   ///< "tip", "shaft", "jaw_a", "jaw_b", "blade"
  BodyId body;
  int jaw_sign = 0;   ///< +1 jaw A (rotated by -theta/2 about y), -1 jaw B, 0 rigid with the pose
};

/// An instrument in a World: its kinematic bodies and current pose.
class Instrument {
 public:
  /// Builds the meshes and adds the kinematic bodies (named "<name>/<part>") to `world`.
  static Instrument create(World& world, const InstrumentSpec& spec);

  const std::string& name() const { return spec_.name; }
  const InstrumentSpec& spec() const { return spec_; }
  InstrumentKind kind() const { return spec_.kind; }

  /// Sets the target poses of all bodies for the next World::step. The jaw opening is clamped
  /// to [0, max_jaw_opening].
  void apply(World& world, const InstrumentCommand& cmd);

  /// Sum of the reactions on the instrument's bodies in `r` (N): the haptic force.
  Vec3 force(const StepReport& r) const;
  /// Sum of the reaction torques (N m) about the instrument origin.
  Vec3 torque(const StepReport& r) const;

  /// Last commanded pose and jaw opening (rad).
  Pose pose() const { return command_.pose; }
  double jaw_opening() const { return command_.jaw_opening; }
  const InstrumentCommand& command() const { return command_; }

  /// Handles of all bodies of this instrument.
  std::vector<BodyId> bodies() const;
  const std::vector<InstrumentPart>& parts() const { return parts_; }

  /// World pose of a part for a command (the instrument pose times the part's jaw rotation).
  Pose part_pose(const InstrumentPart& part, const InstrumentCommand& cmd) const;

  /// Inner tip point of a jaw in the instrument frame for an opening angle (rad); sign +1 = jaw A.
  Vec3 jaw_tip_local(int jaw_sign, double opening) const;

 private:
  InstrumentSpec spec_;
  std::vector<InstrumentPart> parts_;
  InstrumentCommand command_;
};

/// Quaternion from JSON [qw, qx, qy, qz], normalised; fails on a zero or non-finite quaternion.
Quat read_quaternion(const JsonReader& j);

}  // namespace pliant
