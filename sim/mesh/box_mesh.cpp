#include "sim/mesh/box_mesh.h"

#include "sim/input_error.h"

namespace pliant {

TetMeshPtr make_box_mesh(const BoxMeshSpec& spec) {
  if (spec.nx < 1 || spec.ny < 1 || spec.nz < 1) {
    throw InputError(InputErrorKind::bad_value, "box", "cell counts must be at least 1");
  }
  if (!(spec.size.array() > 0.0).all() || !spec.size.allFinite()) {
    throw InputError(InputErrorKind::bad_value, "box", "size must be positive and finite");
  }
  const int nx = spec.nx, ny = spec.ny, nz = spec.nz;
  auto id = [&](int i, int j, int k) { return (k * (ny + 1) + j) * (nx + 1) + i; };
  std::vector<Vec3> x;
  x.reserve(static_cast<size_t>((nx + 1) * (ny + 1) * (nz + 1)));
  const Vec3 origin = -0.5 * spec.size;
  for (int k = 0; k <= nz; ++k) {
    for (int j = 0; j <= ny; ++j) {
      for (int i = 0; i <= nx; ++i) {
        x.push_back(origin + Vec3(spec.size.x() * i / nx, spec.size.y() * j / ny, spec.size.z() * k / nz));
      }
    }
  }
  // Kuhn simplices: walk from corner (0,0,0) to (1,1,1) stepping one axis at a time, in each of
  // the six axis orders.
  constexpr int kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  std::vector<TetIndices> tets;
  tets.reserve(static_cast<size_t>(6 * nx * ny * nz));
  for (int k = 0; k < nz; ++k) {
    for (int j = 0; j < ny; ++j) {
      for (int i = 0; i < nx; ++i) {
        for (const auto& order : kOrders) {
          int c[3] = {i, j, k};
          TetIndices tet{};
          tet[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            c[order[s]] += 1;
            tet[static_cast<size_t>(s) + 1] = id(c[0], c[1], c[2]);
          }
          tets.push_back(tet);  // orientation fixed by TetMesh::build
        }
      }
    }
  }
  return TetMesh::build(std::move(x), std::move(tets), "box");
}

}  // namespace pliant
