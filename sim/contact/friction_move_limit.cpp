#include "sim/contact/friction_move_limit.h"

#include <cmath>

namespace pliant {

double vertex_stiffness_along(const Body& body, int vertex, const Vec3& direction) {
  const TetMesh& mesh = *body.mesh;
  const auto& x = mesh.rest_positions();
  const double mu = body.material.lame_mu(), lambda = body.material.lame_lambda();
  double k = 0.0;
  for (int t : mesh.vertex_tets(vertex)) {
    const TetIndices& tet = mesh.tets()[static_cast<size_t>(t)];
    Vec3 face[3];
    int n = 0;
    for (int a = 0; a < 4; ++a) {
      if (tet[static_cast<size_t>(a)] != vertex)
        face[n++] = x[static_cast<size_t>(tet[static_cast<size_t>(a)])];
    }
    const double volume = mesh.rest_volumes()[static_cast<size_t>(t)];
    if (!(volume > 0.0)) continue;
    // grad N of the vertex: the opposite face's area normal / (3 V) (its sign does not matter here).
    const Vec3 g = 0.5 * (face[1] - face[0]).cross(face[2] - face[0]) / (3.0 * volume);
    k += volume * (mu * g.squaredNorm() + (lambda + mu) * std::pow(g.dot(direction), 2));
  }
  return k;
}

double friction_move_scale(const Body& body, int vertex, const Vec3& direction, double dt) {
  if (body.is_immovable(vertex)) return 1.0;
  const double k = vertex_stiffness_along(body, vertex, direction);
  const double m = body.masses[static_cast<size_t>(vertex)];
  const double omega_dt_sq = k * dt * dt / m;
  return omega_dt_sq > 1.0 ? 1.0 / std::sqrt(omega_dt_sq) : 1.0;
}

}  // namespace pliant
