#include "interaction/instrument_meshes.h"

#include <algorithm>
#include <cmath>

#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

// Raw vertices and tets of the Kuhn box [-1, 1]^2 x [-1, 1] (or the given size), centred at 0.
RawTetMesh kuhn_box(const Vec3& size, int nx, int ny, int nz) {
  const TetMeshPtr box = make_box_mesh(BoxMeshSpec{size, nx, ny, nz});
  return RawTetMesh{box->rest_positions(), box->tets()};
}

// Cube surface point u (max |u_i| = 1) onto the unit sphere (cube-sphere map, cyclic in x, y, z).
Vec3 cube_to_sphere(const Vec3& u) {
  const double x2 = u.x() * u.x(), y2 = u.y() * u.y(), z2 = u.z() * u.z();
  return Vec3(u.x() * std::sqrt(std::max(0.0, 1.0 - y2 / 2.0 - z2 / 2.0 + y2 * z2 / 3.0)),
              u.y() * std::sqrt(std::max(0.0, 1.0 - z2 / 2.0 - x2 / 2.0 + z2 * x2 / 3.0)),
              u.z() * std::sqrt(std::max(0.0, 1.0 - x2 / 2.0 - y2 / 2.0 + x2 * y2 / 3.0)));
}

}  // namespace

RawTetMesh ball_tets(double radius, int cells, const Vec3& center) {
  cells = std::max(cells, 2);
  RawTetMesh raw = kuhn_box(Vec3::Constant(2.0), cells, cells, cells);
  for (Vec3& p : raw.positions) {
    // Shell |p|_inf = s goes to the sphere of radius s.
    const double s = p.cwiseAbs().maxCoeff();
    p = s > 0.0 ? Vec3(center + radius * s * cube_to_sphere(p / s)) : center;
  }
  return raw;
}

RawTetMesh cylinder_tets(double radius, double length, int cells, int length_cells, double z0) {
  cells = std::max(cells, 1);
  length_cells = std::max(length_cells, 1);
  RawTetMesh raw = kuhn_box(Vec3(2.0, 2.0, 1.0), cells, cells, length_cells);
  for (Vec3& p : raw.positions) {
    // Elliptical grid map of the square [-1, 1]^2 onto the unit disk.
    const double x = p.x(), y = p.y();
    p = Vec3(radius * x * std::sqrt(1.0 - y * y / 2.0), radius * y * std::sqrt(1.0 - x * x / 2.0),
             z0 + length * (p.z() + 0.5));
  }
  return raw;
}

RawTetMesh box_tets(const Vec3& min, const Vec3& max, int nx, int ny, int nz) {
  RawTetMesh raw = kuhn_box(max - min, std::max(nx, 1), std::max(ny, 1), std::max(nz, 1));
  const Vec3 center = 0.5 * (min + max);
  for (Vec3& p : raw.positions) p += center;
  return raw;
}

RawTetMesh merge(const std::vector<RawTetMesh>& parts) {
  RawTetMesh out;
  for (const RawTetMesh& part : parts) {
    const int offset = static_cast<int>(out.positions.size());
    out.positions.insert(out.positions.end(), part.positions.begin(), part.positions.end());
    for (TetIndices t : part.tets) {
      for (int& v : t) v += offset;
      out.tets.push_back(t);
    }
  }
  return out;
}

TetMeshPtr build_instrument_mesh(RawTetMesh raw, const std::string& source) {
  return TetMesh::build(std::move(raw.positions), std::move(raw.tets), source);
}

int cells_along(double length, double cell_size) {
  if (!(cell_size > 0.0)) return 1;
  const double n = std::round(length / cell_size);
  return static_cast<int>(std::clamp(n, 1.0, 64.0));
}

double tet_radius_ratio(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 u = b - a, v = c - a, w = d - a;
  const double six_v = std::abs(u.dot(v.cross(w)));
  if (six_v == 0.0) return 0.0;
  // Inradius 3V / (total face area); circumradius |u^2 (v x w) + v^2 (w x u) + w^2 (u x v)| / (12 V).
  const double area = 0.5 * ((b - a).cross(c - a).norm() + (b - a).cross(d - a).norm() +
                             (c - a).cross(d - a).norm() + (c - b).cross(d - b).norm());
  const double r_in = 0.5 * six_v / area;
  const double r_out =
      (u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u) + w.squaredNorm() * u.cross(v)).norm() /
      (2.0 * six_v);
  return 3.0 * r_in / r_out;
}

}  // namespace pliant
