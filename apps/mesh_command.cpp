#include "apps/mesh_command.h"

#include <map>

#include "sim/io/tet_mesh_reader.h"
#include "sim/mesh/mesh_quality.h"

namespace pliant {
namespace {

std::ostream& operator<<(std::ostream& out, const Vec3& v) {
  return out << '(' << v.x() << ", " << v.y() << ", " << v.z() << ')';
}

}  // namespace

int run_mesh_info(const std::string& file, std::ostream& out) {
  TetMeshReadReport report;
  const TetMeshPtr mesh = read_tet_mesh(file, &report);
  const Aabb box = mesh->rest_bounds();
  const MeshQuality q = compute_mesh_quality(*mesh);
  out << "file:              " << file << '\n'
      << "format:            " << report.format << '\n'
      << "vertices:          " << mesh->vertex_count() << " (" << mesh->surface_vertices().size() << " on the surface)\n"
      << "tetrahedra:        " << mesh->tet_count() << '\n'
      << "surface triangles: " << mesh->surface_triangle_count() << '\n'
      << "edges:             " << mesh->edges().size() << " (mean length " << mesh->mean_edge_length() << " m)\n"
      << "volume:            " << mesh->total_rest_volume() << " m^3\n"
      << "bounding box:      min " << box.min << " max " << box.max << " extent " << box.extent() << " m\n";
  if (!mesh->tet_tags().empty()) {
    std::map<int, int> tags;
    for (int t : mesh->tet_tags()) tags[t]++;
    out << "tags:             ";
    for (const auto& [tag, count] : tags) out << ' ' << tag << " (" << count << " tets)";
    out << '\n';
  }
  out << "dihedral angles:   min " << q.min_dihedral_deg << " deg, max " << q.max_dihedral_deg << " deg\n"
      << "radius ratio:      min " << q.min_radius_ratio << " (tet " << q.worst_tet << "), mean " << q.mean_radius_ratio
      << " (1 = regular)\n"
      << "tet volumes:       min " << q.min_volume << " m^3, max " << q.max_volume << " m^3, ratio " << q.volume_ratio
      << '\n';
  const auto& flipped = report.build.reoriented_tets;
  out << "validation:        " << flipped.size() << " tets re-oriented";
  if (!flipped.empty()) {
    out << " (";
    for (size_t i = 0; i < flipped.size() && i < 10; ++i) out << (i > 0 ? ", " : "") << flipped[i];
    out << (flipped.size() > 10 ? ", ...)" : ")");
  }
  out << ", " << report.unused_vertices_removed << " unused vertices dropped, " << report.skipped_elements
      << " non-tetrahedral elements skipped\n";
  return 0;
}

int run_mesh_convert(const std::string& in, const std::string& out_path, std::ostream& out) {
  TetMeshReadReport report;
  const TetMeshPtr mesh = read_tet_mesh(in, &report);
  write_tet_mesh(out_path, *mesh);
  out << "wrote " << out_path << ": " << mesh->vertex_count() << " vertices, " << mesh->tet_count() << " tetrahedra";
  if (!report.build.reoriented_tets.empty()) out << " (" << report.build.reoriented_tets.size() << " re-oriented)";
  out << '\n';
  return 0;
}

}  // namespace pliant
