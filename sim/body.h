// Body: a mesh, a material, a deformation model, and the changing state (STYLE.md 2).
// Deformable bodies are integrated by their model; kinematic bodies (instruments, fixtures) move
// by prescribed pose only and count as infinitely stiff in contact.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "sim/material.h"
#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"
#include "sim/model/deformation_model.h"
#include "sim/sleep/sleep_settings.h"

namespace pliant {

enum class BodyMotion {
  deformable,  ///< integrated by its deformation model
  kinematic,   ///< moved by prescribed pose; infinitely stiff
};

/// Everything needed to add a body to a world. Checked once by World::add_body.
struct BodyDef {
  std::string name;
  TetMeshPtr mesh;
  Material material;
  BodyMotion motion = BodyMotion::deformable;
  /// Kinematic bodies only: an instrument (a tool the scene moves into tissue), not a fixture.
  /// A body an instrument touches never falls asleep (sim/sleep/sleep_settings.h).
  bool instrument = false;
  ModelKind model = ModelKind::corotational_fem;
  ModelSettings model_settings;
  Pose pose;                          ///< placement of the rest mesh in the world
  Vec3 initial_velocity = Vec3::Zero();  ///< m/s, all vertices
  std::vector<int> fixed_vertices;    ///< held in place (infinitely stiff supports)
  bool self_collision = false;
  unsigned collision_group = 1u;
  unsigned collision_mask = ~0u;
};

class Body {
 public:
  std::string name;
  TetMeshPtr mesh;
  Material material;
  BodyMotion motion = BodyMotion::deformable;
  bool instrument = false;  ///< kinematic bodies: an instrument, not a fixture (BodyDef::instrument)
  std::unique_ptr<DeformationModel> model;  ///< null for kinematic bodies

  // State, touched every step: flat arrays indexed by vertex.
  std::vector<Vec3> positions;        ///< x (m)
  std::vector<Vec3> velocities;       ///< v (m/s)
  std::vector<double> masses;         ///< lumped (kg)
  std::vector<char> fixed;            ///< 1 where held in place
  std::vector<Vec3> applied_forces;   ///< user forces (N), kept until changed

  // Kinematic bodies: the rest mesh placed by `pose`; `target_pose` is reached in the next step.
  Pose pose;
  Pose target_pose;

  bool self_collision = false;
  unsigned collision_group = 1u;
  unsigned collision_mask = ~0u;

  SleepState sleep;            ///< deformable bodies: asleep or not (sim/sleep/sleep_settings.h)
  bool moved_this_step = true; ///< kinematic bodies: pose changed in the last integrate stage

  bool is_kinematic() const { return motion == BodyMotion::kinematic; }
  /// True while the body sleeps (not integrated; immovable in contact).
  bool is_sleeping() const { return sleep.sleeping; }
  /// True if vertex v cannot be moved by contact (kinematic or sleeping body, or fixed vertex).
  bool is_immovable(int v) const {
    return is_kinematic() || sleep.sleeping || fixed[static_cast<size_t>(v)] != 0;
  }
  int vertex_count() const { return static_cast<int>(positions.size()); }
  double total_mass() const;
};

}  // namespace pliant
