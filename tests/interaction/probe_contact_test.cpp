// A sphere-tipped probe pressed into a block fixed at its base, through the whole chain (tool
// script -> instrument -> World::step with the contact-surface response -> instrument force):
// the force is zero out of contact, opposes the motion in contact, grows with depth, and two runs
// give bit-identical forces.
#include <gtest/gtest.h>

#include "interaction/instrument.h"
#include "interaction/script_pose_source.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

using nlohmann::json;

struct Sample {
  double depth = 0.0;  ///< m, how far the probe's lowest point is below the block's top
  Vec3 force = Vec3::Zero();
};

std::vector<Sample> press_probe(double max_depth) {
  WorldSettings settings;
  settings.gravity = Vec3::Zero();
  World world(settings);
  BodyDef block;
  block.name = "block";
  block.mesh = make_box_mesh(BoxMeshSpec{Vec3(0.04, 0.04, 0.02), 8, 8, 4});
  block.material.young_modulus = 5e3;
  block.material.poisson_ratio = 0.3;
  block.material.mass_damping = 5.0;
  for (int v = 0; v < block.mesh->vertex_count(); ++v) {
    if (block.mesh->rest_positions()[static_cast<size_t>(v)].z() < -0.01 + 1e-9) block.fixed_vertices.push_back(v);
  }
  world.add_body(block);
  const double top = 0.01, radius = 0.005;
  const json spec = {{"name", "probe"}, {"type", "probe"}, {"tip_radius", radius}, {"shaft_length", 0.0},
                     {"position", {0.0013, -0.0007, top + radius + 0.001}}};
  Instrument probe = Instrument::create(world, parse_instrument_spec(JsonReader(spec, "test", "/instruments/0")));
  const json script = json::array({{{"t", 1.0}, {"instrument", "probe"}, {"op", "press"}, {"axis", {0, 0, -1}},
                                    {"depth", 0.001 + max_depth}}});
  ScriptPoseSource source(parse_tool_script(JsonReader(script, "test", "/script"), {"probe"}), "probe",
                          probe.command());
  std::vector<Sample> samples;
  InstrumentFeedback fb;
  const double dt = 1e-3;
  for (int i = 1; i <= 1000; ++i) {
    probe.apply(world, source.sample(i * dt, fb));
    const StepReport& r = world.step(dt);
    EXPECT_EQ(r.fault, StepFault::none) << r.fault_message;
    fb.force = probe.force(r);
    fb.time = r.time;
    samples.push_back({top - (probe.pose().translation.z() - radius), fb.force});
  }
  return samples;
}

TEST(ProbeContact, ForceOpposesTheMotionGrowsWithDepthAndIsZeroOutOfContact) {
  const std::vector<Sample> samples = press_probe(0.004);
  double previous = 0.0;
  int in_contact = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    ASSERT_TRUE(s.force.allFinite());
    if (s.depth < 0.0) {
      EXPECT_EQ(s.force, Vec3::Zero()) << "depth " << s.depth;
      continue;
    }
    if (s.depth < 2e-4) continue;  // first contact: coarse detection of the first vertex
    ++in_contact;
    // Opposes the downward motion: pushes the probe up, mostly along +z.
    EXPECT_GT(s.force.z(), 0.0) << "depth " << s.depth;
    EXPECT_GT(s.force.z(), 0.5 * s.force.norm()) << "depth " << s.depth;
  }
  EXPECT_GT(in_contact, 300);
  // Grows with depth: the force ripples step to step as tissue vertices enter and leave contact
  // (a few percent), so compare means over 0.25 mm bins of depth; each must exceed the last.
  for (double bin = 0.25e-3; bin + 0.25e-3 <= 0.004 + 1e-12; bin += 0.25e-3) {
    double sum = 0.0;
    int n = 0;
    for (const Sample& s : samples) {
      if (s.depth >= bin && s.depth < bin + 0.25e-3) {
        sum += s.force.z();
        ++n;
      }
    }
    ASSERT_GT(n, 0) << bin;
    EXPECT_GT(sum / n, previous) << "depth bin " << bin;
    previous = sum / n;
  }
  // Order of magnitude: a rigid sphere into an elastic half-space (Hertz, E* = E/(1-nu^2)),
  // F = 4/3 E* sqrt(R) d^1.5 ~ 0.045 N at 4 mm; a coarse finite block differs, not by 10x.
  const double e_star = 5e3 / (1 - 0.09);
  const double hertz = 4.0 / 3.0 * e_star * std::sqrt(0.005) * std::pow(0.004, 1.5);
  EXPECT_GT(samples.back().force.z(), 0.1 * hertz);
  EXPECT_LT(samples.back().force.z(), 10.0 * hertz);
}

TEST(ProbeContact, TwoRunsGiveBitIdenticalForces) {
  const std::vector<Sample> a = press_probe(0.003), b = press_probe(0.003);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].force.x(), b[i].force.x()) << i;
    ASSERT_EQ(a[i].force.y(), b[i].force.y()) << i;
    ASSERT_EQ(a[i].force.z(), b[i].force.z()) << i;
  }
}

}  // namespace
}  // namespace pliant
