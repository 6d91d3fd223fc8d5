#include "interaction/instrument_meshes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

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
  // An inner cube of half-size kInner * radius (Kuhn cells) inside a shell of six blocks of
  // hexahedra between the cube's faces and the sphere (cube-sphere map), split into Kuhn tets.
  // Every shell tet spans two radial layers, so none has all four vertices on the sphere (a
  // Kuhn-cube-then-project ball does, and its corner tets become slivers as cells shrink).
  // Local axes of each block are the two other global axes in increasing order plus the outward
  // radius, so the face diagonals of neighbouring cells agree everywhere (conforming mesh).
  constexpr double kInner = 0.35;
  const int n = std::max(cells, 2);
  const int layers = std::max(1, static_cast<int>(std::lround((1.0 - kInner) / (2.0 * kInner / n))));
  const auto grid = [n](int i) { return -1.0 + 2.0 * i / n; };
  RawTetMesh raw;
  std::map<std::array<int, 4>, int> index;  // (I, J, K, layer) -> vertex
  const auto vertex = [&](int i, int j, int k, int layer) {
    const std::array<int, 4> key{i, j, k, layer};
    auto [it, inserted] = index.try_emplace(key, static_cast<int>(raw.positions.size()));
    if (inserted) {
      const Vec3 c(grid(i), grid(j), grid(k));
      const Vec3 inner = kInner * c;
      const Vec3 outer = cube_to_sphere(c);
      const Vec3 p = layer == layers ? outer : Vec3(inner + (static_cast<double>(layer) / layers) * (outer - inner));
      raw.positions.push_back(center + radius * p);
    }
    return it->second;
  };
  constexpr int kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  // Kuhn split of a cell whose corner (a, b, c) + (da, db, dc) maps to a vertex through `at`.
  const auto kuhn = [&](const auto& at) {
    for (const auto& order : kOrders) {
      int d[3] = {0, 0, 0};
      TetIndices tet{};
      tet[0] = at(0, 0, 0);
      for (int s = 0; s < 3; ++s) {
        d[order[s]] = 1;
        tet[static_cast<size_t>(s) + 1] = at(d[0], d[1], d[2]);
      }
      raw.tets.push_back(tet);  // orientation fixed by TetMesh::build
    }
  };
  // Inner cube (layer 0).
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        kuhn([&](int a, int b, int c) { return vertex(i + a, j + b, k + c, 0); });
      }
    }
  }
  // Shell: for each face (normal axis, side), cells (u, v) over the other two axes, layers outward.
  for (int axis = 0; axis < 3; ++axis) {
    const int ua = axis == 0 ? 1 : 0, va = axis == 2 ? 1 : 2;
    for (int side : {0, n}) {
      for (int v = 0; v < n; ++v) {
        for (int u = 0; u < n; ++u) {
          for (int l = 0; l < layers; ++l) {
            kuhn([&](int du, int dv, int dl) {
              int ijk[3];
              ijk[axis] = side;
              ijk[ua] = u + du;
              ijk[va] = v + dv;
              return vertex(ijk[0], ijk[1], ijk[2], l + dl);
            });
          }
        }
      }
    }
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
