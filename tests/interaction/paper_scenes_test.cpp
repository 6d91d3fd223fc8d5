// The paper's four experiments as shipped scenes (assets/scenes/paper/): sizes within 5% of the
// paper's (Spillmann & Teschner, Sec. 5), counting every body; the two small scenes run a few
// steps with both contact methods: free fall until they touch (closed form), the squeezed sphere
// pushed out, every step finite.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "interaction/scene/scene.h"
#include "interaction/scene/scene_runner.h"
#include "sim/input_error.h"
#include "sim/mesh/cylinder_mesh.h"
#include "sim/mesh/sphere_mesh.h"

namespace pliant {
namespace {

std::string paper_scene(const std::string& name) {
  return std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/" + name + ".json";
}

struct Counts {
  long vertices = 0;
  long surface_triangles = 0;
};

Counts count(const World& world) {
  Counts c;
  for (const Body* b : world.bodies()) {
    if (b == nullptr) continue;
    c.vertices += b->mesh->vertex_count();
    c.surface_triangles += b->mesh->surface_triangle_count();
  }
  return c;
}

struct PaperSize {
  const char* scene;
  long vertices;
  long surface_triangles;
};

class PaperSceneSize : public ::testing::TestWithParam<PaperSize> {};

TEST_P(PaperSceneSize, WithinFivePercentOfThePaper) {
  const PaperSize& p = GetParam();
  const Scene scene = load_scene(paper_scene(p.scene));
  EXPECT_EQ(scene.name, p.scene);
  const SceneInstance instance = instantiate_scene(scene);
  const Counts c = count(*instance.world);
  EXPECT_NEAR(static_cast<double>(c.vertices), static_cast<double>(p.vertices),
              0.05 * static_cast<double>(p.vertices));
  EXPECT_NEAR(static_cast<double>(c.surface_triangles), static_cast<double>(p.surface_triangles),
              0.05 * static_cast<double>(p.surface_triangles));
}

// Paper, Sec. 5: Fig. 7 (323 / 624), Fig. 8 (95 / 166), Fig. 9 (16030 / 27116), Fig. 10 (2178 / 4320).
INSTANTIATE_TEST_SUITE_P(Paper, PaperSceneSize,
                         ::testing::Values(PaperSize{"three_cubes", 323, 624},
                                           PaperSize{"sphere_squeeze", 95, 166},
                                           PaperSize{"fruit_dish", 16030, 27116},
                                           PaperSize{"membrane_stack", 2178, 4320}),
                         [](const auto& info) { return std::string(info.param.scene); });

TEST(PaperScenes, ExactSizesWhereThePaperCountsAreReachable) {
  // Three 2x2x2-cell cubes on a 10x10x1-cell membrane and nine such membranes hit the paper exactly.
  EXPECT_EQ(count(*instantiate_scene(load_scene(paper_scene("three_cubes"))).world).vertices, 323);
  EXPECT_EQ(count(*instantiate_scene(load_scene(paper_scene("three_cubes"))).world).surface_triangles, 624);
  EXPECT_EQ(count(*instantiate_scene(load_scene(paper_scene("membrane_stack"))).world).vertices, 2178);
  EXPECT_EQ(count(*instantiate_scene(load_scene(paper_scene("membrane_stack"))).world).surface_triangles,
            4320);
}

// Mass-weighted mean height of a body (m).
double centre_height(const Body& b) {
  double m = 0.0, mz = 0.0;
  for (int v = 0; v < b.vertex_count(); ++v) {
    m += b.masses[static_cast<size_t>(v)];
    mz += b.masses[static_cast<size_t>(v)] * b.positions[static_cast<size_t>(v)].z();
  }
  return mz / m;
}

// The contact method is the parameter: "surface" or "penalty".
class ThreeCubesRun : public ::testing::TestWithParam<const char*> {};
class SphereSqueezeRun : public ::testing::TestWithParam<const char*> {};

Scene small_scene(const char* name, const char* method) {
  Scene scene = load_scene(paper_scene(name));
  scene.world.contact.method = contact_method_from_string(method);
  return scene;
}

// Three cubes: the heavy cube falls freely for 10 mm, then lands; every step finite.
TEST_P(ThreeCubesRun, FallFreelyThenLandFinite) {
  const Scene scene = small_scene("three_cubes", GetParam());
  SceneRunner runner(scene);
  const Body& heavy = runner.world().body(runner.instance().bodies.back());
  const double z0 = centre_height(heavy);
  // Before anything touches, the centre falls as 1/2 g t^2 (15% allowed for mass damping and
  // implicit Euler's one-step lead, (n + 1) / n = 8% at n = 12).
  const long free_steps = 12;  // 12 ms: 0.7 mm of fall, less than the 10 mm gap
  for (long i = 0; i < free_steps; ++i) ASSERT_TRUE(runner.tick()) << runner.fault();
  const double t = static_cast<double>(free_steps) * scene.time_step;
  EXPECT_NEAR(z0 - centre_height(heavy), 0.5 * 9.81 * t * t, 0.15 * 0.5 * 9.81 * t * t);

  int colliding_max = 0;
  double residual_max = 0.0;
  for (long i = 0; i < 60; ++i) {  // lands at about 45 ms
    ASSERT_TRUE(runner.tick()) << runner.fault();
    ASSERT_TRUE(runner.report().all_finite);
    colliding_max = std::max(colliding_max, runner.report().colliding_vertices);
    residual_max = std::max(residual_max, runner.report().max_residual_overlap);
  }
  EXPECT_GT(colliding_max, 0) << "the cubes never landed";
  // Finishing projection (on in the shipped scenes) leaves no overlap beyond round-off.
  if (std::string(GetParam()) == "surface") {
    EXPECT_LT(residual_max, 1e-6);
  }
}

// Sphere squeeze: the sphere starts 5 mm inside each kinematic cuboid and is pushed out: the
// contact surface leaves no overlap, the penalty springs a smaller one than at the start.
TEST_P(SphereSqueezeRun, IsPushedOutFinite) {
  SceneRunner runner(small_scene("sphere_squeeze", GetParam()));
  ASSERT_TRUE(runner.tick()) << runner.fault();
  const double initial = runner.report().max_penetration_before;
  EXPECT_NEAR(initial, 0.005, 0.001);  // 5 mm by construction, less where no vertex sits on the axis
  double residual_max = 0.0;
  for (long i = 0; i < 80; ++i) {
    ASSERT_TRUE(runner.tick()) << runner.fault();
    ASSERT_TRUE(runner.report().all_finite);
    ASSERT_GT(runner.report().colliding_vertices, 0);
    residual_max = std::max(residual_max, runner.report().max_residual_overlap);
  }
  if (std::string(GetParam()) == "surface") {
    EXPECT_LT(residual_max, 1e-6);
  } else {
    EXPECT_GT(runner.report().max_residual_overlap, 0.0);
    EXPECT_LT(runner.report().max_residual_overlap, 0.5 * initial);
  }
}

INSTANTIATE_TEST_SUITE_P(Paper, ThreeCubesRun, ::testing::Values("surface", "penalty"),
                         [](const auto& info) { return std::string(info.param); });
INSTANTIATE_TEST_SUITE_P(Paper, SphereSqueezeRun, ::testing::Values("surface", "penalty"),
                         [](const auto& info) { return std::string(info.param); });

// A corner of the fruit dish: four fruits of the bottom layer and the one of the second layer that
// falls into the pocket between them (a pile), in the kinematic dish, contact surface.
Scene fruit_pile() {
  Scene scene = load_scene(paper_scene("fruit_dish"));
  std::vector<BodyDef> kept;
  for (const BodyDef& b : scene.bodies) {
    if (b.motion == BodyMotion::kinematic || b.name == "fruit0" || b.name == "fruit1" || b.name == "fruit6" ||
        b.name == "fruit7" || b.name == "fruit36") {
      kept.push_back(b);
    }
  }
  scene.bodies = kept;
  return scene;
}

// Sleeping never makes a body float or sink: every fruit of the pile run with sleeping on ends at
// the centre height of the same run with sleeping off (the reference), within 2 mm (twice the
// default rest ball; the dish scene's own ball is 2 mm since session 5), while fruits fall asleep on
// the way. Without held contact forces, resting on the contact
// surface kept the contact vertices' stored velocities far above the rest speed (the search dents,
// the implicit step springs back: docs/experiments.md, "Resting motion"), so the old fastest-vertex
// criterion could put none of them to sleep. With held contact forces at full strength (the library
// default since session 4) that pumping is gone: the resting contact vertices' stored speed must
// stay below the rest speed. (Measured: held off, one fruit sleeps at 1.0 s and is woken again, and
// contact vertices move at 5-130 mm/s; held 0.8, two sleep by 1.5 s; held 1 (default), 3 of 5 asleep
// at 1.5 s and contact vertices at 0.15 mm/s; session 5, the scene's 2 mm ball and the non-spreading
// wake rule: 4 of 5 asleep at most, 3 at 1.5 s.)
// The pile run with sleeping on (`on`) and off side by side for 1.5 s; every fruit ends at the
// sleeping-off run's centre height within 2 mm.
struct PileRun {
  int asleep_max = 0, asleep_at_end = 0;
  double contact_vertex_speed_max = 0.0;  ///< m/s, stored velocity of contact vertices at rest (sleep off)
};
PileRun run_pile_against_awake(const Scene& on) {
  PileRun result;
  Scene off = on;
  off.world.sleep.enabled = false;
  SceneRunner run_on(on), run_off(off);
  const long steps = 1500;  // 1.5 s: the top fruit lands at about 0.1 s; they sleep at 1-1.5 s
  for (long i = 0; i < steps; ++i) {
    EXPECT_TRUE(run_on.tick()) << run_on.fault();
    EXPECT_TRUE(run_off.tick()) << run_off.fault();
    if (!run_on.report().all_finite || !run_off.report().all_finite) return result;
    result.asleep_at_end = run_on.report().sleeping_bodies;
    result.asleep_max = std::max(result.asleep_max, result.asleep_at_end);
    if (i >= steps - 100) {
      for (const VertexContact& c : run_off.world().contacts()) {
        const Body* b = run_off.world().bodies()[static_cast<size_t>(c.body)];
        if (!b->is_kinematic()) {
          result.contact_vertex_speed_max =
              std::max(result.contact_vertex_speed_max, b->velocities[static_cast<size_t>(c.vertex)].norm());
        }
      }
    }
  }
  const double tolerance = 0.002;  // m
  for (size_t i = 0; i < on.bodies.size(); ++i) {
    const Body& a = *run_on.world().bodies()[i];
    if (a.is_kinematic()) continue;
    const Body& b = *run_off.world().bodies()[i];
    EXPECT_NEAR(centre_height(a), centre_height(b), tolerance) << a.name << (a.is_sleeping() ? " (asleep)" : "");
  }
  return result;
}

TEST(PaperScenes, FruitPileSleepsAtTheHeightsItRestsAtAwake) {
  Scene on = fruit_pile();
  ASSERT_EQ(on.bodies.size(), 10u);
  ASSERT_TRUE(on.world.sleep.enabled);  // the scene's default
  on.world.sleep.wake_on_centre_motion = false;  // the library's default wake rule (the dish ships the centre rule)
  const auto [asleep_max, asleep_at_end, contact_vertex_speed_max] = run_pile_against_awake(on);
  EXPECT_GE(asleep_max, 1) << "no fruit ever fell asleep";
  // Held contact forces hold the dents: no stored motion at resting contacts (docs/contact-surface.md).
  EXPECT_LT(contact_vertex_speed_max, on.world.sleep.speed);
  std::printf("fruit pile: %d of 5 asleep at most, %d at 1.5 s; contact vertices' stored speed up to %.1f mm/s\n",
              asleep_max, asleep_at_end, contact_vertex_speed_max * 1e3);
}

// The same pile with sleep.wake_on_centre_motion (session 12, opt-in: a fruit turning or changing
// shape in place wakes no neighbour): it too ends at the sleeping-off run's heights within 2 mm
// while fruits sleep (measured, session 12: 3 of 5 asleep at most and 2 at 1.5 s; the shipped rule
// on the same build: 3 at most, 0 at 1.5 s).
TEST(PaperScenes, FruitPileWakingOnCentreMotionSleepsAtTheHeightsItRestsAtAwake) {
  Scene on = fruit_pile();
  ASSERT_TRUE(on.world.sleep.wake_on_centre_motion);  // as fruit_dish.json ships it (session 12)
  const PileRun centre_rule = run_pile_against_awake(on);
  EXPECT_GE(centre_rule.asleep_max, 1) << "no fruit ever fell asleep";
  std::printf("fruit pile, centre rule: %d of 5 asleep at most, %d at 1.5 s\n", centre_rule.asleep_max,
              centre_rule.asleep_at_end);
}

// The procedural shapes the paper scenes use, through the scene loader: same mesh as the generator,
// bad parameters named by JSON path.
Scene scene_with_mesh(const std::string& mesh_json) {
  const auto root = nlohmann::json::parse(R"({"bodies": [{"mesh": )" + mesh_json + "}]}");
  return parse_scene(root, "shapes.json", ".");
}

TEST(PaperSceneShapes, SphereAndCylinderMatchTheirGenerators) {
  const Scene sphere =
      scene_with_mesh(R"({"shape": "sphere", "radius": 0.04, "surface_vertices": 75, "shells": 2})");
  const TetMeshPtr reference = make_sphere_mesh({0.04, 75, 2});
  EXPECT_EQ(sphere.bodies[0].mesh->vertex_count(), reference->vertex_count());
  EXPECT_EQ(sphere.bodies[0].mesh->vertex_count(), 2 * 75 + 1);
  EXPECT_EQ(sphere.bodies[0].mesh->surface_triangle_count(), 2 * 75 - 4);
  EXPECT_EQ(sphere.bodies[0].mesh->tet_count(), reference->tet_count());
  const Scene cylinder = scene_with_mesh(
      R"({"shape": "cylinder", "radius": 0.02, "length": 0.1, "radial_cells": 2, "axial_cells": 3})");
  const TetMeshPtr cyl = make_cylinder_mesh({0.02, 0.1, 2, 3});
  EXPECT_EQ(cylinder.bodies[0].mesh->vertex_count(), cyl->vertex_count());
  EXPECT_EQ(cylinder.bodies[0].mesh->vertex_count(), (1 + 3 * 2 * 3) * 4);  // disc 1 + 3n(n+1), 4 layers
  const Scene ellipsoid = scene_with_mesh(R"({"shape": "ellipsoid", "semi_axes": [0.03, 0.02, 0.01]})");
  EXPECT_EQ(ellipsoid.bodies[0].mesh->vertex_count(), 73 + 1);  // defaults: 73 surface points, 1 shell
}

void expect_error_at(const std::string& mesh_json, const std::string& path) {
  try {
    scene_with_mesh(mesh_json);
    ADD_FAILURE() << "no error for " << mesh_json;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(PaperSceneShapes, BadShapeParametersNameTheirJsonPath) {
  expect_error_at(R"({"shape": "sphere", "radius": -1})", "/bodies/0/mesh/radius");
  expect_error_at(R"({"shape": "sphere", "radius": 1, "surface_vertices": 5})",
                  "/bodies/0/mesh/surface_vertices");
  expect_error_at(R"({"shape": "sphere", "radius": 1, "shells": 0})", "/bodies/0/mesh/shells");
  expect_error_at(R"({"shape": "sphere", "radius": 1, "size": [1, 1, 1]})", "/bodies/0/mesh");
  expect_error_at(R"({"shape": "ellipsoid", "semi_axes": [1, 0, 1]})", "/bodies/0/mesh/semi_axes");
  expect_error_at(R"({"shape": "cylinder", "radius": 1, "length": 1, "radial_cells": 0})",
                  "/bodies/0/mesh/radial_cells");
  expect_error_at(R"({"shape": "cylinder", "radius": 1})", "/bodies/0/mesh: missing required key 'length'");
  expect_error_at(R"({"shape": "torus"})", "/bodies/0/mesh/shape");
}

}  // namespace
}  // namespace pliant
