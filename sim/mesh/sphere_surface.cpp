// Incremental convex hull (Clarkson-Shor style, O(n^2) without a conflict graph: fine for the few
// thousand points a simulation sphere has). All points lie on the hull, none are coplanar with a
// face in exact arithmetic, and the tolerance only guards rounding.
#include "sim/mesh/sphere_surface.h"

#include <cassert>
#include <cmath>
#include <map>
#include <numbers>

namespace pliant {

SphereTriangulation fibonacci_sphere_triangulation(int n) {
  assert(n >= 4);
  SphereTriangulation s;
  const double golden_angle = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden_angle * i;
    s.points.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  const auto& p = s.points;
  auto at = [&](int i) -> const Vec3& { return p[static_cast<size_t>(i)]; };

  // Start from a big tetrahedron: first point, farthest point, largest triangle, largest volume.
  int i0 = 0, i1 = 1, i2 = 2, i3 = 3;
  for (int i = 1; i < n; ++i) if ((at(i) - at(i0)).squaredNorm() > (at(i1) - at(i0)).squaredNorm()) i1 = i;
  double best = -1.0;
  for (int i = 0; i < n; ++i) {
    const double a = (at(i1) - at(i0)).cross(at(i) - at(i0)).squaredNorm();
    if (i != i0 && i != i1 && a > best) best = a, i2 = i;
  }
  best = -1.0;
  for (int i = 0; i < n; ++i) {
    const double v = std::abs(signed_tet_volume(at(i0), at(i1), at(i2), at(i)));
    if (i != i0 && i != i1 && i != i2 && v > best) best = v, i3 = i;
  }
  if (signed_tet_volume(at(i0), at(i1), at(i2), at(i3)) < 0.0) std::swap(i2, i3);
  // Faces of the positive tet (i0, i1, i2, i3), outward.
  std::vector<TriIndices> faces = {{i1, i2, i3}, {i0, i3, i2}, {i0, i1, i3}, {i0, i2, i1}};
  std::vector<char> alive(4, 1);

  const double eps = 1e-12;
  for (int i = 0; i < n; ++i) {
    if (i == i0 || i == i1 || i == i2 || i == i3) continue;
    const Vec3& q = at(i);
    // Faces that see q; their boundary (directed edges without their reverse) is the horizon.
    std::map<std::pair<int, int>, int> visible_edges;
    std::vector<size_t> visible;
    for (size_t f = 0; f < faces.size(); ++f) {
      if (!alive[f]) continue;
      const auto& t = faces[f];
      const Vec3 normal = (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0]));
      if (normal.dot(q - at(t[0])) > eps * normal.norm()) visible.push_back(f);
    }
    assert(!visible.empty());
    for (size_t f : visible) {
      alive[f] = 0;
      const auto& t = faces[f];
      for (int k = 0; k < 3; ++k) visible_edges[{t[static_cast<size_t>(k)], t[static_cast<size_t>((k + 1) % 3)]}] = 1;
    }
    for (const auto& [edge, unused] : visible_edges) {
      if (visible_edges.count({edge.second, edge.first}) == 0) {
        faces.push_back({edge.first, edge.second, i});
        alive.push_back(1);
      }
    }
  }
  for (size_t f = 0; f < faces.size(); ++f) {
    if (alive[f]) s.triangles.push_back(faces[f]);
  }
  return s;
}

}  // namespace pliant
