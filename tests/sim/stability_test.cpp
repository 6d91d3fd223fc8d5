// Stability at the extremes, the reduced set for the default suite (issue 8, item 3): a few corners
// of the matrix in tests/sim/stability_long_test.cpp that pass all three checks (finite, energy
// within the work put in, bounded residual overlap; tests/sim/stability_harness.h). Corners that
// fail are findings and stay in the long file only (docs/stability.md lists them).
#include "sim/stability_harness.h"

namespace pliant::stability {
namespace {

TEST(Stability, SurfaceSoftOnStiffRatio1e6) {
  Case c{.name = "surface stiffness ratio 1e-6", .method = ContactMethod::contact_surface};
  c.stiffness_ratio = 1e-6;
  expect_stable(c);
}

// F1, fixed by the held contact forces (docs/stability.md): a block resting on a block of the
// probe scene's tissue (nu 0.45) stored 10x the budget with the paper's response alone.
TEST(Stability, SurfaceRestingOnNearlyIncompressibleTissue) {
  for (double nu : {0.45, 0.49}) {
    Case c{.name = "surface poisson " + std::to_string(nu), .method = ContactMethod::contact_surface};
    c.poisson = nu;
    expect_stable(c);
  }
}

// F3 at dt 1 ms, fixed by the held contact forces: a slow press stored more than its work.
TEST(Stability, SurfaceSlowInstrumentPress) {
  Case c{.name = "surface instrument 0.01 m/s", .method = ContactMethod::contact_surface,
         .partner = Partner::instrument};
  c.speed = 0.01;
  expect_stable(c);
}

// The cap on the held contact force (docs/contact-surface.md): without it the inertial part of
// the instrument's first bite was held too and flung the tissue ahead of it (energy 2x the work).
TEST(Stability, SurfaceFastInstrumentAtTinyStep) {
  Case c{.name = "surface instrument 2 m/s dt 1e-5", .method = ContactMethod::contact_surface,
         .partner = Partner::instrument};
  c.speed = 2.0;
  c.dt = 1e-5;
  expect_stable(c);
}

TEST(Stability, SurfaceTinyStep) {
  Case c{.name = "surface dt 1e-5", .method = ContactMethod::contact_surface};
  c.dt = 1e-5;
  expect_stable(c);
}

TEST(Stability, InstrumentAt2MetresPerSecond) {
  for (ContactMethod m : {ContactMethod::contact_surface, ContactMethod::penalty}) {
    Case c{.name = std::string(to_string(m)) + " instrument 2 m/s", .method = m, .partner = Partner::instrument};
    c.speed = 2.0;
    expect_stable(c);
  }
}

TEST(Stability, SliverTetUnderAnInstrument) {
  for (ContactMethod m : {ContactMethod::contact_surface, ContactMethod::penalty}) {
    Case c{.name = std::string(to_string(m)) + " sliver instrument", .method = m, .partner = Partner::instrument};
    c.sliver = true;
    c.speed = 0.5;
    expect_stable(c);
  }
}

// Passes at the library defaults but sits on an edge (docs/stability.md, M6): the 1 mg block's
// contact layer is at CFL 66; friction's positional move (M6a) and the search's split of the
// block's self-made overlaps (M6b) store energy in bursts whose highest peak decides the verdict.
TEST(Stability, SurfaceMilligramBodyWithASliver) {
  Case c{.name = "surface 1 mg sliver", .method = ContactMethod::contact_surface};
  c.upper_mass = 1e-6;
  c.sliver = true;
  expect_stable(c);
}

// Session 21: the final evaluation linearised under held forces (ContactSettings::
// held_linearised_final_strain, opt-in; three_cubes.json ships 3e-3) keeps this case: its gate
// refuses the sliver's moves. At the search's own gate (1e-2) the case fails (measured: 1.31x the
// work put in), which is why the held gate is a separate, tighter one.
TEST(Stability, SurfaceMilligramBodyWithASliverUnderTheHeldFinalGate) {
  Case c{.name = "surface 1 mg sliver, held final gate 3e-3", .method = ContactMethod::contact_surface};
  c.upper_mass = 1e-6;
  c.sliver = true;
  c.contact_tweak = [](ContactSettings& s) { s.held_linearised_final_strain = 3e-3; };
  expect_stable(c);
}

TEST(Stability, PenaltyNinetyPercentInitialOverlap) {
  Case c{.name = "penalty initial overlap 0.9", .method = ContactMethod::penalty};
  c.overlap_fraction = 0.9;
  expect_stable(c);
}

}  // namespace
}  // namespace pliant::stability
