// The contact-surface search with the model's frozen-rotation query (ContactSettings::
// frozen_rotation_search, docs/contact-surface.md "Speed"), and with reused nearby rotations
// (ContactSettings::search_rotation_tolerance, session 5), against the same step with the exact
// query (a second method), from bit-identical states: two worlds built alike and stepped alike with
// the exact query, then one step each way. After n bisection iterations a vertex's fraction is
// known to 1 / 2^(n+1); a pressure error below that resolution can flip at most the decisions
// taken near the balance, so each vertex may end at most 2 / 2^(n+1) of its displacement from the
// exact search's surface. Displacements are bounded by the step's largest penetration depth.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "sim/mesh/box_mesh.h"
#include "sim/mesh/sphere_mesh.h"
#include "sim/world.h"

namespace pliant {
namespace {

Material tissue(double young, double poisson = 0.3) {
  Material m;
  m.young_modulus = young;
  m.poisson_ratio = poisson;
  m.density = 1000.0;
  m.mass_damping = 1.0;
  m.stiffness_damping = 0.01;
  return m;
}

std::vector<int> base_vertices(const TetMesh& mesh, double z) {
  std::vector<int> out;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    if (std::abs(mesh.rest_positions()[static_cast<size_t>(v)].z() - z) < 1e-9) out.push_back(v);
  }
  return out;
}

// A deformable block (40 x 40 x 20 mm) dropped 1 mm onto a 3x softer block fixed at its base:
// both sides search (the stability harness's block case, off centre).
void add_block_on_block(World& world) {
  const auto lower_mesh = make_box_mesh({Vec3(0.08, 0.08, 0.04), 6, 6, 3});
  BodyDef lower{.name = "lower", .mesh = lower_mesh, .material = tissue(1e4)};
  lower.pose.translation = Vec3(0, 0, -0.02);
  lower.fixed_vertices = base_vertices(*lower_mesh, -0.02);
  const auto upper_mesh = make_box_mesh({Vec3(0.04, 0.04, 0.02), 4, 4, 2});
  BodyDef upper{.name = "upper", .mesh = upper_mesh, .material = tissue(3e4)};
  upper.pose.translation = Vec3(0.0013, 0.0007, 0.011);
  world.add_body(lower);
  world.add_body(upper);
}

// A kinematic 10 mm sphere pressed into a nu 0.45 block at 0.1 m/s (the probe scene's case): the
// tissue faces an immovable body, so nothing searches, and the final evaluation is exact.
void add_probe(World& world) {
  const auto block_mesh = make_box_mesh({Vec3(0.1, 0.1, 0.04), 9, 9, 3});
  BodyDef block{.name = "block", .mesh = block_mesh, .material = tissue(5e3, 0.45)};
  block.pose.translation = Vec3(0, 0, -0.02);
  block.fixed_vertices = base_vertices(*block_mesh, -0.02);
  BodyDef sphere{.name = "sphere", .mesh = make_sphere_mesh({.radius = 0.01, .surface_vertices = 73, .shells = 2}),
                 .material = tissue(1e6), .motion = BodyMotion::kinematic};
  sphere.pose.translation = Vec3(0.004, -0.003, 0.0101);
  world.add_body(block);
  world.add_body(sphere);
}

struct Comparison {
  double max_difference = 0.0;  ///< m, largest vertex position difference after the step
  double bound = 0.0;           ///< m, 2 / 2^(n+1) of the step's largest penetration depth
  double elastic_difference = 0.0;  ///< relative difference of the first pair's elastic forces
};

void frozen_search(ContactSettings& contact) { contact.frozen_rotation_search = true; }

// Steps two identical worlds `steps` times with the exact query, then once more, world b with the
// search `approximate` sets (default: the frozen-rotation query), world a with `reference`'s (if
// given; else exact), and compares.
Comparison compare_after(void (*build)(World&), int steps, bool probe,
                         void (*approximate)(ContactSettings&) = frozen_search,
                         void (*reference)(ContactSettings&) = nullptr) {
  World a, b;
  for (World* w : {&a, &b}) {
    w->settings().contact.finishing_projection = false;  // the paper's search alone
    w->settings().contact.frozen_rotation_search = false;
    w->settings().contact.search_rotation_tolerance = 0.0;  // exact (the nearby query is approximate)
    w->settings().contact.linearised_search = false;         // every iteration asks the query
    // The paper's response alone, also without held forces (the default since session 4): they
    // hold a resting dent closed (penetration 1.8e-6 m after 60 steps of the block case), and at
    // such overlaps both searches pick the same sides bit for bit, so nothing would be compared.
    w->settings().contact.held_force_fraction = 0.0;
    build(*w);
  }
  const BodyId sphere = probe ? a.body_id(1) : BodyId{};
  Pose pose = probe ? a.body(sphere).pose : Pose{};
  for (int s = 0; s <= steps; ++s) {
    if (s == steps) {
      approximate(b.settings().contact);
      if (reference != nullptr) reference(a.settings().contact);
    }
    if (probe) {
      pose.translation.z() -= 1e-4;  // 0.1 m/s at dt 1 ms
      a.set_kinematic_pose(sphere, pose);
      b.set_kinematic_pose(b.body_id(1), pose);
    }
    a.step(1e-3);
    b.step(1e-3);
  }
  Comparison c;
  const int n = a.settings().contact.binary_search_iterations;
  c.bound = 2.0 * std::ldexp(1.0, -(n + 1)) * a.last_report().max_penetration_before;
  for (int i = 0; i < 2; ++i) {
    const auto& xa = a.body(a.body_id(i)).positions;
    const auto& xb = b.body(b.body_id(i)).positions;
    for (size_t v = 0; v < xa.size(); ++v) c.max_difference = std::max(c.max_difference, (xa[v] - xb[v]).norm());
  }
  const auto& pa = a.last_report().pair_forces;
  const auto& pb = b.last_report().pair_forces;
  if (!pa.empty() && !pb.empty()) {
    const double scale = pa[0].elastic_on_a.norm() + pa[0].elastic_on_b.norm();
    EXPECT_GT(scale, 0.0);
    c.elastic_difference = ((pa[0].elastic_on_a - pb[0].elastic_on_a).norm() +
                            (pa[0].elastic_on_b - pb[0].elastic_on_b).norm()) / scale;
  }
  EXPECT_GT(a.last_report().colliding_vertices, 0) << steps;
  std::printf("after %d steps: max difference %.3g m (bound %.3g m), elastic force %.3g relative\n", steps,
              c.max_difference, c.bound, c.elastic_difference);
  return c;
}

TEST(ContactFrozenRotation, BlockOnBlockSurfaceWithinOneBisectionStepOfTheExactSearch) {
  double largest_elastic_difference = 0.0;
  for (int steps : {20, 60, 200}) {  // landing, settling, resting
    const Comparison c = compare_after(add_block_on_block, steps, false);
    EXPECT_LE(c.max_difference, c.bound) << steps;
    largest_elastic_difference = std::max(largest_elastic_difference, c.elastic_difference);
  }
  // The final evaluation is exact (session 4): the reported elastic forces differ only where the
  // frozen search ended at other positions (after 60 steps: measured 2.1e-4 relative).
  EXPECT_GT(largest_elastic_difference, 0.0) << "the frozen query was never taken";
  EXPECT_LT(largest_elastic_difference, 0.03);
}

TEST(ContactFrozenRotation, ProbeSurfaceIsTheExactSearchs) {
  for (int steps : {30, 100}) {  // 3 mm and 10 mm in
    const Comparison c = compare_after(add_probe, steps, true);
    // Nothing searches against an immovable probe: the same surface, bit for bit; and since
    // session 4 the final evaluation (reported elastic force, held-force cap) is always exact, so
    // the reported force is the exact search's, bit for bit, too (it was 0.15% / 0.35% off).
    EXPECT_EQ(c.max_difference, 0.0) << steps;
    EXPECT_EQ(c.elastic_difference, 0.0) << steps;
  }
}

// Session 5: the search reusing rotations extracted earlier (the last step's exact queries: the
// worlds ran exact until the compared step) where the tet's F moved by at most the library's
// default tolerance (ContactSettings::search_rotation_tolerance). Its force error (rotation error
// about |dF| / 2 <= 5e-4, times the stress) is below the search's resolution, so the same bound as
// the frozen search's holds: each vertex within 2 / 2^(n+1) of its displacement.
void nearby_search(ContactSettings& contact) { contact.search_rotation_tolerance = ContactSettings{}.search_rotation_tolerance; }

// Ten times the tolerance: large enough that the reuse changes a search decision here (so the
// comparison sees that it was taken), and still within the bound.
void coarse_nearby_search(ContactSettings& contact) {
  contact.search_rotation_tolerance = 10.0 * ContactSettings{}.search_rotation_tolerance;
}

TEST(ContactNearbyRotation, BlockOnBlockSurfaceWithinOneBisectionStepOfTheExactSearch) {
  ASSERT_GT(ContactSettings{}.search_rotation_tolerance, 0.0);
  for (auto* search : {nearby_search, coarse_nearby_search}) {
    double largest_difference = 0.0;
    for (int steps : {20, 60, 200}) {  // landing, settling, resting
      const Comparison c = compare_after(add_block_on_block, steps, false, search);
      EXPECT_LE(c.max_difference, c.bound) << steps;
      largest_difference = std::max(largest_difference, c.max_difference + c.elastic_difference);
      // The final evaluation is exact: the elastic forces differ only where the search ended elsewhere.
      EXPECT_LT(c.elastic_difference, 0.03) << steps;
    }
    // At the default tolerance every decision here is the exact search's (measured: bit for bit).
    if (search == coarse_nearby_search) {
      EXPECT_GT(largest_difference, 0.0) << "no rotation was reused";
    }
  }
}

TEST(ContactNearbyRotation, ProbeSurfaceIsTheExactSearchs) {
  for (int steps : {30, 100}) {  // nothing searches against an immovable probe: bit for bit
    const Comparison c = compare_after(add_probe, steps, true, nearby_search);
    EXPECT_EQ(c.max_difference, 0.0) << steps;
    EXPECT_EQ(c.elastic_difference, 0.0) << steps;
  }
}

// Session 6: the linearised search (ContactSettings::linearised_search): the first iteration asks
// the query (here exact), the later ones take f(x1) - K' (x - x1) with the K' of the step's
// implicit solve (rotations of x_n, reused within 1e-3 rad). Its error is the frozen-rotation
// law's (the gate keeps the moves below h / 2^(n+1)) plus K's rotation lag, below the search's
// resolution: the frozen search's bound, each vertex within 2 / 2^(n+1) of its displacement.
void linearised_search(ContactSettings& contact) { contact.linearised_search = true; }

// With the library's default nearby rotations (the default search): since session 8 they are
// used only by bodies the gates refuse; the first iteration of a linearised body is exact.
void linearised_nearby_search(ContactSettings& contact) {
  contact.linearised_search = true;
  contact.search_rotation_tolerance = ContactSettings{}.search_rotation_tolerance;
}

TEST(ContactLinearisedSearch, BlockOnBlockSurfaceWithinOneBisectionStepOfTheExactSearch) {
  for (auto* search : {linearised_search, linearised_nearby_search}) {
    double largest_difference = 0.0;
    for (int steps : {20, 60, 200}) {  // landing, settling, resting
      const Comparison c = compare_after(add_block_on_block, steps, false, search);
      EXPECT_LE(c.max_difference, c.bound) << steps;
      largest_difference = std::max(largest_difference, c.max_difference);
      // The final evaluation is exact: the elastic forces differ only where the search ended elsewhere.
      EXPECT_LT(c.elastic_difference, 0.03) << steps;
    }
    // Measured: the same surface at 20 and 200 steps' end, 6.8e-6 m apart at 60 (a decision flipped).
    EXPECT_GT(largest_difference, 0.0) << "the linearisation was never taken";
  }
}

// Session 8: the first iteration, where the linearised search takes f(x1), is the exact query even
// with search_rotation_tolerance's reuse on (a reused rotation's error there is carried through
// every later iteration; with it the free stack's churn was measured on one unlucky sample). So a
// step where every body linearises is the same with reuse on and off, bit for bit.
TEST(ContactLinearisedSearch, LinearisationPointIsTheExactQueryWithRotationReuseOn) {
  for (int steps : {20, 60, 200}) {  // landing, settling, resting
    const Comparison c = compare_after(add_block_on_block, steps, false, linearised_nearby_search, linearised_search);
    EXPECT_EQ(c.max_difference, 0.0) << steps;
    EXPECT_EQ(c.elastic_difference, 0.0) << steps;
  }
}

TEST(ContactLinearisedSearch, ProbeSurfaceIsTheExactSearchs) {
  for (int steps : {30, 100}) {  // nothing searches against an immovable probe: bit for bit
    const Comparison c = compare_after(add_probe, steps, true, linearised_search);
    EXPECT_EQ(c.max_difference, 0.0) << steps;
    EXPECT_EQ(c.elastic_difference, 0.0) << steps;
  }
}

// Session 7: the final evaluation linearised too (ContactSettings::linearised_final_evaluation,
// without held forces: its forces are only reported), against the same linearised search with the
// exact final evaluation. The search is the same, so every position is bit for bit; the reported
// elastic forces differ by the linearisation's error over the moves since the first evaluation:
// the K' product's first-order law holds to 0.016 of the force change (CorotationalLocalQuery.
// StiffnessProductIsTheExactForceChangeToFirstOrder's bound), and the moves since x1 (<= 7/16 of
// |s| plus the secant step, within [0, 1] of |s|) change the force by at most the whole dent's,
// under half the elastic force here (the dent is a fraction of the pre-stress): bound 0.016 / 2.
void linearised_exact_final(ContactSettings& contact) {
  contact.linearised_search = true;
  contact.linearised_final_evaluation = false;
}

void linearised_final(ContactSettings& contact) {
  contact.linearised_search = true;
  contact.linearised_final_evaluation = true;
}

TEST(ContactLinearisedFinalEvaluation, SameStepAndElasticForcesWithinTheLinearisationBound) {
  ASSERT_TRUE(ContactSettings{}.linearised_final_evaluation);
  double largest = 0.0;
  for (int steps : {20, 60, 200}) {  // landing, settling, resting
    const Comparison c = compare_after(add_block_on_block, steps, false, linearised_final, linearised_exact_final);
    EXPECT_EQ(c.max_difference, 0.0) << steps;  // only reported forces change
    EXPECT_LE(c.elastic_difference, 0.008) << steps;
    largest = std::max(largest, c.elastic_difference);
  }
  EXPECT_GT(largest, 0.0) << "the final evaluation was never linearised";
}

// With held forces the final forces cap the next step's external force: always exact, bit for bit.
void held_linearised_final(ContactSettings& contact) {
  linearised_final(contact);
  contact.held_force_fraction = 1.0;
}

void held_linearised_exact_final(ContactSettings& contact) {
  linearised_exact_final(contact);
  contact.held_force_fraction = 1.0;
}

TEST(ContactLinearisedFinalEvaluation, ExactWithHeldForces) {
  for (int steps : {20, 60}) {
    const Comparison c =
        compare_after(add_block_on_block, steps, false, held_linearised_final, held_linearised_exact_final);
    EXPECT_EQ(c.max_difference, 0.0) << steps;
    EXPECT_EQ(c.elastic_difference, 0.0) << steps;
  }
}

// Session 21: with held forces, the opt-in gate (ContactSettings::held_linearised_final_strain)
// linearises the final evaluation where the moves since x1 pass it. The step's positions are the
// same (the held forces act in the next integration); the forces the held-force cap and the report
// read are within session 7's linearisation bound (0.016 / 2, above).
void held_gated_linearised_final(ContactSettings& contact) {
  held_linearised_final(contact);
  contact.held_linearised_final_strain = 3e-3;  // what three_cubes.json ships
}

TEST(ContactLinearisedFinalEvaluation, HeldForcesUnderTheOptInGateWithinTheLinearisationBound) {
  ASSERT_EQ(ContactSettings{}.held_linearised_final_strain, 0.0);  // exact by default (the test above)
  double largest = 0.0;
  for (int steps : {20, 60, 200}) {  // landing, settling, resting
    const Comparison c =
        compare_after(add_block_on_block, steps, false, held_gated_linearised_final, held_linearised_exact_final);
    EXPECT_EQ(c.max_difference, 0.0) << steps;
    EXPECT_LE(c.elastic_difference, 0.008) << steps;
    largest = std::max(largest, c.elastic_difference);
  }
  EXPECT_GT(largest, 0.0) << "the final evaluation was never linearised";
}

}  // namespace
}  // namespace pliant
