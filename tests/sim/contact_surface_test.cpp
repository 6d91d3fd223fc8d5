// The contact-surface response (paper sections 4.3-4.5) against analytic references
// (algorithms.md section 6): the series-spring split of an overlap, invariance to scaling both
// moduli, statics on a rigid floor, the paper's Fig. 2 case, Newton's third law and Coulomb
// friction on an incline.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/mesh/box_mesh.h"
#include "sim/world.h"

namespace pliant {
namespace {

constexpr double kPi = 3.14159265358979323846;

Material soft(double young) {
  Material m;
  m.young_modulus = young;
  m.poisson_ratio = 0.3;
  m.density = 1000.0;
  m.mass_damping = 0.0;
  m.stiffness_damping = 0.0;
  return m;
}

// Two blocks of the same mesh: N below with its top face at z = +delta/2, M above with its
// bottom face at z = -delta/2 (overlap delta). M is N turned 180 degrees about x, so the two
// layers that touch are congruent and respond identically to the same displacement.
struct TwoBlocks {
  World world{WorldSettings{.gravity = Vec3::Zero()}};
  BodyId upper, lower;
  double delta = 0.0;
  double height = 0.04;
};

void make_two_blocks(TwoBlocks& s, double e_upper, double e_lower, double delta, int iterations, bool projection,
                     const Vec3& upper_offset = Vec3::Zero()) {
  s.delta = delta;
  s.world.settings().contact.binary_search_iterations = iterations;
  s.world.settings().contact.finishing_projection = projection;
  s.world.settings().contact.friction = false;
  const auto mesh = make_box_mesh({Vec3(0.2, 0.2, s.height), 8, 8, 2});
  BodyDef lower{.name = "lower", .mesh = mesh, .material = soft(e_lower)};
  lower.pose.translation = Vec3(0, 0, delta / 2 - s.height / 2);
  BodyDef upper{.name = "upper", .mesh = mesh, .material = soft(e_upper)};
  upper.pose.translation = Vec3(0, 0, s.height / 2 - delta / 2) + upper_offset;
  upper.pose.rotation = Quat(Eigen::AngleAxisd(kPi, Vec3::UnitX()));
  s.lower = s.world.add_body(lower);
  s.upper = s.world.add_body(upper);
}

// Mean z of the vertices of a body that started at height z0 (the contact face), away from the
// rim: the rim of each face lies in the other block's side planes, where penetration directions
// turn sideways; two cells in, their influence has faded.
double mean_face_height(const World& world, BodyId id, double z0) {
  const Body& b = world.body(id);
  double sum = 0.0;
  int n = 0;
  const auto& rest = b.mesh->rest_positions();
  for (size_t v = 0; v < rest.size(); ++v) {
    const Vec3 placed = b.pose.apply(rest[v]);
    if (std::abs(placed.z() - z0) > 1e-9) continue;
    if (std::abs(placed.x()) > 0.051 || std::abs(placed.y()) > 0.051) continue;
    sum += b.positions[v].z();
    ++n;
  }
  EXPECT_GT(n, 0);
  return sum / n;
}

TEST(ContactSurface, EqualBlocksMeetAtTheMidplane) {
  const double delta = 0.002;
  for (int iterations : {3, 4, 5}) {
    TwoBlocks s;
    make_two_blocks(s, 1e4, 1e4, delta, iterations, false);
    const StepReport& r = s.world.step(1e-3);
    ASSERT_GT(r.colliding_vertices, 0);
    const double resolution = delta / std::ldexp(1.0, iterations + 1);
    EXPECT_NEAR(mean_face_height(s.world, s.upper, -delta / 2), 0.0, resolution + 1e-12) << iterations;
    EXPECT_NEAR(mean_face_height(s.world, s.lower, +delta / 2), 0.0, resolution + 1e-12) << iterations;
  }
}

TEST(ContactSurface, StiffnessRatioThreeSplitsOneToThree) {
  const double delta = 0.002;
  // The softer block takes 3/4 of the overlap (series springs: delta kB / (kA + kB)).
  {
    TwoBlocks s;
    make_two_blocks(s, 3e4, 1e4, delta, 6, false);
    s.world.step(1e-3);
    const double upper_moved = mean_face_height(s.world, s.upper, -delta / 2) + delta / 2;
    const double lower_moved = delta / 2 - mean_face_height(s.world, s.lower, +delta / 2);
    EXPECT_NEAR(upper_moved, 0.25 * delta, 0.03 * delta);
    EXPECT_NEAR(lower_moved, 0.75 * delta, 0.03 * delta);
  }
  // Ratio 1/3 mirrors it.
  {
    TwoBlocks s;
    make_two_blocks(s, 1e4, 3e4, delta, 6, false);
    s.world.step(1e-3);
    const double upper_moved = mean_face_height(s.world, s.upper, -delta / 2) + delta / 2;
    const double lower_moved = delta / 2 - mean_face_height(s.world, s.lower, +delta / 2);
    EXPECT_NEAR(upper_moved, 0.75 * delta, 0.03 * delta);
    EXPECT_NEAR(lower_moved, 0.25 * delta, 0.03 * delta);
  }
}

// Scaling both moduli by 10 scales every pressure by 10, so every comparison of the binary search
// comes out the same: the contact surface stays where it was (there is no parameter to tune).
// The upper block is narrower, so no vertex sits in the other block's side planes (where a
// comparison of two near-zero pressures would be decided by round-off).
void run_narrow_on_wide(World& world, double e_upper, double e_lower, BodyId& upper_id, BodyId& lower_id,
                        int lower_cells = 4) {
  world.settings().contact.binary_search_iterations = 5;
  world.settings().contact.friction = false;
  BodyDef lower{.name = "lower", .mesh = make_box_mesh({Vec3(0.1, 0.1, 0.04), lower_cells, lower_cells, 2}),
                .material = soft(e_lower)};
  lower.pose.translation = Vec3(0, 0, 0.001 - 0.02);
  BodyDef upper{.name = "upper", .mesh = make_box_mesh({Vec3(0.06, 0.06, 0.03), 3, 3, 2}), .material = soft(e_upper)};
  upper.pose.translation = Vec3(0.003, -0.002, 0.015 - 0.001);
  lower_id = world.add_body(lower);
  upper_id = world.add_body(upper);
  world.step(1e-3);
}

// Beyond the paper: a secant step on the search's samples represents stiffness ratios the
// bisection cannot (after n iterations it leaves the stiffer side at least delta / 2^(n+1)).
// The upper block is shifted sideways by (1.3, 0.7) mm. In the aligned fixture every contact-face
// vertex lies exactly on a vertical edge of the other block, where the inside test is decided by
// round-off: after a8871d4 changed the first step's positions by ~1e-17 m, 3 of the 25 measured
// soft-face vertices went undetected, so each had s = delta / 2 (Eq. 1's +1) instead of delta and
// the soft side's mean fell to 0.939 delta (this test failed in session 2; a 1e-15 m shift of the
// block passes it again). Shifted, no vertex lies on an edge or face of the other block.
TEST(ContactSurface, SecantRefinementRepresentsExtremeStiffnessRatios) {
  const double delta = 0.002;
  const Vec3 offset(0.0013, 0.0007, 0.0);
  auto split = [&](double ratio, bool secant, int iterations) {
    TwoBlocks s;
    make_two_blocks(s, ratio * 1e4, 1e4, delta, iterations, false, offset);
    s.world.settings().contact.secant_refinement = secant;
    s.world.step(1e-3);
    const double upper_moved = mean_face_height(s.world, s.upper, -delta / 2) + delta / 2;
    const double lower_moved = delta / 2 - mean_face_height(s.world, s.lower, +delta / 2);
    return std::make_pair(upper_moved, lower_moved);
  };
  // Ratio 1000: the stiff upper block should take delta / 1001.
  const auto bisection = split(1000.0, false, 4);
  EXPECT_NEAR(bisection.first, delta / 32, 1e-9) << "bisection floor: 1/2^(n+1)";
  const auto secant = split(1000.0, true, 4);
  EXPECT_LT(secant.first, 0.005 * delta);
  // Each vertex refines on its own samples while its neighbours move too, so the estimate need not
  // be exact; the bisection's resolution at n = 4 is 1/32 = 3.1% of delta.
  EXPECT_NEAR(secant.second, delta * 1000.0 / 1001.0, 0.025 * delta);
  // Ratio 3 (a ratio the bisection represents): the secant at n = 4 lands where a bisection at
  // n = 10 (resolution delta / 2048) does on the same meshes. Against the closed form 1:3 the
  // shifted faces differ by a few percent for either method (their vertices no longer face each
  // other; StiffnessRatioThreeSplitsOneToThree checks the closed form on the aligned fixture).
  const auto three = split(3.0, true, 4);
  const auto fine = split(3.0, false, 10);
  EXPECT_NEAR(three.first, fine.first, 0.015 * delta);
  EXPECT_NEAR(three.second, fine.second, 0.015 * delta);
}

TEST(ContactSurface, ScalingBothModuliLeavesTheSurfaceWhereItWas) {
  World a{WorldSettings{.gravity = Vec3::Zero()}}, b{WorldSettings{.gravity = Vec3::Zero()}};
  BodyId au, al, bu, bl;
  run_narrow_on_wide(a, 3e4, 1e4, au, al);
  run_narrow_on_wide(b, 3e5, 1e5, bu, bl);
  ASSERT_GT(a.last_report().colliding_vertices, 0);
  double moved = 0.0;
  for (BodyId id : {au, al}) {
    const auto& pa = a.body(id).positions;
    const auto& pb = b.body(id).positions;
    for (size_t v = 0; v < pa.size(); ++v) {
      EXPECT_NEAR((pa[v] - pb[v]).norm(), 0.0, 1e-9) << v;
      moved = std::max(moved, (pa[v] - a.body(id).pose.apply(a.body(id).mesh->rest_positions()[v])).norm());
    }
  }
  EXPECT_GT(moved, 1e-4) << "the contact must have moved something";
}

TEST(ContactSurface, FinishingProjectionLeavesNoOverlap) {
  const double delta = 0.002;
  TwoBlocks with;
    make_two_blocks(with, 3e4, 1e4, delta, 4, true);
  const StepReport& r = with.world.step(1e-3);
  EXPECT_LT(r.max_residual_overlap, 1e-12);
}

// A block resting on a kinematic floor carries m g through the contact.
TEST(ContactSurface, BlockAtRestOnAFloorCarriesItsWeight) {
  World world;
  world.settings().contact.friction = false;
  world.settings().contact.finishing_projection = true;
  const auto block_mesh = make_box_mesh({Vec3(0.04, 0.04, 0.04), 3, 3, 3});
  Material m = soft(5e4);
  m.mass_damping = 2.0;  // settles within 0.3 s; more drag would hold part of the weight itself
  BodyDef block{.name = "block", .mesh = block_mesh, .material = m};
  block.pose.translation = Vec3(0, 0, 0.02);
  const BodyId block_id = world.add_body(block);
  BodyDef floor{.name = "floor", .mesh = make_box_mesh({Vec3(0.1, 0.1, 0.02), 3, 3, 1}),
                .material = soft(1e6), .motion = BodyMotion::kinematic};
  floor.pose.translation = Vec3(0, 0, -0.01);
  const BodyId floor_id = world.add_body(floor);

  const double weight = world.body(block_id).total_mass() * 9.81;
  for (int i = 0; i < 600; ++i) ASSERT_EQ(world.step(1e-3).fault, StepFault::none);
  const StepReport& r = world.last_report();
  ASSERT_EQ(r.reactions.size(), 1u);
  EXPECT_EQ(r.reactions[0].body, static_cast<int>(floor_id.index));
  // The floor is pushed down by the block's weight.
  EXPECT_NEAR(r.reactions[0].force.z(), -weight, 0.02 * weight);
  EXPECT_NEAR(r.reactions[0].force.head<2>().norm(), 0.0, 0.02 * weight);
  EXPECT_LT(r.max_residual_overlap, 1e-9);
  EXPECT_LT(r.energy.kinetic, 1e-6);
}

// The paper's Fig. 2: a single vertex of one body inside a single coarse triangle of the other.
// Both bodies must move, and the vertex ends in the plane of the displaced triangle.
TEST(ContactSurface, SingleVertexInsideACoarseTriangleMovesBothBodies) {
  for (bool projection : {false, true}) {
    World world{WorldSettings{.gravity = Vec3::Zero()}};
    world.settings().contact.finishing_projection = projection;
    world.settings().contact.friction = false;
    const double delta = 0.002;
    BodyDef coarse{.name = "coarse", .mesh = make_box_mesh({Vec3(0.1, 0.1, 0.05), 1, 1, 1}), .material = soft(1e4)};
    coarse.pose.translation = Vec3(0, 0, -0.025);  // top face at z = 0
    // A small cube balanced on a corner: its lowest vertex pokes delta into the coarse top face,
    // off any vertex or edge of the coarse triangle.
    BodyDef fine{.name = "fine", .mesh = make_box_mesh({Vec3(0.02, 0.02, 0.02), 2, 2, 2}), .material = soft(1e4)};
    const Quat corner_down = Quat::FromTwoVectors(Vec3(-1, -1, -1).normalized(), Vec3(0, 0, -1));
    fine.pose.rotation = corner_down;
    const double half_diagonal = 0.01 * std::sqrt(3.0);
    fine.pose.translation = Vec3(0.02, -0.015, half_diagonal - delta);
    const BodyId coarse_id = world.add_body(coarse);
    const BodyId fine_id = world.add_body(fine);
    const std::vector<Vec3> coarse_before = world.body(coarse_id).positions;
    const std::vector<Vec3> fine_before = world.body(fine_id).positions;

    const StepReport& r = world.step(1e-3);
    ASSERT_EQ(r.colliding_vertices, 1);
    ASSERT_EQ(world.contacts().size(), 1u);
    const VertexContact& c = world.contacts()[0];
    EXPECT_EQ(c.body, static_cast<int>(fine_id.index));
    double coarse_moved = 0.0, fine_moved = 0.0;
    for (size_t v = 0; v < coarse_before.size(); ++v) {
      coarse_moved = std::max(coarse_moved, (world.body(coarse_id).positions[v] - coarse_before[v]).norm());
    }
    for (size_t v = 0; v < fine_before.size(); ++v) {
      fine_moved = std::max(fine_moved, (world.body(fine_id).positions[v] - fine_before[v]).norm());
    }
    EXPECT_GT(coarse_moved, 0.01 * delta) << "the coarse body must take part (deformation region)";
    EXPECT_GT(fine_moved, 0.01 * delta);
    // Signed distance of the vertex above the displaced triangle's plane.
    const Body& n = world.body(coarse_id);
    const auto& tri = n.mesh->surface_triangles()[static_cast<size_t>(c.contact_triangle)];
    const Vec3 normal = n.mesh->triangle_normal(n.positions, c.contact_triangle);
    const double gap = (world.body(fine_id).positions[static_cast<size_t>(c.vertex)] - n.positions[static_cast<size_t>(tri[0])]).dot(normal);
    if (projection) {
      EXPECT_NEAR(gap, 0.0, 1e-12);
    } else {
      // The paper's Eq. 1 gives a non-colliding triangle vertex s = w(-d)/(w+1): with the vertex
      // near the centroid (w ~ 1/3) the triangle can move at most d/4, and the stiff fine corner
      // backs off, so most of the overlap remains: the case the finishing projection is for.
      EXPECT_LT(gap, 0.0);
      EXPECT_GT(gap, -delta);
    }
  }
}

// Newton's third law: the restoring forces each body's own elasticity exerts through the contact
// surface cancel over the pair to the accuracy of the pressure balance, which the paper says holds
// over a larger contact area rather than per vertex. With a coarse lower block (25 mm spacing under
// a 20 mm upper one) its non-colliding deformation-region vertices carry too much; refining the
// lower block brings the two totals together (measured 35% at 4 cells, 3% at 12).
TEST(ContactSurface, ElasticContactForcesCancelAsTheSurfaceIsRefined) {
  auto imbalance = [](int lower_cells) {
    World world{WorldSettings{.gravity = Vec3::Zero()}};
    BodyId upper, lower;
    run_narrow_on_wide(world, 3e4, 1e4, upper, lower, lower_cells);
    const StepReport& r = world.last_report();
    EXPECT_EQ(r.pair_forces.size(), 1u);
    const auto& p = r.pair_forces.at(0);
    const double scale = std::max(p.elastic_on_a.norm(), p.elastic_on_b.norm());
    EXPECT_GT(scale, 0.0);
    EXPECT_LT(p.elastic_on_a.dot(p.elastic_on_b), 0.0);
    // The impulse forces are equal and opposite by construction.
    EXPECT_NEAR((p.force_on_a + p.force_on_b).norm(), 0.0, 1e-12 * std::max(1.0, p.force_on_a.norm()));
    return (p.elastic_on_a + p.elastic_on_b).norm() / scale;
  };
  const double coarse = imbalance(4);
  const double fine = imbalance(12);
  EXPECT_LT(fine, coarse);
  EXPECT_LT(fine, 0.05);
}

// Coulomb friction on an incline: sticks when tan(theta) < mu, else slides with
// a = g (sin(theta) - mu cos(theta)).
struct InclineResult {
  double slope_velocity_early, slope_velocity_late, t_early, t_late, displacement;
};

InclineResult run_incline(double theta, double mu) {
  World world;
  const Vec3 down_slope = Quat(Eigen::AngleAxisd(theta, Vec3::UnitX())) * Vec3(0, -1, 0);
  const Quat tilt(Eigen::AngleAxisd(theta, Vec3::UnitX()));
  Material block_material = soft(1e6);
  block_material.friction = mu;
  block_material.stiffness_damping = 1e-3;
  BodyDef block{.name = "block", .mesh = make_box_mesh({Vec3(0.03, 0.03, 0.03), 2, 2, 2}), .material = block_material};
  block.pose.rotation = tilt;
  block.pose.translation = tilt * Vec3(0, 0, 0.015);
  Material floor_material = soft(1e6);
  floor_material.friction = mu;
  BodyDef floor{.name = "floor", .mesh = make_box_mesh({Vec3(0.5, 0.5, 0.02), 4, 4, 1}), .material = floor_material,
                .motion = BodyMotion::kinematic};
  floor.pose.rotation = tilt;
  floor.pose.translation = tilt * Vec3(0, 0, -0.01);
  const BodyId id = world.add_body(block);
  world.add_body(floor);
  auto centre = [&] {
    const Body& b = world.body(id);
    Vec3 c = Vec3::Zero();
    for (size_t v = 0; v < b.positions.size(); ++v) c += b.masses[v] * b.positions[v];
    return Vec3(c / b.total_mass());
  };
  auto slope_velocity = [&] {
    const Body& b = world.body(id);
    Vec3 p = Vec3::Zero();
    for (size_t v = 0; v < b.positions.size(); ++v) p += b.masses[v] * b.velocities[v];
    return (p / b.total_mass()).dot(down_slope);
  };
  const Vec3 start = centre();
  InclineResult r{};
  const double dt = 1e-3;
  for (int i = 1; i <= 400; ++i) {
    EXPECT_EQ(world.step(dt).fault, StepFault::none);
    if (i == 200) {
      r.slope_velocity_early = slope_velocity();
      r.t_early = world.time();
    }
  }
  r.slope_velocity_late = slope_velocity();
  r.t_late = world.time();
  r.displacement = (centre() - start).dot(down_slope);
  return r;
}

TEST(ContactSurface, CoulombFrictionOnAnIncline) {
  const double g = 9.81;
  // Sticks: tan(20 deg) = 0.36 < 0.6.
  {
    const InclineResult r = run_incline(20.0 * kPi / 180.0, 0.6);
    EXPECT_LT(std::abs(r.displacement), 2e-4) << "block must stick";
  }
  // Slides: tan(35 deg) = 0.70 > 0.3.
  {
    const double theta = 35.0 * kPi / 180.0, mu = 0.3;
    const InclineResult r = run_incline(theta, mu);
    const double expected = g * (std::sin(theta) - mu * std::cos(theta));
    const double measured = (r.slope_velocity_late - r.slope_velocity_early) / (r.t_late - r.t_early);
    EXPECT_NEAR(measured, expected, 0.05 * expected);
  }
}

}  // namespace
}  // namespace pliant
