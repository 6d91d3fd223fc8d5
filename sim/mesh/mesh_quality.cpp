#include "sim/mesh/mesh_quality.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace pliant {

TetQuality compute_tet_quality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 p[4] = {a, b, c, d};
  // Area vectors of the faces opposite each vertex, pointing away from that vertex (outward).
  Vec3 n[4];
  double area_sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    const Vec3& u = p[(i + 1) % 4];
    const Vec3& v = p[(i + 2) % 4];
    const Vec3& w = p[(i + 3) % 4];
    Vec3 normal = (v - u).cross(w - u);
    if (normal.dot(p[i] - u) > 0.0) normal = -normal;
    n[i] = normal;
    area_sum += 0.5 * normal.norm();
  }
  TetQuality q;
  q.min_dihedral_deg = 180.0;
  q.max_dihedral_deg = 0.0;
  // The dihedral angle at the edge shared by the faces opposite i and j is pi minus the angle
  // between their outward normals.
  for (int i = 0; i < 4; ++i) {
    for (int j = i + 1; j < 4; ++j) {
      const double denom = n[i].norm() * n[j].norm();
      const double cosine = denom > 0.0 ? std::clamp(n[i].dot(n[j]) / denom, -1.0, 1.0) : 1.0;
      const double angle = 180.0 - std::acos(cosine) * 180.0 / std::numbers::pi;
      q.min_dihedral_deg = std::min(q.min_dihedral_deg, angle);
      q.max_dihedral_deg = std::max(q.max_dihedral_deg, angle);
    }
  }
  // r_in = 3V / (sum of face areas); R_circ = |l_a^2 (b x c) + l_b^2 (c x a) + l_c^2 (a x b)| / (12 V)
  // with edge vectors from vertex a.
  const Vec3 e1 = b - a, e2 = c - a, e3 = d - a;
  const double six_volume = std::abs(e1.dot(e2.cross(e3)));
  if (six_volume > 0.0 && area_sum > 0.0) {
    const double r_in = 0.5 * six_volume / area_sum;
    const Vec3 m = e1.squaredNorm() * e2.cross(e3) + e2.squaredNorm() * e3.cross(e1) + e3.squaredNorm() * e1.cross(e2);
    const double r_circ = m.norm() / (2.0 * six_volume);
    q.radius_ratio = std::min(1.0, 3.0 * r_in / r_circ);
  }
  return q;
}

MeshQuality compute_mesh_quality(const TetMesh& mesh) {
  MeshQuality q;
  q.min_dihedral_deg = 180.0;
  q.max_dihedral_deg = 0.0;
  q.min_volume = std::numeric_limits<double>::infinity();
  q.max_volume = 0.0;
  q.min_radius_ratio = 1.0;
  double sum_ratio = 0.0;
  const auto& x = mesh.rest_positions();
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const auto& tet = mesh.tets()[static_cast<size_t>(t)];
    const TetQuality tq = compute_tet_quality(x[static_cast<size_t>(tet[0])], x[static_cast<size_t>(tet[1])],
                                              x[static_cast<size_t>(tet[2])], x[static_cast<size_t>(tet[3])]);
    q.min_dihedral_deg = std::min(q.min_dihedral_deg, tq.min_dihedral_deg);
    q.max_dihedral_deg = std::max(q.max_dihedral_deg, tq.max_dihedral_deg);
    if (tq.radius_ratio < q.min_radius_ratio || q.worst_tet < 0) {
      q.min_radius_ratio = std::min(q.min_radius_ratio, tq.radius_ratio);
      q.worst_tet = t;
    }
    sum_ratio += tq.radius_ratio;
    const double v = mesh.rest_volumes()[static_cast<size_t>(t)];
    q.min_volume = std::min(q.min_volume, v);
    q.max_volume = std::max(q.max_volume, v);
  }
  q.mean_radius_ratio = sum_ratio / static_cast<double>(std::max(1, mesh.tet_count()));
  q.volume_ratio = q.max_volume > 0.0 ? q.min_volume / q.max_volume : 0.0;
  return q;
}

}  // namespace pliant
