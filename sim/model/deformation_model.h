// One interface for deformation models (algorithms.md section 3). The contact-surface method only
// needs internal forces, re-evaluated locally after vertices are displaced, so the interface has a
// cheap local query beside the whole-body one. A model is per body and owns its per-step scratch.
#pragma once

#include <memory>
#include <span>
#include <string>

#include "sim/material.h"
#include "sim/math_types.h"
#include "sim/mesh/tet_mesh.h"

namespace pliant {

class TaskExecutor;

/// Which deformation model a body uses.
enum class ModelKind {
  corotational_fem,   ///< Mueller & Gross 2004, implicit Euler + CG (default)
  teschner_explicit,  ///< Teschner et al. 2004 constraint energies, Verlet (the paper's model)
};

/// Solver accuracy a model runs at; the real-time governor lowers and raises it within floors.
struct ModelAccuracy {
  int max_solver_iterations = 20;   ///< CG iteration cap per step (implicit models)
  double solver_tolerance = 1e-6;   ///< relative CG residual at which to stop
};

/// Default rotation tolerance (rad) of the corotational FEM's K' reuse between steps
/// (docs/deformation-models.md "K' reuse between steps").
inline constexpr double kDefaultStiffnessRotationTolerance = 1e-3;

/// Model settings from the scene. Fields a model does not use are ignored by it.
struct ModelSettings {
  ModelAccuracy accuracy;
  /// Teschner model stiffnesses (N/m-like constants of the constraint energies, E = k C^2 / 2).
  /// Zero means "derive from the material" (see docs/deformation-models.md).
  double distance_stiffness = 0.0;
  double volume_stiffness = 0.0;
  double area_stiffness = 0.0;
  double distance_damping = 0.0;  ///< k_d on distance constraints; zero means derive
  /// Corotational FEM: the SSOR-PCG iteration in the AVX2/FMA kernels where the CPU has them (the
  /// default since session 8); false: the exact sweeps, bit for bit the solve before session 8.
  bool fused_sweeps = true;
  /// Corotational FEM: the coarse (two-level) correction of the SSOR-PCG, deflation by the rigid
  /// translations of boxes of about this many free vertices (sim/model/coarse_correction.h; runs
  /// the exact sweeps). 0: off, the solve before session 13 bit for bit.
  int coarse_aggregate_size = 0;
  /// Corotational FEM: a tet's K' blocks are kept from the rotation they were built from until its
  /// rotation is more than this (rad) away from it; only the matrix of the linear solve changes, never
  /// the forces. 0: K' from the current rotations every step, exact.
  double stiffness_rotation_tolerance = kDefaultStiffnessRotationTolerance;
};

/// What one step of a model did.
struct IntegrationResult {
  int solver_iterations = 0;     ///< CG iterations used (0 for explicit models)
  double solver_residual = 0.0;  ///< final relative residual
  bool converged = true;         ///< false if the iteration cap was hit before the tolerance
  int substeps = 1;              ///< explicit substeps taken for the requested dt
};

/// Per-step inputs of time integration.
struct IntegrationInput {
  std::span<const double> masses;         ///< lumped vertex masses (kg)
  std::span<const char> fixed;            ///< 1 where a vertex is held in place
  std::span<const Vec3> external_forces;  ///< gravity plus applied forces (N), per vertex
  double dt = 1e-3;                       ///< step (s)
  /// Optional normal constraints (Baraff & Witkin 1998, sec. 5.3; empty: none, the unconstrained
  /// step). Per vertex a unit normal n (the direction a contact pushes it) along which the new
  /// velocity is prescribed, v_{n+1} . n = constraint_normal_velocities[i] (m/s), or the zero vector
  /// where the vertex is free. Models that cannot constrain their solve ignore it.
  std::span<const Vec3> constraint_normals;
  std::span<const double> constraint_normal_velocities;  ///< m/s, per vertex (read where n != 0)
  /// Optional output (empty: not written): per vertex, the constraint force (N) along n the solve
  /// applied over the step; a constraint that would pull (force . n < 0) is released.
  std::span<Vec3> constraint_forces;
};

class DeformationModel {
 public:
  virtual ~DeformationModel() = default;

  virtual ModelKind kind() const = 0;

  /// Internal elastic forces (N) on every vertex at positions x. f.size() == vertex count.
  virtual void internal_forces(std::span<const Vec3> x, std::span<Vec3> f) = 0;

  /// Internal forces at `vertices` only (f[i] belongs to vertices[i]), evaluating only the elements
  /// adjacent to them. Called several times per step inside the contact binary search.
  virtual void internal_forces_at(std::span<const Vec3> x, std::span<const int> vertices,
                                  std::span<Vec3> f) = 0;

  /// A cheaper internal_forces_at for small displacements from the state the last `advance` left
  /// (the contact stage's binary search): models with element rotations may keep them frozen at
  /// that state (first-order error in the rotation change, see docs/deformation-models.md). The
  /// default is the exact internal_forces_at.
  virtual void internal_forces_at_frozen_rotations(std::span<const Vec3> x, std::span<const int> vertices,
                                                   std::span<Vec3> f) {
    internal_forces_at(x, vertices, f);
  }

  /// internal_forces_at for the contact stage's binary search, allowed to reuse an element rotation
  /// extracted earlier (in any query or step) where the element's deformation gradient has since
  /// moved by at most `rotation_tolerance` (Frobenius norm of the change in F, dimensionless).
  /// Tolerance 0 must be the exact internal_forces_at, which is also the default.
  virtual void internal_forces_at_nearby_rotations(std::span<const Vec3> x, std::span<const int> vertices,
                                                   std::span<Vec3> f, double rotation_tolerance) {
    (void)rotation_tolerance;
    internal_forces_at(x, vertices, f);
  }

  /// The stiffness matrix K' the last `advance` solved with (element rotations frozen), applied to
  /// displacements d (m) at the `moved` vertices (zero elsewhere): y[k] = sum_j K'_{rows[k] j} d_j (N).
  /// With rotations frozen the internal force is linear in x, f(x1 + d) = f(x1) - K' d (the
  /// contact stage's linearised binary search). Returns false where the model holds no such
  /// matrix, or where a move changes an element's deformation gradient by more than
  /// `strain_tolerance` (|d| |grad N|, dimensionless; a sliver's rotation turns fast): the caller
  /// then asks a force query. The default: false.
  virtual bool stiffness_product_at(std::span<const int> moved, std::span<const Vec3> d, std::span<const int> rows,
                                    std::span<Vec3> y, double strain_tolerance) {
    (void)moved, (void)d, (void)rows, (void)y, (void)strain_tolerance;
    return false;
  }

  /// Elastic energy (J) at positions x; internal_forces is its negative gradient.
  virtual double elastic_energy(std::span<const Vec3> x) = 0;

  /// Advances positions x and velocities v by one step of in.dt (fixed vertices stay put).
  virtual IntegrationResult advance(std::span<Vec3> x, std::span<Vec3> v, const IntegrationInput& in) = 0;

  virtual void set_accuracy(const ModelAccuracy& accuracy) = 0;
  virtual ModelAccuracy accuracy() const = 0;

  /// Runs the model's per-element loops through `executor` (not owned; null: one thread). A model
  /// must give the same bits for every thread count; the default ignores it (one thread).
  virtual void set_executor(TaskExecutor* executor) { (void)executor; }
};

/// Creates a model for a mesh and material. Throws InputError for settings it cannot use.
std::unique_ptr<DeformationModel> make_deformation_model(ModelKind kind, TetMeshPtr mesh,
                                                         const Material& material,
                                                         const ModelSettings& settings);

/// "corotational_fem" / "teschner_explicit".
const char* to_string(ModelKind kind);

}  // namespace pliant
