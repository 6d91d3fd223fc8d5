// sim/contact/derived_held_fraction.h (session 10, issue #8): the held strength of a deformable pair
// from its contact mode. References: the trapezoidal rule run on a spring (a second method for the
// closed-form fraction, and its energy conservation, which is why that rule is the one matched), and
// the column formula E A / L with the stacked blocks' own numbers for the contact mode.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sim/contact/derived_held_fraction.h"
#include "support/block_stack.h"

namespace pliant {
namespace {

// One trapezoidal (implicit midpoint) step of m u'' = W - k u from (u0, v0), solved as the 2x2
// linear system it is; returns the mean force k (u0 + u1) / 2 the spring applied over the step.
double trapezoidal_spring_force(double k, double m, double load, double dt, double u0, double v0, double* u1_out = nullptr,
                                double* v1_out = nullptr) {
  // u1 = u0 + dt (v0 + v1) / 2, v1 = v0 + dt (W - k (u0 + u1) / 2) / m; with a = k dt^2 / (4 m),
  // substituting u1: v1 (1 + a) = v0 (1 - a) + dt (W - k u0) / m.
  const double a = k * dt * dt / (4.0 * m);
  const double v1 = (v0 * (1.0 - a) + dt * (load - k * u0) / m) / (1.0 + a);
  const double u1 = u0 + 0.5 * dt * (v0 + v1);
  if (u1_out != nullptr) *u1_out = u1;
  if (v1_out != nullptr) *v1_out = v1;
  return 0.5 * k * (u0 + u1);
}

// From relative rest (v0 = 0, what stage 5 leaves) the trapezoidal step's mean spring force is
// linear in the start force k u0 and the load W; its weight on k u0 is the derived held fraction.
TEST(HeldFractionForContactMode, IsTheTrapezoidalStepsShareOfTheStartForce) {
  const double m = 0.0135, dt = 1e-3;
  for (double omega_dt : {0.0, 0.1, 0.5, 1.0, 2.0, 5.0}) {
    const double omega = omega_dt / dt, k = m * omega * omega;
    const double u0 = 1e-5;
    const double start_part = trapezoidal_spring_force(k, m, 0.0, dt, u0, 0.0);  // no load
    const double load_part = trapezoidal_spring_force(k, m, 0.26, dt, 0.0, 0.0);  // no start force
    if (k > 0.0) {
      EXPECT_NEAR(start_part / (k * u0), held_fraction_for_contact_mode(omega_dt), 1e-12) << omega_dt;
    }
    EXPECT_NEAR(load_part / 0.26, 1.0 - held_fraction_for_contact_mode(omega_dt), 1e-12) << omega_dt;
  }
  EXPECT_DOUBLE_EQ(held_fraction_for_contact_mode(1.0), 0.8);  // session 9's measured optimum's omega dt
}

// The rule matched conserves the spring's energy over many steps at omega dt = 1.5 (no energy in or
// out per cycle), where backward Euler loses most of it: why the trapezoidal share is the target.
TEST(HeldFractionForContactMode, TheMatchedRuleConservesTheSpringsEnergy) {
  const double m = 0.02, dt = 1e-3, omega = 1500.0, k = m * omega * omega;
  double u = 1e-4, v = 0.0;
  const double e0 = 0.5 * k * u * u;
  for (int n = 0; n < 1000; ++n) {
    double u1 = 0.0, v1 = 0.0;
    trapezoidal_spring_force(k, m, 0.0, dt, u, v, &u1, &v1);
    u = u1;
    v = v1;
  }
  EXPECT_NEAR(0.5 * k * u * u + 0.5 * m * v * v, e0, 1e-9 * e0);
}

// Two stacked 30 mm blocks (E 1 MPa, 1000 kg/m^3) along z: each is a column E A / L = E L = 3e4 N/m,
// in series 1.5e4 N/m, on the reduced mass of 27 g and 27 g; with the lower block's base fixed the
// upper block moves alone (27 g).
TEST(ContactModeOmega, StackedBlocksAreTwoColumnsInSeries) {
  const double mass = 1000.0 * 0.03 * 0.03 * 0.03, k_block = 1e6 * 0.03;
  {
    World world;
    const std::vector<BodyId> ids = add_block_stack(world, 2, 0.5);
    const Body &lower = world.body(ids[0]), &upper = world.body(ids[1]);
    EXPECT_NEAR(bounce_stiffness_along(lower, Vec3::UnitZ()), k_block, 1e-9 * k_block);
    EXPECT_NEAR(contact_mode_omega(lower, upper, Vec3::UnitZ()), std::sqrt(0.5 * k_block / (0.5 * mass)), 1e-6);
    EXPECT_NEAR(contact_mode_omega(upper, lower, -Vec3::UnitZ()), std::sqrt(0.5 * k_block / (0.5 * mass)), 1e-6);
  }
  {
    World world;
    const std::vector<BodyId> ids = add_block_stack(world, 2, 0.5, true);
    EXPECT_NEAR(contact_mode_omega(world.body(ids[0]), world.body(ids[1]), Vec3::UnitZ()),
                std::sqrt(0.5 * k_block / mass), 1e-6);
  }
}

}  // namespace
}  // namespace pliant
