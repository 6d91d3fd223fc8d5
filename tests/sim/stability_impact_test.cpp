// Where the matrix's contact-surface energy failures come from (issue 8, docs/stability.md
// "Session 5: mechanisms"). Two focused checks, each against an energy reference that needs no
// simulation:
//  - the deformation model alone (no contact) never gains energy, also at nu 0.499: implicit
//    Euler with Rayleigh damping only removes energy, so E = kinetic + elastic + gravitational
//    (relative to the start) stays <= 0 up to the harness's round-off floor. So the nu 0.499
//    failure is not the model's.
//  - a block dropped on a kinematic floor at 0.5 m/s: the contact may only remove energy, so the
//    block's E never exceeds its kinetic energy at release (the harness's 10% slack). This holds
//    while the acoustic CFL number of the contact layer, c_p dt / h (c_p = sqrt((lambda + 2 mu) /
//    rho), the pressure-wave speed; h the cell height), is below about 1, and fails beyond it:
//    the search moves the surface vertices by the step's whole approach v dt while the interior,
//    which the contact's wave would have reached within the step, keeps moving, so the dent
//    stores about (c_p dt)^2 / (h H) times the kinetic energy (H the body's height). The failing
//    case stays DISABLED_ with its measured numbers.
//  - the opt-in CFL limit on the search's displacement, on the two matrix cases it fixes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "sim/mesh/box_mesh.h"
#include "sim/stability_harness.h"
#include "sim/world.h"
#include "support/drop_on_floor.h"

namespace pliant {
namespace {

Material tissue(double young, double poisson) {
  Material m;
  m.young_modulus = young;
  m.poisson_ratio = poisson;
  m.density = 1000.0;
  m.mass_damping = 1.0;
  m.stiffness_damping = 0.01;
  m.friction = 0.2;
  return m;
}

constexpr double kCellHeight = 0.01;  // m, the dropped block's cell height (20 mm in 2 cells)

// The matrix's lower block (80 x 80 x 40 mm, fixed at its base) at nu 0.499 under gravity alone:
// E stays <= 1e-3 of m g h (the harness's floor). Measured: E <= 0 throughout (session 5).
TEST(StabilityMechanism, NearlyIncompressibleBlockAloneGainsNoEnergy) {
  World world;
  const TetMeshPtr mesh = make_box_mesh({Vec3(0.08, 0.08, 0.04), 6, 6, 3});
  BodyDef lower{.name = "lower", .mesh = mesh, .material = tissue(1e4, 0.499)};
  lower.pose.translation = Vec3(0, 0, -0.02);
  for (int v = 0; v < mesh->vertex_count(); ++v) {
    if (std::abs(mesh->rest_positions()[static_cast<size_t>(v)].z() + 0.02) < 1e-9)
      lower.fixed_vertices.push_back(v);
  }
  const BodyId id = world.add_body(lower);
  const double floor = 1e-3 * world.body(id).total_mass() * 9.81 * 0.04;
  double max_energy = -1.0;
  for (int i = 0; i < 300; ++i) {
    const StepReport& r = world.step(1e-3);
    ASSERT_EQ(r.fault, StepFault::none) << i;
    max_energy = std::max(max_energy, r.energy.total());
  }
  EXPECT_LE(max_energy, floor);
}

// CFL 0.37 (the matrix's nominal tissue, E 10 kPa, nu 0.3, dt 1 ms): measured ratio 0.79.
TEST(StabilityMechanism, DropOnAFloorBelowTheContactLayerCflLosesEnergy) {
  const Material m = tissue(1e4, 0.3);
  const double dt = 1e-3;
  ASSERT_LT(m.pressure_wave_speed() * dt / kCellHeight, 1.0);
  EXPECT_LE(drop_energy_ratio(m, dt), 1.1);
}

// KNOWN FAILURE (session 5): the same drop on the matrix's nu 0.499 tissue, CFL 4.1: the block's
// energy reaches 12.7x its kinetic energy at release (step 1). Sweep (max E / KE at release, CFL in
// brackets; nu 0.3 unless given): E 1e4 dt 5 ms 4.45 (1.83); E 1e5 1.37 (1.16); E 1e6 12.1 (3.67);
// E 1e7 124 (11.6); nu 0.49 1.54 (1.31); nu 0.499 E 1e5 456 (12.9). The ratio grows about as
// CFL^2: the search's displacement (stage 4) dents the contact layer by the whole approach of the
// step, which the velocity update (stage 5) does not pay for. A fix has to spread the step's
// contact response over the depth its pressure wave reaches in dt (e.g. the displacement as a
// constraint inside the implicit solve, or as a held force only); not done (docs/stability.md). The
// opt-in CFL limit brings it to 2.76x (friction's positional move is most of the rest: 1.21x
// without friction).
TEST(StabilityMechanism, DISABLED_DropOnAFloorAboveTheContactLayerCflLosesEnergy) {
  const Material m = tissue(1e4, 0.499);
  const double dt = 1e-3;
  ASSERT_GT(m.pressure_wave_speed() * dt / kCellHeight, 4.0);
  EXPECT_LE(drop_energy_ratio(m, dt), 1.1);
}

// The opt-in experiment against M1 (ContactSettings::cfl_limited_displacement: a vertex takes
// 1/CFL^2 of the search's displacement where CFL > 1) on two matrix cases that fail at the library
// defaults: nu 0.499 (1.77x the budget -> 0.84x) and stiffness ratio 1e6 (7.2e3x -> 0). It is not
// the default: it fails four default-suite tests and makes dt 20 ms worse (docs/stability.md).
TEST(StabilityMechanism, CflLimitedDisplacementKeepsNearlyIncompressibleAndStiffContactsWithinBudget) {
  using stability::Case;
  for (const bool incompressible : {true, false}) {
    Case c{.name = incompressible ? "surface poisson 0.499, CFL-limited" : "surface ratio 1e6, CFL-limited"};
    if (incompressible) {
      c.poisson = 0.499;
    } else {
      c.stiffness_ratio = 1e6;
    }
    c.contact_tweak = [](ContactSettings& s) { s.cfl_limited_displacement = true; };
    stability::expect_stable(c);
  }
}

}  // namespace
}  // namespace pliant
