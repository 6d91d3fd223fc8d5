// The paper's point (issue 5, tests 8-10): coarse sampling. A rigid sphere pressed into a block
// whose vertex spacing exceeds its radius must not slip between the coarse vertices; a probe
// sliding across a coarse surface must feel a force that changes smoothly, more smoothly with the
// paper's barycentric weighting than without; and a heavy cube on a soft membrane sinks in under
// the penalty method (more with more weight) but not with the contact surface.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/mesh/box_mesh.h"
#include "sim/mesh/membrane_mesh.h"
#include "sim/mesh/sphere_mesh.h"
#include "sim/world.h"

namespace pliant {
namespace {

Material tissue(double young) {
  Material m;
  m.young_modulus = young;
  m.poisson_ratio = 0.45;
  m.density = 1000.0;
  m.mass_damping = 5.0;
  m.stiffness_damping = 0.01;
  return m;
}

// A coarse tissue block 100 x 100 x 40 mm (vertex spacing 11 mm), top face at z = 0, base fixed,
// and a rigid sphere of radius 10 mm above it.
struct CoarseProbe {
  World world{WorldSettings{.gravity = Vec3::Zero()}};
  BodyId block, sphere;
  double radius = 0.01;
  double inscribed = 0.0;  // radius of the sphere mesh's inscribed sphere
};

void make_coarse_probe(CoarseProbe& s, bool weighting, int cells) {
  s.world.settings().contact.finishing_projection = true;
  s.world.settings().contact.friction = false;
  s.world.settings().contact.barycentric_weighting = weighting;
  const auto block_mesh = make_box_mesh({Vec3(0.1, 0.1, 0.04), cells, cells, 3});
  BodyDef block{.name = "block", .mesh = block_mesh, .material = tissue(5e3)};
  block.pose.translation = Vec3(0, 0, -0.02);
  for (int v = 0; v < block_mesh->vertex_count(); ++v) {
    if (block_mesh->rest_positions()[static_cast<size_t>(v)].z() < -0.0199) block.fixed_vertices.push_back(v);
  }
  const auto sphere_mesh = make_sphere_mesh({.radius = s.radius, .surface_vertices = 73, .shells = 2});
  BodyDef sphere{.name = "sphere", .mesh = sphere_mesh, .material = tissue(1e6), .motion = BodyMotion::kinematic};
  sphere.pose.translation = Vec3(0.004, -0.003, s.radius + 0.001);  // off the coarse vertices
  s.block = s.world.add_body(block);
  s.sphere = s.world.add_body(sphere);
  s.inscribed = s.radius;
  const auto& x = sphere_mesh->rest_positions();
  for (int t = 0; t < sphere_mesh->surface_triangle_count(); ++t) {
    const auto& tri = sphere_mesh->surface_triangles()[static_cast<size_t>(t)];
    s.inscribed = std::min(s.inscribed, -(Vec3::Zero() - x[static_cast<size_t>(tri[0])]).dot(sphere_mesh->triangle_normal(x, t)));
  }
}

// Height of the block's deformed top surface straight above (x, y): the upward-facing surface
// triangle whose projection contains the point.
double surface_height_at(const Body& block, double x, double y) {
  const auto& mesh = *block.mesh;
  double best = -1e9;
  for (int t = 0; t < mesh.surface_triangle_count(); ++t) {
    if (mesh.triangle_normal(block.positions, t).z() <= 0.1) continue;
    const auto& tri = mesh.surface_triangles()[static_cast<size_t>(t)];
    const Vec3& a = block.positions[static_cast<size_t>(tri[0])];
    const Vec3& b = block.positions[static_cast<size_t>(tri[1])];
    const Vec3& c = block.positions[static_cast<size_t>(tri[2])];
    const double det = (b.x() - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (b.y() - a.y());
    if (std::abs(det) < 1e-15) continue;
    const double u = ((x - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (y - a.y())) / det;
    const double v = ((b.x() - a.x()) * (y - a.y()) - (x - a.x()) * (b.y() - a.y())) / det;
    if (u < -1e-12 || v < -1e-12 || u + v > 1 + 1e-12) continue;
    best = std::max(best, a.z() + u * (b.z() - a.z()) + v * (c.z() - a.z()));
  }
  return best;
}

TEST(ContactCoarse, RigidSpherePressedIntoACoarseBlockDoesNotSlipBetweenVertices) {
  CoarseProbe s;
  make_coarse_probe(s, true, 9);
  ASSERT_GT(s.world.body(s.block).mesh->mean_edge_length(), s.radius);
  const double depth = 0.010;
  const int steps = 400;
  const Vec3 start = s.world.body(s.sphere).pose.translation;
  for (int i = 1; i <= steps; ++i) {
    const double t = static_cast<double>(i) / steps;
    Pose pose = s.world.body(s.sphere).pose;
    pose.translation = start - Vec3(0, 0, (0.001 + depth) * t * t * (3 - 2 * t));
    s.world.set_kinematic_pose(s.sphere, pose);
    const StepReport& r = s.world.step(1e-3);
    ASSERT_EQ(r.fault, StepFault::none);
    const Body& block = s.world.body(s.block);
    const Body& sphere = s.world.body(s.sphere);
    const Vec3 centre = sphere.pose.translation;
    // The sphere mesh's lowest point never sits more than 1% of the indentation below the
    // deformed surface straight above it.
    Vec3 lowest = sphere.positions[0];
    for (const Vec3& p : sphere.positions) {
      if (p.z() < lowest.z()) lowest = p;
    }
    const double indentation = std::max(0.0, -lowest.z());
    const double surface = surface_height_at(block, lowest.x(), lowest.y());
    EXPECT_GE(lowest.z(), surface - 0.01 * indentation - 1e-9) << "step " << i;
    // No tissue vertex inside the sphere (its inscribed ball, to round-off).
    for (const Vec3& p : block.positions) EXPECT_GE((p - centre).norm(), s.inscribed - 1e-9) << "step " << i;
  }
  // It pushed back.
  EXPECT_GT(s.world.last_report().reactions.at(0).force.z(), 0.0);
}

// Slides a sphere at a fixed depth slowly across the coarse block; returns the largest
// step-to-step change of the vertical reaction over its mean.
double sliding_force_jump(bool weighting) {
  CoarseProbe s;
  make_coarse_probe(s, weighting, 6);
  const double depth = 0.004;
  Vec3 position = s.world.body(s.sphere).pose.translation;
  auto move_to = [&](const Vec3& p) {
    Pose pose = s.world.body(s.sphere).pose;
    pose.translation = p;
    s.world.set_kinematic_pose(s.sphere, pose);
    EXPECT_EQ(s.world.step(1e-3).fault, StepFault::none);
  };
  for (int i = 1; i <= 200; ++i) move_to(position - Vec3(0, 0, (0.001 + depth) * i / 200.0));
  position = s.world.body(s.sphere).pose.translation;
  for (int i = 0; i < 200; ++i) move_to(position);  // settle
  double previous = s.world.last_report().reactions.at(0).force.z();
  double jump = 0.0, sum = 0.0;
  const int slide_steps = 800;
  for (int i = 1; i <= slide_steps; ++i) {  // 20 mm at 25 mm/s: across about one coarse cell
    move_to(position + Vec3(0.02 * i / slide_steps, 0, 0));
    const double f = s.world.last_report().reactions.at(0).force.z();
    jump = std::max(jump, std::abs(f - previous));
    sum += f;
    previous = f;
  }
  const double mean = sum / slide_steps;
  EXPECT_GT(mean, 0.0);
  return jump / mean;
}

TEST(ContactCoarse, SlidingForceIsContinuousAndSmootherWithBarycentricWeights) {
  const double weighted = sliding_force_jump(true);
  const double unweighted = sliding_force_jump(false);
  // Stated bound: no step changes the force by more than 35% of its mean while sliding 25 um per
  // step across 17 mm cells (measured: 25% weighted; see docs/contact-surface.md).
  EXPECT_LT(weighted, 0.35);
  EXPECT_LT(weighted, unweighted);
  RecordProperty("weighted_jump", std::to_string(weighted));
  RecordProperty("unweighted_jump", std::to_string(unweighted));
}

// A cube resting on a soft membrane clamped at its rim: the mean over the last 200 steps of a
// 0.6 s run of the step's largest overlap.
double resting_overlap(ContactMethod method, double density) {
  World world;
  world.settings().contact.method = method;
  world.settings().contact.finishing_projection = true;
  world.settings().contact.penalty_stiffness = 2e3;
  world.settings().contact.penalty_damping = 2.0;
  const auto membrane_mesh = make_membrane_mesh({.width = 0.2, .depth = 0.2, .thickness = 0.01, .nx = 10, .ny = 10});
  BodyDef membrane{.name = "membrane", .mesh = membrane_mesh, .material = tissue(2e4)};
  for (int v = 0; v < membrane_mesh->vertex_count(); ++v) {
    const Vec3& p = membrane_mesh->rest_positions()[static_cast<size_t>(v)];
    if (std::abs(p.x()) > 0.0999 || std::abs(p.y()) > 0.0999) membrane.fixed_vertices.push_back(v);
  }
  Material cube_material = tissue(1e5);
  cube_material.density = density;
  BodyDef cube{.name = "cube", .mesh = make_box_mesh({Vec3(0.05, 0.05, 0.05), 2, 2, 2}), .material = cube_material};
  cube.pose.translation = Vec3(0.003, -0.002, 0.005 + 0.025 + 0.0005);
  world.add_body(membrane);
  world.add_body(cube);
  double overlap = 0.0;
  for (int i = 0; i < 600; ++i) {
    const StepReport& r = world.step(1e-3);
    EXPECT_EQ(r.fault, StepFault::none);
    if (i >= 400) overlap += r.max_residual_overlap / 200.0;
  }
  return overlap;
}

TEST(ContactCoarse, PenaltyOverlapGrowsWithWeightButTheContactSurfaceStaysClosed) {
  const double penalty_light = resting_overlap(ContactMethod::penalty, 250.0);
  const double penalty_heavy = resting_overlap(ContactMethod::penalty, 4000.0);
  const double surface_heavy = resting_overlap(ContactMethod::contact_surface, 4000.0);
  EXPECT_GT(penalty_light, 0.0);
  EXPECT_GT(penalty_heavy, 2.0 * penalty_light);
  EXPECT_LT(surface_heavy, 1e-9);
  EXPECT_LT(surface_heavy, 0.01 * penalty_heavy);
}

}  // namespace
}  // namespace pliant
