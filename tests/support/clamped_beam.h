// A beam 1 x 0.1 x 0.1 m clamped at x = -0.5, the body the corotational FEM's step tests advance.
#pragma once

#include <functional>
#include <vector>

#include "sim/material.h"
#include "sim/mesh/box_mesh.h"
#include "sim/model/deformation_model.h"

namespace pliant {

/// Soft beam (E 100 kPa, nu 0.45, 1000 kg/m^3, Rayleigh 1 / 0.01) clamped at its x = -0.5 end; each
/// free vertex carries the external force load(rest position, mass) (N); steps of 5 ms.
struct ClampedBeam {
  TetMeshPtr mesh;
  Material material;
  std::vector<double> masses;
  std::vector<char> fixed;
  std::vector<Vec3> external;
  std::vector<Vec3> x;
  std::vector<Vec3> v;

  ClampedBeam(int cells_along, const std::function<Vec3(const Vec3&, double)>& load)
      : mesh(make_box_mesh({Vec3(1.0, 0.1, 0.1), cells_along, 2, 2})) {
    material.young_modulus = 1e5;
    material.poisson_ratio = 0.45;
    material.density = 1000.0;
    material.mass_damping = 1.0;
    material.stiffness_damping = 0.01;
    masses = mesh->lumped_masses(material.density);
    x = mesh->rest_positions();
    v.assign(x.size(), Vec3::Zero());
    fixed.assign(x.size(), 0);
    external.assign(x.size(), Vec3::Zero());
    for (size_t i = 0; i < x.size(); ++i) {
      fixed[i] = x[i].x() < -0.5 + 1e-12 ? 1 : 0;
      external[i] = load(x[i], masses[i]);
    }
  }

  /// One 5 ms step's input.
  IntegrationInput input() const { return {masses, fixed, external, 5e-3}; }
};

/// The beam at 20 cells with no gravity and its outer 15% pushed sideways and down: the tip swings
/// (its tets rotate past the K' reuse tolerance) while the part near the clamp barely rotates (its
/// rows are reused), the workload of the K' reuse and incremental-system tests.
struct TipPushedBeam : ClampedBeam {
  TipPushedBeam()
      : ClampedBeam(20, [](const Vec3& rest, double m) {
          return rest.x() > 0.35 ? Vec3(m * Vec3(0.0, 3.0, -6.0)) : Vec3::Zero();
        }) {}
};

}  // namespace pliant
