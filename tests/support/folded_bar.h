// A bar folded onto itself: the self-collision scene shared by the contact-triangle and tet-walk
// tests (one body whose surface penetrates its own surface).
#pragma once

#include <algorithm>
#include <numbers>
#include <vector>

#include "sim/collision/contact_types.h"
#include "sim/math_types.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {

/// A 1 x 0.3 x 0.1 m bar (20 x 6 x 2 cells) whose first 0.15 m (in x) is turned by up to 0.97 pi
/// about z and lifted by up to 3 cm, so its far part lies folded through its near part.
struct FoldedBar {
  TetMeshPtr mesh = make_box_mesh({Vec3(1.0, 0.3, 0.1), 20, 6, 2});  ///< the bar's rest mesh
  std::vector<Vec3> x = folded_positions(*mesh);                     ///< folded positions (m)

  /// The folded positions of `mesh`'s rest positions.
  static std::vector<Vec3> folded_positions(const TetMesh& mesh) {
    std::vector<Vec3> folded;
    for (const Vec3& p : mesh.rest_positions()) {
      const double f = std::clamp(p.x() / 0.15, 0.0, 1.0);
      folded.push_back(Eigen::AngleAxisd(0.97 * std::numbers::pi * f, Vec3::UnitZ()) * p +
                       Vec3(0.0, 0.0, 0.03 * f));
    }
    return folded;
  }

  /// The bar as one self-colliding body at the folded positions (a view of x).
  std::vector<CollisionBody> bodies() const {
    std::vector<CollisionBody> b(1);
    b[0].mesh = mesh.get();
    b[0].positions = x;
    b[0].self_collision = true;
    return b;
  }
};

}  // namespace pliant
