// Instruments: meshes valid and closed, geometry matches the spec, grasper jaws follow the hinge,
// forces sum over the instrument's bodies, bad specs name their JSON path.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numbers>

#include "interaction/instrument.h"
#include "interaction/instrument_meshes.h"

namespace pliant {
namespace {

// Every surface edge is shared by exactly two surface triangles with opposite directions.
bool surface_is_closed(const TetMesh& mesh) {
  std::map<std::pair<int, int>, int> directed;
  for (const TriIndices& t : mesh.surface_triangles()) {
    for (int e = 0; e < 3; ++e) directed[{t[e], t[(e + 1) % 3]}]++;
  }
  for (const auto& [edge, count] : directed) {
    if (count != 1) return false;
    auto it = directed.find({edge.second, edge.first});
    if (it == directed.end() || it->second != 1) return false;
  }
  return true;
}

// Volume enclosed by the outward surface (divergence theorem): sum x0 . (x1 x x2) / 6.
double enclosed_volume(const TetMesh& mesh) {
  const auto& x = mesh.rest_positions();
  double v = 0.0;
  for (const TriIndices& t : mesh.surface_triangles()) v += x[t[0]].dot(x[t[1]].cross(x[t[2]])) / 6.0;
  return v;
}

double min_radius_ratio(const TetMesh& mesh) {
  const auto& x = mesh.rest_positions();
  double q = 1.0;
  for (const TetIndices& t : mesh.tets()) q = std::min(q, tet_radius_ratio(x[t[0]], x[t[1]], x[t[2]], x[t[3]]));
  return q;
}

TEST(InstrumentMeshes, RadiusRatioOfRegularTetIsOne) {
  const Vec3 a(1, 1, 1), b(1, -1, -1), c(-1, 1, -1), d(-1, -1, 1);
  EXPECT_NEAR(tet_radius_ratio(a, b, c, d), 1.0, 1e-12);
  EXPECT_LT(tet_radius_ratio(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0.5, 0.5, 1e-6)), 1e-3);
}

TEST(InstrumentMeshes, BallIsClosedWellShapedAndConvergesToTheSphereVolume) {
  const double r = 0.005;
  double previous_error = 1.0;
  for (int cells : {2, 4, 6, 8}) {
    const TetMeshPtr m = build_instrument_mesh(ball_tets(r, cells), "ball");
    EXPECT_TRUE(surface_is_closed(*m)) << cells;
    // Closed and consistently oriented: the surface encloses exactly the tets' volume.
    EXPECT_NEAR(enclosed_volume(*m), m->total_rest_volume(), 1e-12 * r * r * r) << cells;
    // No slivers: radius ratio bounded away from zero at every resolution.
    EXPECT_GT(min_radius_ratio(*m), 0.15) << cells;  // Kuhn cube tets: 0.72
    // Surface vertices on the sphere, none outside it.
    for (int v = 0; v < m->vertex_count(); ++v) {
      const double d = m->rest_positions()[static_cast<size_t>(v)].norm();
      EXPECT_LE(d, r * (1 + 1e-12));
      if (m->is_surface_vertex(v)) {
        EXPECT_NEAR(d, r, 1e-12 * r);
      }
    }
    // Inscribed polyhedron: volume below the sphere's, error shrinking with refinement.
    const double sphere = 4.0 / 3.0 * std::numbers::pi * r * r * r;
    const double error = (sphere - m->total_rest_volume()) / sphere;
    EXPECT_GT(error, 0.0);
    EXPECT_LT(error, previous_error) << cells;
    previous_error = error;
  }
  EXPECT_LT(previous_error, 0.03);
}

TEST(InstrumentMeshes, CylinderIsClosedAndHasTheRightSize) {
  const double r = 0.002, l = 0.03;
  const TetMeshPtr m = build_instrument_mesh(cylinder_tets(r, l, 4, 10, 0.01), "cylinder");
  EXPECT_TRUE(surface_is_closed(*m));
  EXPECT_NEAR(enclosed_volume(*m), m->total_rest_volume(), 1e-18);
  EXPECT_GT(min_radius_ratio(*m), 0.1);
  const Aabb box = m->rest_bounds();
  EXPECT_NEAR(box.min.z(), 0.01, 1e-15);
  EXPECT_NEAR(box.max.z(), 0.04, 1e-15);
  EXPECT_NEAR(box.max.x(), r, 1e-15);
  const double exact = std::numbers::pi * r * r * l;
  EXPECT_LT(m->total_rest_volume(), exact);
  EXPECT_GT(m->total_rest_volume(), 0.9 * exact);
}

InstrumentSpec spec_from(const nlohmann::json& j) { return parse_instrument_spec(JsonReader(j, "scene.json", "/instruments/0")); }

TEST(Instrument, EveryKindBuildsValidClosedMeshes) {
  const std::vector<nlohmann::json> specs = {
      {{"name", "p"}, {"type", "probe"}, {"tip_radius", 0.004}},
      {{"name", "s"}, {"type", "shaft"}, {"radius", 0.002}, {"length", 0.05}},
      {{"name", "g"}, {"type", "grasper"}, {"jaw_length", 0.02}, {"jaw_width", 0.005}, {"jaw_thickness", 0.002}},
      {{"name", "sp"}, {"type", "spatula"}, {"blade_length", 0.02}, {"blade_width", 0.01}, {"blade_thickness", 0.001}},
  };
  World world;
  for (const auto& j : specs) {
    const Instrument tool = Instrument::create(world, spec_from(j));
    ASSERT_FALSE(tool.bodies().empty());
    for (BodyId id : tool.bodies()) {
      const Body& b = world.body(id);
      EXPECT_TRUE(b.is_kinematic());
      EXPECT_TRUE(surface_is_closed(*b.mesh)) << b.name;
      EXPECT_NEAR(enclosed_volume(*b.mesh) / b.mesh->total_rest_volume(), 1.0, 1e-9) << b.name;
      EXPECT_GT(min_radius_ratio(*b.mesh), 0.05) << b.name;
    }
  }
}

TEST(Instrument, ProbeTipIsABallAtTheOriginWithTheShaftAbove) {
  World world;
  InstrumentSpec s = spec_from({{"name", "p"}, {"type", "probe"}, {"tip_radius", 0.004}, {"shaft_length", 0.04},
                                {"position", {0.1, 0.2, 0.3}}});
  const Instrument tool = Instrument::create(world, s);
  const Body& b = world.body(tool.bodies()[0]);
  const Aabb box = b.mesh->rest_bounds();
  EXPECT_NEAR(box.min.z(), -0.004, 1e-12);                    // bottom of the ball
  EXPECT_NEAR(box.max.z(), std::sqrt(0.004 * 0.004 - 0.002 * 0.002) + 0.04, 1e-12);  // top of the shaft
  EXPECT_NEAR(box.max.x(), 0.004, 1e-12);
  // Placed at its pose.
  EXPECT_NEAR((b.positions[0] - (b.mesh->rest_positions()[0] + Vec3(0.1, 0.2, 0.3))).norm(), 0.0, 1e-15);
}

TEST(Instrument, GrasperJawTipsFollowTheOpeningAngleAboutTheHinge) {
  World world;
  const double length = 0.02;
  InstrumentSpec s = spec_from({{"name", "g"}, {"type", "grasper"}, {"jaw_length", length}, {"jaw_width", 0.004},
                                {"jaw_thickness", 0.002}, {"shaft_length", 0.0}, {"max_jaw_opening_deg", 90}});
  Instrument tool = Instrument::create(world, s);
  ASSERT_EQ(tool.parts().size(), 2u);
  // The inner tip corner (0, -w/2, -L) of each jaw's rest mesh.
  auto tip_vertex = [&](const Body& b) {
    const auto& rest = b.mesh->rest_positions();
    for (size_t i = 0; i < rest.size(); ++i) {
      if ((rest[i] - Vec3(0.0, -0.002, -length)).norm() < 1e-12) return i;
    }
    ADD_FAILURE() << "no tip vertex";
    return size_t{0};
  };
  const Body& a = world.body(tool.parts()[0].body);
  const Body& b = world.body(tool.parts()[1].body);
  const size_t ia = tip_vertex(a), ib = tip_vertex(b);
  Pose pose;
  pose.translation = Vec3(0.01, -0.02, 0.05);
  pose.rotation = Quat(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  for (double deg : {0.0, 10.0, 30.0, 60.0, 90.0, 120.0}) {
    const double theta = deg * std::numbers::pi / 180.0;
    tool.apply(world, InstrumentCommand{pose, theta});
    world.step(1e-3);
    const double expected = 2.0 * length * std::sin(0.5 * std::min(theta, std::numbers::pi / 2));  // clamped at max
    EXPECT_NEAR((a.positions[ia] - b.positions[ib]).norm(), expected, 1e-12) << deg;
    // Each tip corner is where the hinge rotation puts it: R_y(-/+theta/2) (0, -w/2, -L), then the pose.
    const double clamped = std::min(theta, std::numbers::pi / 2);
    for (int sign : {+1, -1}) {
      const Vec3 local = Eigen::AngleAxisd(-sign * 0.5 * clamped, Vec3::UnitY()) * Vec3(0.0, -0.002, -length);
      const Vec3& tip = sign > 0 ? a.positions[ia] : b.positions[ib];
      EXPECT_NEAR((tip - pose.apply(local)).norm(), 0.0, 1e-12) << deg;
      // At distance sqrt(L^2 + (w/2)^2) from the hinge point (0, -w/2, 0) for every angle.
      EXPECT_NEAR((tip - pose.apply(Vec3(0.0, -0.002, 0.0))).norm(), length, 1e-12);
    }
    // Jaw A opens towards the instrument's +x.
    if (theta > 0) {
      EXPECT_GT((a.positions[ia] - b.positions[ib]).dot(pose.rotation * Vec3::UnitX()), 0.0);
    }
  }
}

TEST(Instrument, ForceAndTorqueSumOverItsBodiesOnly) {
  World world;
  Instrument g = Instrument::create(world, spec_from({{"name", "g"}, {"type", "grasper"}, {"jaw_length", 0.02},
                                                      {"jaw_width", 0.005}, {"jaw_thickness", 0.002}}));
  Instrument p = Instrument::create(world, spec_from({{"name", "p"}, {"type", "probe"}, {"tip_radius", 0.004}}));
  StepReport r;
  Vec3 expected = Vec3::Zero();
  for (BodyId id : g.bodies()) {
    const Vec3 f(1.0 + id.index, 2.0, -3.0 * id.index);
    r.reactions.push_back({static_cast<int>(id.index), f, 2.0 * f});
    expected += f;
  }
  r.reactions.push_back({static_cast<int>(p.bodies()[0].index), Vec3(100, 100, 100), Vec3(7, 7, 7)});
  EXPECT_EQ(g.bodies().size(), 3u);  // shaft + two jaws
  EXPECT_NEAR((g.force(r) - expected).norm(), 0.0, 1e-15);
  EXPECT_NEAR((g.torque(r) - 2.0 * expected).norm(), 0.0, 1e-15);
  EXPECT_NEAR((p.force(r) - Vec3(100, 100, 100)).norm(), 0.0, 1e-15);
}

void expect_error(const nlohmann::json& j, const std::string& path_fragment, InputErrorKind kind) {
  try {
    spec_from(j);
    ADD_FAILURE() << "no error for " << j.dump();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path_fragment), std::string::npos) << e.what();
    EXPECT_EQ(e.kind(), kind) << e.what();
  }
}

TEST(Instrument, BadSpecsNameTheirJsonPath) {
  expect_error({{"name", "p"}, {"type", "probe"}}, "/instruments/0", InputErrorKind::bad_value);  // missing tip_radius
  expect_error({{"name", "p"}, {"type", "probe"}, {"tip_radius", -1}}, "/instruments/0/tip_radius",
               InputErrorKind::bad_value);
  expect_error({{"name", "p"}, {"type", "laser"}}, "/instruments/0/type", InputErrorKind::bad_value);
  expect_error({{"name", "p"}, {"type", "probe"}, {"tip_radius", 0.01}, {"colour", 1}}, "/instruments/0/colour",
               InputErrorKind::unknown_key);
  expect_error({{"name", "p"}, {"type", "probe"}, {"tip_radius", 0.01}, {"orientation", {0, 0, 0, 0}}},
               "/instruments/0/orientation", InputErrorKind::bad_value);
  expect_error({{"name", "p"}, {"type", "shaft"}, {"radius", 0.01}, {"length", std::nan("")}},
               "/instruments/0/length", InputErrorKind::non_finite);
}

}  // namespace
}  // namespace pliant
