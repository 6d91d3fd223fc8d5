// The resting-churn case (docs/contact-surface.md "Resting churn", issues #5 and #8): free 30 mm
// stiff blocks (2x2x2 cells) stacked on a kinematic floor; shared by the resting-churn test and the
// churn's per-stage energy ledger.
#pragma once

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

}  // namespace pliant
