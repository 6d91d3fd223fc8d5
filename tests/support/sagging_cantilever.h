// A box cantilever fixed at its x = -length/2 end, loaded by gravity, stepped at 10 ms: the body
// the kernel tests (fused SSOR sweeps, AVX2 stiffness rows) advance beside the exact path.
#pragma once

#include <vector>

#include "sim/material.h"
#include "sim/mesh/box_mesh.h"
#include "sim/model/deformation_model.h"

namespace pliant {

/// length x width x width m, cells_along x cells_across x cells_across cells, E young_modulus
/// (Pa), nu 0.45, 1000 kg/m^3, stiffness damping 0.01 (so the K' blocks enter the system).
struct SaggingCantilever {
  TetMeshPtr mesh;
  Material m;
  size_t n = 0;
  std::vector<double> masses;
  std::vector<char> fixed;
  std::vector<Vec3> ext;
  std::vector<Vec3> x, v;

  SaggingCantilever(double length, double width, int cells_along, int cells_across, double young_modulus)
      : mesh(make_box_mesh({Vec3(length, width, width), cells_along, cells_across, cells_across})) {
    m.young_modulus = young_modulus;
    m.poisson_ratio = 0.45;
    m.density = 1000.0;
    m.stiffness_damping = 0.01;
    n = static_cast<size_t>(mesh->vertex_count());
    masses = mesh->lumped_masses(m.density);
    x = mesh->rest_positions();
    v.assign(n, Vec3::Zero());
    fixed.assign(n, 0);
    ext.assign(n, Vec3::Zero());
    for (size_t i = 0; i < n; ++i) {
      fixed[i] = x[i].x() < -0.5 * length + 1e-12 ? 1 : 0;
      ext[i] = masses[i] * Vec3(0, 0, -9.81);
    }
  }

  /// One 10 ms step of `model` from (x, v).
  IntegrationResult step(DeformationModel& model) { return model.advance(x, v, {masses, fixed, ext, 1e-2}); }
};

}  // namespace pliant
