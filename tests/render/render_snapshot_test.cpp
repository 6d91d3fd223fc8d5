// take_snapshot: an independent copy of the World (later steps do not change it), removed bodies
// skipped, kinematic flags and colours, the displacement field equal to the displacement applied,
// and a reaction arrow along the tissue's force on the instrument from the mean contact point.
#include <gtest/gtest.h>

#include "render/render_snapshot.h"
#include "sim/mesh/box_mesh.h"
#include "sim/world.h"

namespace pliant {
namespace {

BodyDef box_def(const std::string& name, BodyMotion motion, const Vec3& size, int cells, const Vec3& centre) {
  BodyDef def;
  def.name = name;
  def.mesh = make_box_mesh({size, cells, cells, cells});
  def.motion = motion;
  def.pose.translation = centre;
  return def;
}

TEST(RenderSnapshot, IsACopyThatLaterStepsDoNotChange) {
  World world;
  const BodyId a = world.add_body(box_def("a", BodyMotion::kinematic, Vec3::Constant(0.1), 1, Vec3::Zero()));
  const BodyId gone = world.add_body(box_def("gone", BodyMotion::kinematic, Vec3::Constant(0.1), 1, Vec3(1, 0, 0)));
  world.add_body(box_def("c", BodyMotion::kinematic, Vec3::Constant(0.1), 1, Vec3(0, 1, 0)));
  world.remove_body(gone);

  const RenderSnapshot snap = take_snapshot(world);
  ASSERT_EQ(snap.bodies.size(), 2u);
  EXPECT_EQ(snap.bodies[0].name, "a");
  EXPECT_EQ(snap.bodies[1].name, "c");
  EXPECT_TRUE(snap.bodies[0].kinematic);
  EXPECT_EQ(snap.bodies[0].colour, default_body_colour(0, true));
  EXPECT_EQ(snap.bodies[0].positions, world.body(a).positions);
  EXPECT_TRUE(snap.arrows.empty());
  EXPECT_TRUE(snap.contact_points.empty());
  const Aabb box = snap.bounds();
  EXPECT_TRUE(box.min.isApprox(Vec3(-0.05, -0.05, -0.05)));
  EXPECT_TRUE(box.max.isApprox(Vec3(0.05, 1.05, 0.05)));

  const std::vector<Vec3> before = snap.bodies[0].positions;
  Pose moved;
  moved.translation = Vec3(0.3, 0.0, 0.0);
  world.set_kinematic_pose(a, moved);
  world.step(1e-3);
  EXPECT_EQ(snap.bodies[0].positions, before);
  EXPECT_NE(world.body(a).positions, before);
  EXPECT_DOUBLE_EQ(take_snapshot(world).time, world.time());
}

TEST(RenderSnapshot, DisplacementFieldIsTheAppliedDisplacement) {
  World world;
  const BodyId tissue =
      world.add_body(box_def("tissue", BodyMotion::deformable, Vec3::Constant(0.1), 2, Vec3(0.0, 0.0, 0.2)));
  world.add_body(box_def("probe", BodyMotion::kinematic, Vec3::Constant(0.02), 1, Vec3(0.5, 0.0, 0.0)));
  auto& x = world.body(tissue).positions;
  for (size_t i = 0; i < x.size(); ++i) x[i] += Vec3(0.0, 0.0, -1e-3 * static_cast<double>(i % 5));

  SnapshotOptions options;
  options.field = ScalarField::displacement;
  options.body_colours = {{"probe", Rgba8{1, 2, 3, 255}}};
  const RenderSnapshot snap = take_snapshot(world, options);
  ASSERT_EQ(snap.bodies.size(), 2u);
  const auto& field = snap.bodies[0].scalar_field;
  ASSERT_EQ(field.size(), x.size());
  for (size_t i = 0; i < field.size(); ++i) EXPECT_NEAR(field[i], 1e-3 * static_cast<double>(i % 5), 1e-15);
  EXPECT_TRUE(snap.bodies[1].scalar_field.empty()) << "instruments have no displacement field";
  EXPECT_EQ(snap.bodies[1].colour, (Rgba8{1, 2, 3, 255}));
  EXPECT_EQ(snap.bodies[0].colour, default_body_colour(0, false));
  EXPECT_DOUBLE_EQ(snap.field_min, 0.0);
  EXPECT_NEAR(snap.field_max, 4e-3, 1e-15);
  EXPECT_TRUE(snap.has_scalar_field());

  options.field_range = std::pair{0.0, 0.01};
  const RenderSnapshot fixed = take_snapshot(world, options);
  EXPECT_DOUBLE_EQ(fixed.field_max, 0.01);
}

TEST(RenderSnapshot, ReactionArrowPointsAlongTheForceFromTheContactPoints) {
  World world;
  BodyDef tissue = box_def("tissue", BodyMotion::deformable, Vec3(0.1, 0.1, 0.04), 4, Vec3::Zero());
  world.add_body(std::move(tissue));
  // A probe whose bottom face reaches 4 mm into the tissue's top face (z = 0.02).
  const BodyId probe =
      world.add_body(box_def("probe", BodyMotion::kinematic, Vec3(0.02, 0.02, 0.04), 2, Vec3(0.0, 0.0, 0.036)));
  world.settings().gravity = Vec3::Zero();
  // The probe presses on, 0.1 mm in this step (0.1 m/s): the response stage's velocity update then
  // stops the tissue's contact vertices, and that impulse is the probe's reaction. A probe at rest
  // in a tissue at rest meets no velocity to remove, so its reported reaction would be zero.
  world.set_kinematic_pose(probe, Pose{Vec3(0.0, 0.0, 0.036 - 1e-4), Quat::Identity()});
  const StepReport& report = world.step(1e-3);
  ASSERT_EQ(report.fault, StepFault::none) << report.fault_message;
  const auto& reactions = world.last_report().reactions;
  ASSERT_EQ(reactions.size(), 1u);
  ASSERT_FALSE(world.contacts().empty());
  // The tissue below pushes the probe up.
  ASSERT_GT(reactions[0].force.z(), 1e-9);

  SnapshotOptions options;
  options.step_ms = 1.25;
  const RenderSnapshot snap = take_snapshot(world, options);
  ASSERT_EQ(snap.arrows.size(), 1u);
  const ForceArrow& arrow = snap.arrows[0];
  EXPECT_NEAR(arrow.vector.normalized().dot(reactions[0].force.normalized()), 1.0, 1e-12);

  Vec3 mean = Vec3::Zero();
  int n = 0;
  for (const auto& c : world.contacts()) {
    if (c.body == static_cast<int>(probe.index) || c.penetrated_body == static_cast<int>(probe.index)) {
      mean += c.contact_point;
      ++n;
    }
  }
  ASSERT_GT(n, 0);
  EXPECT_TRUE(arrow.origin.isApprox(mean / n, 1e-12));
  EXPECT_EQ(snap.contact_points.size(), world.contacts().size());
  // Automatic scale: the (only, hence largest) arrow is a quarter of the bodies' diagonal.
  Aabb bodies_box;
  for (const auto& b : snap.bodies) {
    for (const Vec3& x : b.positions) bodies_box.extend(x);
  }
  EXPECT_NEAR(arrow.vector.norm(), 0.25 * bodies_box.extent().norm(), 1e-12);
  // Text: time, the probe's force, the step time.
  ASSERT_EQ(snap.overlay_lines.size(), 3u);
  EXPECT_NE(snap.overlay_lines[1].find("probe F"), std::string::npos) << snap.overlay_lines[1];
  EXPECT_EQ(snap.overlay_lines[2], "step 1.25 ms");
}

}  // namespace
}  // namespace pliant
