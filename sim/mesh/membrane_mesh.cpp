#include "sim/mesh/membrane_mesh.h"

#include <cmath>

#include "sim/input_error.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {

TetMeshPtr make_membrane_mesh(const MembraneMeshSpec& spec) {
  const Vec3 size(spec.width, spec.depth, spec.thickness);
  if (!size.allFinite() || !(size.array() > 0.0).all()) {
    throw InputError(InputErrorKind::bad_value, "membrane", "width, depth and thickness must be positive and finite");
  }
  if (spec.nx < 1 || spec.ny < 1 || spec.layers < 1) {
    throw InputError(InputErrorKind::bad_value, "membrane", "nx, ny and layers must be at least 1");
  }
  return make_box_mesh({size, spec.nx, spec.ny, spec.layers});
}

}  // namespace pliant
