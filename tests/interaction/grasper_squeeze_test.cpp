// A grasper closing on a soft cylinder, through the whole chain (tool script `jaws` -> grasper ->
// World::step with the contact-surface response -> per-jaw reactions). The cylinder (radius 5 mm,
// 30 mm long, axis along the hinge axis y, centre 18 mm below the hinge, both end caps fixed) sits
// between the 30 mm jaws; the jaws close from 40 to 20 degrees (a narrow wedge, so the squeeze
// does not just push the cylinder out towards the jaw tips).
// References:
//   - geometry: a jaw's inner face is the plane through the hinge axis at angle theta/2 from -z,
//     so at the cylinder centre's depth h the faces are 2 h tan(theta/2) apart in x (6.3 mm at
//     20 degrees, against the 10 mm diameter). The squeezed cross-section under the jaws must fit
//     between the faces (up to the contact method's residual overlap) and so shrink along x;
//   - forces: the set-up is mirror-symmetric in x, so the jaws' x forces are opposite and equal
//     (their sum is small against each) and their z forces equal. Without friction each force
//     is along its jaw's face normal (cos(theta/2), 0, sin(theta/2)) for jaw A and (-cos, 0, sin)
//     for jaw B: the jaws form a wedge, and the z resultant 2 N sin(theta/2) is what pushes the
//     cylinder out of the wedge against its fixed ends.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "interaction/instrument.h"
#include "interaction/script_pose_source.h"
#include "sim/mesh/cylinder_mesh.h"

namespace pliant {
namespace {

using nlohmann::json;

constexpr double kRadius = 0.005;      // m, cylinder
constexpr double kLength = 0.03;       // m, cylinder along y
constexpr double kCentreDepth = 0.018; // m, cylinder axis below the hinge
constexpr double kJawWidth = 0.006;    // m
constexpr double kJawLength = 0.03;    // m
constexpr double kOpenDeg = 40.0, kClosedDeg = 20.0;

// Cylinder along y through (0, 0, -kCentreDepth): the z-axis generator rotated by -90 degrees
// about x, (x, y, z) -> (x, z, -y).
TetMeshPtr lying_cylinder() {
  const TetMeshPtr c = make_cylinder_mesh(CylinderMeshSpec{kRadius, kLength, 5, 12});
  std::vector<Vec3> positions;
  for (const Vec3& p : c->rest_positions()) positions.emplace_back(p.x(), p.z(), -p.y() - kCentreDepth);
  return TetMesh::build(std::move(positions), c->tets(), "lying cylinder");
}

struct Squeeze {
  Vec3 jaw_a = Vec3::Zero(), jaw_b = Vec3::Zero();  ///< N, tissue on each jaw, mean of the hold
  double half_width = 0.0;       ///< m, max |x| of cylinder vertices under the jaws at the end
  double worst_face_excess = 0.0;  ///< m, max over those vertices of |x| - face offset at their z
  double rest_half_width = 0.0;  ///< m
  double height = 0.0;           ///< m, z extent of the vertices under the jaws at the end
  double rest_height = 0.0;      ///< m
};

Vec3 part_force(const Instrument& g, const StepReport& r, const std::string& part) {
  Vec3 f = Vec3::Zero();
  for (const InstrumentPart& p : g.parts()) {
    if (p.name != part) continue;
    for (const KinematicReaction& reaction : r.reactions) {
      if (reaction.body == static_cast<int>(p.body.index)) f += reaction.force;
    }
  }
  return f;
}

Squeeze squeeze() {
  WorldSettings settings;
  settings.gravity = Vec3::Zero();
  settings.contact.method = ContactMethod::contact_surface;
  // Held contact force (the library default), as in hertz_contact_test.cpp (docs/interaction.md).
  // Without it the dent springs back inside the 2 mm jaws every step and the jaws end 1.8 mm inside
  // the cylinder (half-width 5.05 mm, jaw forces 3 mN); with 0.8: 1.78 mm, 4.96 mm, 12 mN; with 1.0
  // (default): 0.035 mm, 3.95 mm, +0.088 / -0.089 N.
  World world(settings);
  BodyDef tissue;
  tissue.name = "cylinder";
  tissue.mesh = lying_cylinder();
  tissue.material.young_modulus = 5e3;
  tissue.material.poisson_ratio = 0.45;
  tissue.material.mass_damping = 10.0;
  for (int v = 0; v < tissue.mesh->vertex_count(); ++v) {
    if (std::abs(tissue.mesh->rest_positions()[static_cast<size_t>(v)].y()) > 0.5 * kLength - 1e-9) {
      tissue.fixed_vertices.push_back(v);
    }
  }
  const BodyId cylinder = world.add_body(tissue);
  const json spec = {{"name", "g"},          {"type", "grasper"},        {"jaw_length", kJawLength},
                     {"jaw_width", kJawWidth}, {"jaw_thickness", 0.002}, {"shaft_length", 0.0},
                     {"jaw_opening_deg", kOpenDeg}, {"max_jaw_opening_deg", kOpenDeg}, {"resolution", 4}};
  Instrument g = Instrument::create(world, parse_instrument_spec(JsonReader(spec, "test", "/instruments/0")));
  const json script = json::array({{{"t", 0.5}, {"instrument", "g"}, {"op", "jaws"}, {"opening_deg", kClosedDeg}},
                                   {{"t", 0.8}, {"instrument", "g"}, {"op", "hold"}}});
  ScriptPoseSource source(parse_tool_script(JsonReader(script, "test", "/script"), {"g"}), "g", g.command());
  Squeeze out;
  InstrumentFeedback fb;
  const double dt = 1e-3;
  int held = 0;
  for (int i = 1; i <= 800; ++i) {
    g.apply(world, source.sample(i * dt, fb));
    const StepReport& r = world.step(dt);
    EXPECT_EQ(r.fault, StepFault::none) << r.fault_message;
    fb.force = g.force(r);
    fb.time = r.time;
    if (i > 700) {
      out.jaw_a += part_force(g, r, "jaw_a");
      out.jaw_b += part_force(g, r, "jaw_b");
      ++held;
    }
  }
  out.jaw_a /= held;
  out.jaw_b /= held;
  const double tan_half = std::tan(0.5 * kClosedDeg * std::numbers::pi / 180.0);
  const Body& body = world.body(cylinder);
  double z_min = 1.0, z_max = -1.0, rest_z_min = 1.0, rest_z_max = -1.0;
  for (int v = 0; v < body.vertex_count(); ++v) {
    const Vec3& rest = body.mesh->rest_positions()[static_cast<size_t>(v)];
    if (std::abs(rest.y()) > 0.5 * kJawWidth) continue;
    const Vec3& x = body.positions[static_cast<size_t>(v)];
    out.rest_half_width = std::max(out.rest_half_width, std::abs(rest.x()));
    out.half_width = std::max(out.half_width, std::abs(x.x()));
    out.worst_face_excess = std::max(out.worst_face_excess, std::abs(x.x()) - (-x.z()) * tan_half);
    z_min = std::min(z_min, x.z());
    z_max = std::max(z_max, x.z());
    rest_z_min = std::min(rest_z_min, rest.z());
    rest_z_max = std::max(rest_z_max, rest.z());
  }
  out.height = z_max - z_min;
  out.rest_height = rest_z_max - rest_z_min;
  return out;
}

TEST(GrasperSqueeze, ClosingJawsSqueezeTheCylinderAndFeelOppositeForces) {
  const Squeeze s = squeeze();
  std::printf("height %.3f -> %.3f mm, ", s.rest_height * 1e3, s.height * 1e3);
  std::printf("half width %.3f -> %.3f mm, worst face excess %.3f mm, jaw A (%.4g %.4g %.4g) N, jaw B (%.4g %.4g %.4g) N\n",
              s.rest_half_width * 1e3, s.half_width * 1e3, s.worst_face_excess * 1e3, s.jaw_a.x(), s.jaw_a.y(),
              s.jaw_a.z(), s.jaw_b.x(), s.jaw_b.y(), s.jaw_b.z());
  // Squeezed: the cross-section under the jaws fits between the faces (2 h tan 10 deg = 6.3 mm at
  // the centre's depth) up to a residual overlap, so its half-width drops well below the radius.
  EXPECT_NEAR(s.rest_half_width, kRadius, 1e-9);
  EXPECT_LT(s.worst_face_excess, 5e-4);  // 10% of the radius; measured 0.33 mm
  EXPECT_LT(s.half_width, 0.85 * kRadius);
  // The cross-section shrinks along the closing direction, not as a whole: it gets taller (the
  // tissue is nearly incompressible, nu = 0.45).
  EXPECT_GT(s.height, s.rest_height);
  // Opposite along the closing direction: jaw A (at +x) is pushed to +x, jaw B to -x, equally.
  EXPECT_GT(s.jaw_a.x(), 0.0);
  EXPECT_LT(s.jaw_b.x(), 0.0);
  EXPECT_LT(std::abs(s.jaw_a.x() + s.jaw_b.x()), 0.05 * std::abs(s.jaw_a.x()));
  EXPECT_NEAR(s.jaw_a.z(), s.jaw_b.z(), 0.05 * s.jaw_a.norm());
  // Frictionless: each force lies along its face normal (within 10 degrees).
  const double half = 0.5 * kClosedDeg * std::numbers::pi / 180.0;
  const Vec3 normal_a(std::cos(half), 0.0, std::sin(half)), normal_b(-std::cos(half), 0.0, std::sin(half));
  EXPECT_GT(s.jaw_a.normalized().dot(normal_a), std::cos(10.0 * std::numbers::pi / 180.0));
  EXPECT_GT(s.jaw_b.normalized().dot(normal_b), std::cos(10.0 * std::numbers::pi / 180.0));
}

}  // namespace
}  // namespace pliant
