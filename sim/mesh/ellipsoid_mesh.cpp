#include "sim/mesh/ellipsoid_mesh.h"

#include "sim/input_error.h"
#include "sim/mesh/sphere_mesh.h"

namespace pliant {

TetMeshPtr make_ellipsoid_mesh(const EllipsoidMeshSpec& spec) {
  if (!spec.semi_axes.allFinite() || !(spec.semi_axes.array() > 0.0).all()) {
    throw InputError(InputErrorKind::bad_value, "ellipsoid", "semi-axes must be positive and finite");
  }
  const TetMeshPtr unit = make_sphere_mesh({1.0, spec.surface_vertices, spec.shells});
  std::vector<Vec3> x = unit->rest_positions();
  for (Vec3& p : x) p = p.cwiseProduct(spec.semi_axes);
  // A positive diagonal scaling keeps the orientation of every tet.
  return TetMesh::build(std::move(x), unit->tets(), "ellipsoid");
}

}  // namespace pliant
