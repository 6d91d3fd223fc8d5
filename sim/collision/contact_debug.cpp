#include "sim/collision/contact_debug.h"

#include <vector>

#include "sim/io/vtu_writer.h"

namespace pliant {

void write_contact_debug_vtu(const std::string& points_path, const std::string& triangles_path,
                             std::span<const CollisionBody> bodies, std::span<const VertexContact> contacts) {
  // Colliding vertices with their depth vectors.
  std::vector<Vec3> points;
  VtuCells vertices{VtuCellType::vertex, {}};
  std::vector<VtuPointField> fields = {
      {"depth_vector", 3, {}},         {"penetration_depth", 1, {}}, {"penetration_direction", 3, {}},
      {"contact_point_offset", 3, {}}, {"depth_source", 1, {}},      {"layer", 1, {}},
      {"triangle_source", 1, {}},      {"body", 1, {}},              {"vertex", 1, {}},
      {"penetrated_body", 1, {}},
  };
  auto push3 = [](VtuPointField& f, const Vec3& v) { f.values.insert(f.values.end(), {v.x(), v.y(), v.z()}); };
  for (const VertexContact& c : contacts) {
    const Vec3& x = bodies[static_cast<size_t>(c.body)].positions[static_cast<size_t>(c.vertex)];
    vertices.connectivity.push_back(static_cast<int>(points.size()));
    points.push_back(x);
    push3(fields[0], c.depth_vector());
    fields[1].values.push_back(c.penetration_depth);
    push3(fields[2], c.penetration_direction);
    push3(fields[3], c.contact_point - x);
    fields[4].values.push_back(static_cast<double>(c.depth_source));
    fields[5].values.push_back(c.layer);
    fields[6].values.push_back(static_cast<double>(c.triangle_source));
    fields[7].values.push_back(c.body);
    fields[8].values.push_back(c.vertex);
    fields[9].values.push_back(c.penetrated_body);
  }
  write_vtu(points_path, points, vertices, fields);

  // Contact triangles at the penetrated bodies' current positions.
  std::vector<Vec3> corners;
  VtuCells triangles{VtuCellType::triangle, {}};
  std::vector<VtuPointField> triangle_fields = {{"contact", 1, {}}, {"barycentric", 1, {}}};
  for (size_t i = 0; i < contacts.size(); ++i) {
    const VertexContact& c = contacts[i];
    if (c.contact_triangle < 0) continue;
    const CollisionBody& pen = bodies[static_cast<size_t>(c.penetrated_body)];
    const TriIndices& tri = pen.mesh->surface_triangles()[static_cast<size_t>(c.contact_triangle)];
    for (int k = 0; k < 3; ++k) {
      triangles.connectivity.push_back(static_cast<int>(corners.size()));
      corners.push_back(pen.positions[static_cast<size_t>(tri[static_cast<size_t>(k)])]);
      triangle_fields[0].values.push_back(static_cast<double>(i));
      triangle_fields[1].values.push_back(c.contact_barycentric[k]);
    }
  }
  write_vtu(triangles_path, corners, triangles, triangle_fields);
}

}  // namespace pliant
