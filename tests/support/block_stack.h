// The resting-churn case (docs/contact-surface.md "Resting churn", issues #5 and #8): free 30 mm
// stiff blocks (2x2x2 cells) stacked on a kinematic floor; shared by the resting-churn test and the
// churn's per-stage energy ledger.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "sim/material.h"
#include "sim/mesh/box_mesh.h"
#include "sim/world.h"

namespace pliant {

/// The blocks' (and the floor's) material: E 1 MPa, nu 0.3, 1000 kg/m^3, stiffness damping 1e-3,
/// no mass damping, friction coefficient `mu`.
inline Material churn_block_material(double mu) {
  Material m;
  m.young_modulus = 1e6;
  m.poisson_ratio = 0.3;
  m.density = 1000.0;
  m.mass_damping = 0.0;
  m.stiffness_damping = 1e-3;
  m.friction = mu;
  return m;
}

/// Adds `blocks` blocks stacked 30 mm apart (slightly offset, so no vertex sits on a vertex) and
/// the kinematic floor under them; with `fixed_base` the lowest block's bottom vertices are fixed
/// (a deformable support without rigid modes). Returns the blocks' ids, lowest first.
inline std::vector<BodyId> add_block_stack(World& world, int blocks, double mu, bool fixed_base = false) {
  const auto mesh = make_box_mesh({Vec3(0.03, 0.03, 0.03), 2, 2, 2});
  std::vector<BodyId> ids;
  for (int k = 0; k < blocks; ++k) {
    BodyDef block{.name = "block" + std::to_string(k), .mesh = mesh, .material = churn_block_material(mu)};
    block.pose.translation = Vec3(0.003 * k, -0.002 * k, 0.015 + 0.03 * k);
    for (int v = 0; fixed_base && k == 0 && v < mesh->vertex_count(); ++v) {
      if (mesh->rest_positions()[static_cast<size_t>(v)].z() < -0.0149) block.fixed_vertices.push_back(v);
    }
    ids.push_back(world.add_body(block));
  }
  BodyDef floor{.name = "floor", .mesh = make_box_mesh({Vec3(0.5, 0.5, 0.02), 4, 4, 1}),
                .material = churn_block_material(mu), .motion = BodyMotion::kinematic};
  floor.pose.translation = Vec3(0, 0, -0.01);
  world.add_body(floor);
  return ids;
}

/// Late-run numbers of one block-stack run (the resting-churn measures).
struct ChurnRun {
  double kinetic_late_max = 0.0;      ///< largest kinetic energy over the last 2/7 of the run (J)
  double rest_floor = 0.0;            ///< (1/2) M (g dt)^2 over the free mass M (J)
  double stored_speed_max = 0.0;      ///< largest stored vertex speed over the same steps (m/s)
  double positional_speed_max = 0.0;  ///< largest |x_{n+1} - x_n| / dt over the same steps (m/s)
  /// Time (s) from which the kinetic energy stays below the rest floor to the end of the run; the
  /// run's duration if it ends above it.
  double rest_time = 0.0;
};

/// `blocks` stacked blocks (add_block_stack) for 0.7 s of steps dt, held forces 1, finishing
/// projection on, friction iff mu > 0; `adjust` changes the contact settings after those; the top
/// block starts `shift_m` further along x (the late KE at 1 ms is chaotic in it); `adjust_bodies`
/// changes the blocks (their models' settings) after they are added.
inline ChurnRun run_block_stack(int blocks, double mu, double dt, bool fixed_base = false,
                                const std::function<void(ContactSettings&)>& adjust = {}, double shift_m = 0.0,
                                const std::function<void(World&, const std::vector<BodyId>&)>& adjust_bodies = {}) {
  constexpr double kG = 9.81;  // m/s^2, WorldSettings' default gravity
  World world;
  world.settings().contact.held_force_fraction = 1.0;
  world.settings().contact.friction = mu > 0.0;
  world.settings().contact.finishing_projection = true;
  if (adjust) adjust(world.settings().contact);
  const std::vector<BodyId> ids = add_block_stack(world, blocks, mu, fixed_base);
  for (auto& x : world.body(ids.back()).positions) x.x() += shift_m;
  if (adjust_bodies) adjust_bodies(world, ids);
  double mass = 0.0;
  for (BodyId id : ids) mass += world.body(id).total_mass();

  ChurnRun out;
  out.rest_floor = 0.5 * mass * (kG * dt) * (kG * dt);
  const int steps = static_cast<int>(std::lround(0.7 / dt));
  std::vector<std::vector<Vec3>> previous(ids.size());
  for (int i = 1; i <= steps; ++i) {
    for (size_t k = 0; k < ids.size(); ++k) previous[k] = world.body(ids[k]).positions;
    const StepReport& r = world.step(dt);
    EXPECT_EQ(r.fault, StepFault::none) << i;
    if (!(r.energy.kinetic < out.rest_floor)) out.rest_time = i * dt;
    if (i <= steps * 5 / 7) continue;
    out.kinetic_late_max = std::max(out.kinetic_late_max, r.energy.kinetic);
    for (size_t k = 0; k < ids.size(); ++k) {
      const Body& b = world.body(ids[k]);
      for (size_t v = 0; v < b.positions.size(); ++v) {
        out.stored_speed_max = std::max(out.stored_speed_max, b.velocities[v].norm());
        out.positional_speed_max = std::max(out.positional_speed_max, (b.positions[v] - previous[k][v]).norm() / dt);
      }
    }
  }
  return out;
}

}  // namespace pliant
