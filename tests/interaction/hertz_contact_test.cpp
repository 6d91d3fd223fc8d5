// Hertz law through the whole chain (tool script -> probe -> World::step with the contact-surface
// response -> instrument force): a rigid sphere of radius R pressed into an elastic half-space
// needs F = 4/3 E* sqrt(R) d^1.5 (Hertz 1882; Johnson, Contact Mechanics, eq. 4.22,
// E* = E / (1 - nu^2)), so log F against log d has slope 1.5. The test fits that slope by least
// squares on quasi-static samples and asks for 1.5 +- 0.15.
//
// Design note (sizes). A uniformly fine block would cost far more than the 30 s a test may take,
// so the block is graded: a 16 x 16 x 8-cell Kuhn box whose x, y and depth coordinates are
// stretched (sinh laterally, exponential in depth) so cells are about 0.5 mm under the probe and
// grow to several mm at the sides and base. Why it is "half-space enough":
//   - the contact radius a = sqrt(R d) is 2.4-4.5 mm over the fitted range d = 0.6-2.0 mm, while
//     the surface spacing under the probe is about 0.55 mm: 4-8 surface vertices across a;
//   - the block is 60 mm wide (6.7 a_max) and 45 mm thick (10 a_max) on a fixed base: a layer
//     bonded to a rigid base stiffens as a/h grows (Johnson ch. 5.9), which raises the slope.
//     Measured while choosing the sizes (same mesh, beta = 0): 30 / 45 / 60 mm thick gave slopes
//     1.52 / 1.50 / 1.48; nu = 0.3 (not near-incompressible) keeps the effect small;
//   - the probe ball is meshed at resolution 12 (facets about 1.3 mm on R = 10 mm), so the tip is
//     a sphere and not a flat punch (F ~ d) at these contact radii. Facets still matter at the
//     level of the tolerance: resolution 16 gave a slope of 1.58 with the 30 mm block.
// Quasi-static: the probe moves at most 4.8 mm/s (eased), the block's first mode has a period of
// about 50 ms, strong mass damping (alpha = 30 /s) removes the inertial force (its share is
// below 1e-3 of F), and stiffness damping is off: with the default beta = 0.01 s the viscous
// force beta K v is several percent of F and varies with v/d, and the slope came out 1.66
// instead of 1.52 (measured). Hertz is the elastic force; the fit uses
// the mean force in 0.1 mm depth bins, because single steps ripple by a few percent as tissue
// vertices enter contact.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "interaction/instrument.h"
#include "interaction/script_pose_source.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

using nlohmann::json;

constexpr double kRadius = 0.01;       // m, probe tip
constexpr double kHalfWidth = 0.03;    // m
constexpr double kThickness = 0.045;   // m
constexpr double kYoung = 5e3;         // Pa
constexpr double kPoisson = 0.3;

// The graded block: top face at z = 0, base at z = -kThickness, centred on the z axis.
TetMeshPtr graded_block() {
  const TetMeshPtr box = make_box_mesh(BoxMeshSpec{Vec3(2.0, 2.0, 1.0), 16, 16, 8});
  const double b = 4.0;  // lateral stretch: spacing ratio centre/edge = 1/cosh(b)
  const double c = 3.4;  // depth stretch: spacing ratio top/base = exp(-c)
  std::vector<Vec3> positions;
  for (const Vec3& p : box->rest_positions()) {
    const double s = 0.5 - p.z();  // 0 at the top, 1 at the base
    positions.emplace_back(kHalfWidth * std::sinh(b * p.x()) / std::sinh(b),
                           kHalfWidth * std::sinh(b * p.y()) / std::sinh(b),
                           -kThickness * std::expm1(c * s) / std::expm1(c));
  }
  return TetMesh::build(std::move(positions), box->tets(), "graded block");
}

struct Sample {
  double depth = 0.0;  ///< m, probe's lowest point below the undeformed top
  double force = 0.0;  ///< N, along +z
};

std::vector<Sample> press(double max_depth, int steps, double dt) {
  WorldSettings settings;
  settings.gravity = Vec3::Zero();
  settings.contact.method = ContactMethod::contact_surface;
  // The library default holds the whole contact force through the next integration
  // (docs/interaction.md, "Why the Hertz and grasper tests hold the contact force"). Without it the
  // implicit step springs the dent back every step, the block carries only the velocity impulses,
  // and its fixed base carries 0.36x Hertz at 1 mm (slope 1.90; the reported probe force equals
  // that base force within 3%, so the report is right and the load is missing). Measured on this
  // test: held fraction 0 -> slope 1.90, 0.36x; 0.8 -> 1.654, 0.79x; 1.0 (default) -> 1.516, 1.12x.
  World world(settings);
  BodyDef block;
  block.name = "block";
  block.mesh = graded_block();
  block.material.young_modulus = kYoung;
  block.material.poisson_ratio = kPoisson;
  block.material.mass_damping = 30.0;
  block.material.stiffness_damping = 0.0;  // Hertz is elastic: no viscous (beta K v) force
  for (int v = 0; v < block.mesh->vertex_count(); ++v) {
    if (block.mesh->rest_positions()[static_cast<size_t>(v)].z() < -kThickness + 1e-9) block.fixed_vertices.push_back(v);
  }
  world.add_body(block);
  const double gap = 2e-4;
  const json spec = {{"name", "probe"}, {"type", "probe"}, {"tip_radius", kRadius}, {"shaft_length", 0.0},
                     {"resolution", 12}, {"position", {0.0, 0.0, kRadius + gap}}};
  Instrument probe = Instrument::create(world, parse_instrument_spec(JsonReader(spec, "test", "/instruments/0")));
  const json script = json::array({{{"t", steps * dt}, {"instrument", "probe"}, {"op", "press"},
                                    {"axis", {0, 0, -1}}, {"depth", gap + max_depth}}});
  ScriptPoseSource source(parse_tool_script(JsonReader(script, "test", "/script"), {"probe"}), "probe",
                          probe.command());
  std::vector<Sample> samples;
  InstrumentFeedback fb;
  for (int i = 1; i <= steps; ++i) {
    probe.apply(world, source.sample(i * dt, fb));
    const StepReport& r = world.step(dt);
    EXPECT_EQ(r.fault, StepFault::none) << r.fault_message;
    fb.force = probe.force(r);
    fb.time = r.time;
    samples.push_back({-(probe.pose().translation.z() - kRadius), fb.force.z()});
  }
  return samples;
}

TEST(HertzContact, ForceAgainstIndentationHasLogLogSlopeOneAndAHalf) {
  const std::vector<Sample> samples = press(0.0021, 900, 1e-3);
  // Mean (log d, log F) per 0.1 mm bin over 0.6-2.0 mm.
  std::vector<double> log_d, log_f;
  for (double bin = 0.6e-3; bin < 2.0e-3 - 1e-12; bin += 0.1e-3) {
    double d = 0.0, f = 0.0;
    int n = 0;
    for (const Sample& s : samples) {
      if (s.depth >= bin && s.depth < bin + 0.1e-3) {
        d += s.depth;
        f += s.force;
        ++n;
      }
    }
    ASSERT_GT(n, 2) << "bin " << bin;
    ASSERT_GT(f, 0.0) << "bin " << bin;
    log_d.push_back(std::log(d / n));
    log_f.push_back(std::log(f / n));
  }
  // Least-squares line log F = k log d + c.
  const auto m = static_cast<double>(log_d.size());
  double sd = 0.0, sf = 0.0, sdd = 0.0, sdf = 0.0;
  for (size_t i = 0; i < log_d.size(); ++i) {
    sd += log_d[i];
    sf += log_f[i];
    sdd += log_d[i] * log_d[i];
    sdf += log_d[i] * log_f[i];
  }
  const double slope = (m * sdf - sd * sf) / (m * sdd - sd * sd);
  const double e_star = kYoung / (1.0 - kPoisson * kPoisson);
  const auto hertz = [&](double d) { return 4.0 / 3.0 * e_star * std::sqrt(kRadius) * std::pow(d, 1.5); };
  const double ratio_at_1mm = std::exp((sf - slope * sd) / m + slope * std::log(1e-3)) / hertz(1e-3);
  std::printf("log-log slope %.4f over %d bins; force / Hertz at 1 mm: %.3f\n", slope, static_cast<int>(m),
              ratio_at_1mm);
  EXPECT_NEAR(slope, 1.5, 0.15);
  // The prefactor is not what the test is about (a discrete contact surface, a finite block), but
  // it must be Hertz's order of magnitude.
  EXPECT_GT(ratio_at_1mm, 0.5);
  EXPECT_LT(ratio_at_1mm, 2.0);
}

}  // namespace
}  // namespace pliant
