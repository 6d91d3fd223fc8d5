#include "sim/mesh/cylinder_mesh.h"

#include <cmath>
#include <numbers>

#include "sim/input_error.h"
#include "sim/mesh/prism_split.h"

namespace pliant {
namespace {

// Disc of radius r: centre vertex 0, ring k (1..n) with 6k vertices; triangles counter-clockwise.
void make_disc(double r, int n, std::vector<Vec2>& points, std::vector<TriIndices>& triangles) {
  points.emplace_back(0.0, 0.0);
  std::vector<int> ring_start = {0};
  for (int k = 1; k <= n; ++k) {
    ring_start.push_back(static_cast<int>(points.size()));
    const int m = 6 * k;
    for (int i = 0; i < m; ++i) {
      const double angle = 2.0 * std::numbers::pi * i / m;
      points.emplace_back(r * k / n * std::cos(angle), r * k / n * std::sin(angle));
    }
  }
  // Zip ring k-1 (m_in vertices) to ring k (m_out), always advancing the ring whose next vertex
  // comes first in angle; ring 0 is the centre.
  for (int k = 1; k <= n; ++k) {
    const int m_in = k == 1 ? 1 : 6 * (k - 1), m_out = 6 * k;
    const int in0 = ring_start[static_cast<size_t>(k - 1)], out0 = ring_start[static_cast<size_t>(k)];
    int i = k == 1 ? m_in : 0, j = 0;  // the centre has nothing to advance
    while (i < m_in || j < m_out) {
      const int a = in0 + i % m_in, b = out0 + j % m_out;
      const bool advance_out = i == m_in ||
                               (j < m_out && static_cast<double>(j + 1) / m_out <= static_cast<double>(i + 1) / m_in);
      if (advance_out) {
        triangles.push_back({a, b, out0 + (j + 1) % m_out});
        ++j;
      } else {
        triangles.push_back({a, b, in0 + (i + 1) % m_in});
        ++i;
      }
    }
  }
}

}  // namespace

TetMeshPtr make_cylinder_mesh(const CylinderMeshSpec& spec) {
  if (!std::isfinite(spec.radius) || !std::isfinite(spec.length) || !(spec.radius > 0.0) || !(spec.length > 0.0)) {
    throw InputError(InputErrorKind::bad_value, "cylinder", "radius and length must be positive and finite");
  }
  if (spec.radial_cells < 1 || spec.axial_cells < 1 || spec.radial_cells > 1000 || spec.axial_cells > 100000) {
    throw InputError(InputErrorKind::bad_value, "cylinder", "radial_cells and axial_cells must be at least 1");
  }
  std::vector<Vec2> disc;
  std::vector<TriIndices> triangles;
  make_disc(spec.radius, spec.radial_cells, disc, triangles);
  const int nd = static_cast<int>(disc.size());
  std::vector<Vec3> x;
  for (int l = 0; l <= spec.axial_cells; ++l) {
    const double z = -0.5 * spec.length + spec.length * l / spec.axial_cells;
    for (const Vec2& p : disc) x.emplace_back(p.x(), p.y(), z);
  }
  std::vector<TetIndices> tets;
  tets.reserve(3 * triangles.size() * static_cast<size_t>(spec.axial_cells));
  for (int l = 0; l < spec.axial_cells; ++l) {
    const int lo = l * nd, hi = (l + 1) * nd;
    for (const auto& t : triangles) split_prism({lo + t[0], lo + t[1], lo + t[2], hi + t[0], hi + t[1], hi + t[2]}, x, tets);
  }
  return TetMesh::build(std::move(x), std::move(tets), "cylinder");
}

}  // namespace pliant
