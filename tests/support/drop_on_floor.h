// The drop of a block on a kinematic floor (issue 8, docs/stability.md "Session 5: mechanisms"),
// shared by the contact layer's CFL test and the implicit contact correction's drop sweep.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>

#include "sim/contact/contact_settings.h"
#include "sim/material.h"
#include "sim/mesh/box_mesh.h"
#include "sim/world.h"

namespace pliant {

/// Largest E = kinetic + elastic + gravitational of a 40 x 40 x 20 mm block (4 x 4 x 2 cells, the
/// stability matrix's upper block) released 0.1 mm above a kinematic floor at 0.5 m/s downward,
/// over 40 steps of dt (s), divided by its kinetic energy at release. `contact`: the World's
/// contact settings; `after_step(world, block)` runs after every step (checks of the caller).
inline double drop_energy_ratio(const Material& m, double dt, const ContactSettings& contact = {},
                                const std::function<void(const World&, BodyId)>& after_step = {}) {
  World world;
  world.settings().contact = contact;
  BodyDef block{.name = "block", .mesh = make_box_mesh({Vec3(0.04, 0.04, 0.02), 4, 4, 2}), .material = m};
  block.pose.translation = Vec3(0.0013, -0.0007, 0.0101);  // off the floor's vertices
  const double speed = 0.5;                                // m/s
  block.initial_velocity = Vec3(0, 0, -speed);
  BodyDef floor{.name = "floor",
                .mesh = make_box_mesh({Vec3(0.5, 0.5, 0.02), 4, 4, 1}),
                .material = m,
                .motion = BodyMotion::kinematic};
  floor.pose.translation = Vec3(0, 0, -0.01);
  const BodyId id = world.add_body(block);
  world.add_body(floor);
  const double kinetic0 = 0.5 * world.body(id).total_mass() * speed * speed;
  double max_energy = 0.0;
  for (int i = 0; i < 40; ++i) {
    const StepReport& r = world.step(dt);
    EXPECT_EQ(r.fault, StepFault::none) << i;
    max_energy = std::max(max_energy, r.body_energy[id.index].total());
    if (after_step) after_step(world, id);
  }
  return max_energy / kinetic0;
}

}  // namespace pliant
