// Teschner, Heidelberger, Mueller & Gross, "A Versatile and Robust Model for Geometrically Complex
// Deformable Solids" (CGI 2004): constraint energies E = k C^2 / 2 on tet edges (distance), tets
// (signed volume) and surface triangles (area), forces F_i = -k C dC/dp_i, damping on the distance
// terms only, F_i = (-k C - k_d sum_j dC/dp_j . v_j) dC/dp_i, and Verlet integration. Design note:
// - Position Verlet with x_prev = x - h v is symplectic Euler, v+ = v + h a, x+ = x + h v+, which is
//   the form used here: it keeps no x_prev, so the contact stage may edit x and v between steps.
// - Zero stiffness settings are derived from the material per constraint, scaled by the volume (or
//   area) the constraint stands for, so the model converges under refinement (docs/deformation-models.md).
// - The step is split into equal substeps no longer than the stable step, estimated from a Gershgorin
//   bound on the highest constraint frequency (omega^2 <= max_i sum_c k_c |dC/dp_i| sum_j |dC/dp_j| / m_i).
#pragma once

#include <vector>

#include "sim/model/deformation_model.h"

namespace pliant {

class TeschnerExplicit final : public DeformationModel {
 public:
  /// Builds constraints and their stiffnesses; settings stiffnesses of zero are derived from the material.
  TeschnerExplicit(TetMeshPtr mesh, const Material& material, const ModelSettings& settings);

  ModelKind kind() const override { return ModelKind::teschner_explicit; }
  void internal_forces(std::span<const Vec3> x, std::span<Vec3> f) override;
  void internal_forces_at(std::span<const Vec3> x, std::span<const int> vertices, std::span<Vec3> f) override;
  double elastic_energy(std::span<const Vec3> x) override;
  IntegrationResult advance(std::span<Vec3> x, std::span<Vec3> v, const IntegrationInput& in) override;
  void set_accuracy(const ModelAccuracy& accuracy) override { accuracy_ = accuracy; }
  ModelAccuracy accuracy() const override { return accuracy_; }

  /// Largest stable step (s) for these lumped masses, safety factor included.
  double stable_time_step(std::span<const double> masses) const;

  /// Safety factor applied to the estimated stability limit 2/omega.
  static constexpr double kStabilitySafety = 0.5;
  /// Substeps are capped here; a step needing more runs at the cap (and may be unstable).
  static constexpr int kMaxSubsteps = 100000;

 private:
  // Force of all constraints on vertex v only (damped if vel is given).
  Vec3 vertex_force(std::span<const Vec3> x, const Vec3* vel, int v) const;
  void forces(std::span<const Vec3> x, const Vec3* vel, std::span<Vec3> f) const;
  // Factor on derived damping that keeps the highest mode (omega, rad/s) at most critically damped.
  double damping_scale_for(double omega) const;

  TetMeshPtr mesh_;
  ModelAccuracy accuracy_;
  double alpha_ = 0.0;  ///< Rayleigh mass damping (1/s), applied as -alpha m v

  std::vector<double> edge_rest_length_;   ///< D0 (m)
  std::vector<double> edge_stiffness_;     ///< k (J)
  std::vector<double> edge_damping_;       ///< k_d (J s)
  std::vector<double> tet_stiffness_;      ///< k (J) on (V - V0)/V0
  std::vector<double> triangle_rest_area_; ///< A0 (m^2)
  std::vector<double> triangle_stiffness_; ///< k (J) on (A - A0)/A0
  std::vector<int> vertex_edge_offsets_, vertex_edges_;  ///< edges at each vertex (CSR)
  std::vector<double> frequency_bound_;   ///< per vertex: sum_c k_c |dC/dp_i| sum_j |dC/dp_j| at rest (N/m)
  double max_damping_ratio_ = 0.0;        ///< max k_d / k over edges (s)
  bool derived_damping_ = true;           ///< k_d derived from Rayleigh beta (and so capped)
  double damping_scale_ = 1.0;            ///< caps derived damping at critical for the top mode

  std::vector<Vec3> accel_;  ///< scratch
};

}  // namespace pliant
