#include "sim/io/tetgen_format.h"

#include <cmath>
#include <sstream>

#include "sim/io/atomic_file.h"
#include "sim/io/text_scanner.h"

namespace pliant {
namespace {

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Checks that a record line has exactly `expected` tokens.
void expect_tokens(const TextScanner& in, const ScannedLine& line, size_t expected, const std::string& what) {
  if (line.tokens.size() != expected) {
    in.fail(line.tokens.size() < expected ? InputErrorKind::syntax : InputErrorKind::count_mismatch,
            "expected " + std::to_string(expected) + " values (" + what + "), found " +
                std::to_string(line.tokens.size()));
  }
}

}  // namespace

TetGenPaths tetgen_paths(const std::string& path) {
  std::string base = path;
  if (ends_with(path, ".node") || ends_with(path, ".ele")) base = path.substr(0, path.rfind('.'));
  return {base + ".node", base + ".ele"};
}

TetMeshPtr read_tetgen(const std::string& path, TetMeshReadReport* report) {
  const TetGenPaths paths = tetgen_paths(path);
  TetMeshFileData data;

  // .node: "<#points> <dimension (3)> <#attributes> <boundary markers (0 or 1)>", then
  // "<point #> <x> <y> <z> [attributes] [boundary marker]".
  TextScanner node = TextScanner::open(paths.node, '#');
  const ScannedLine& header = node.next_line("the header '<#points> 3 <#attributes> <#markers>'");
  if (header.tokens.size() < 2 || header.tokens.size() > 4) {
    node.fail(InputErrorKind::syntax, "expected the header '<#points> 3 <#attributes> <0|1>'");
  }
  const long n_points = node.parse_int(header.tokens[0], "number of points");
  const long dim = node.parse_int(header.tokens[1], "dimension");
  const long n_attr = header.tokens.size() > 2 ? node.parse_int(header.tokens[2], "number of attributes") : 0;
  const long n_marker = header.tokens.size() > 3 ? node.parse_int(header.tokens[3], "boundary markers") : 0;
  if (dim != 3) node.fail(InputErrorKind::unsupported, "only 3-dimensional points are supported, got " + std::to_string(dim));
  if (n_points <= 0) node.fail(InputErrorKind::unsupported, "expected a positive number of points (points in a .poly are not supported)");
  if (n_attr < 0 || n_attr > 1000 || n_marker < 0 || n_marker > 1) {
    node.fail(InputErrorKind::bad_value, "attributes must be in [0, 1000] and markers 0 or 1");
  }
  long first_index = 0;
  data.positions.reserve(node.reserve_hint(n_points, 4 + n_attr + n_marker));
  for (long i = 0; i < n_points; ++i) {
    const ScannedLine& line = node.next_line("point " + std::to_string(i + 1) + " of " + std::to_string(n_points));
    expect_tokens(node, line, static_cast<size_t>(4 + n_attr + n_marker), "point number, x, y, z, attributes, marker");
    const long number = node.parse_int(line.tokens[0], "point number");
    if (i == 0) {
      if (number != 0 && number != 1) node.fail(InputErrorKind::syntax, "the first point must be numbered 0 or 1");
      first_index = number;
    } else if (number != first_index + i) {
      node.fail(InputErrorKind::syntax, "expected point number " + std::to_string(first_index + i) + ", got " +
                                            std::to_string(number) + " (points must be numbered consecutively)");
    }
    Vec3 p;
    for (int k = 0; k < 3; ++k) p[k] = node.parse_double(line.tokens[static_cast<size_t>(k) + 1], "coordinate");
    data.positions.push_back(p);
  }
  if (!node.at_end()) {
    node.next_line("");
    node.fail(InputErrorKind::count_mismatch, "the header promises " + std::to_string(n_points) + " points, but more follow");
  }

  // .ele: "<#tets> <nodes per tet (4 or 10)> <#attributes>", then "<tet #> <n1> ... [attributes]".
  TextScanner ele = TextScanner::open(paths.ele, '#');
  data.tet_file = paths.ele;
  const ScannedLine& eh = ele.next_line("the header '<#tetrahedra> <4|10> <#attributes>'");
  if (eh.tokens.size() < 2 || eh.tokens.size() > 3) {
    ele.fail(InputErrorKind::syntax, "expected the header '<#tetrahedra> <4|10> <#attributes>'");
  }
  const long n_tets = ele.parse_int(eh.tokens[0], "number of tetrahedra");
  const long per_tet = ele.parse_int(eh.tokens[1], "nodes per tetrahedron");
  const long n_tet_attr = eh.tokens.size() > 2 ? ele.parse_int(eh.tokens[2], "number of attributes") : 0;
  if (per_tet != 4 && per_tet != 10) ele.fail(InputErrorKind::unsupported, "nodes per tetrahedron must be 4 or 10");
  if (n_tets <= 0) ele.fail(InputErrorKind::bad_value, "expected a positive number of tetrahedra");
  if (n_tet_attr < 0 || n_tet_attr > 1000) ele.fail(InputErrorKind::bad_value, "attributes must be in [0, 1000]");
  for (long t = 0; t < n_tets; ++t) {
    const ScannedLine& line = ele.next_line("tetrahedron " + std::to_string(t + 1) + " of " + std::to_string(n_tets));
    expect_tokens(ele, line, static_cast<size_t>(1 + per_tet + n_tet_attr), "tet number, nodes, attributes");
    ele.parse_int(line.tokens[0], "tetrahedron number");
    TetIndices tet{};
    for (size_t k = 0; k < 4; ++k) {  // a 10-node tet lists its corners first
      const long v = ele.parse_int(line.tokens[k + 1], "point number") - first_index;
      if (v < 0 || v >= n_points) {
        ele.fail(InputErrorKind::index_out_of_range,
                 "tetrahedron " + std::to_string(t) + " refers to point " + std::string(line.tokens[k + 1]) +
                     ", but points are numbered " + std::to_string(first_index) + ".." +
                     std::to_string(first_index + n_points - 1));
      }
      tet[k] = static_cast<int>(v);
    }
    data.tets.push_back(tet);
    data.tet_lines.push_back(line.number);
    if (n_tet_attr > 0) {
      const double attr = ele.parse_double(line.tokens[static_cast<size_t>(1 + per_tet)], "region attribute");
      data.tet_tags.push_back(static_cast<int>(std::lround(attr)));
    }
  }
  if (!ele.at_end()) {
    ele.next_line("");
    ele.fail(InputErrorKind::count_mismatch, "the header promises " + std::to_string(n_tets) + " tetrahedra, but more follow");
  }
  if (report != nullptr) report->format = "tetgen";
  return build_tet_mesh_from_file(std::move(data), paths.ele, report);
}

void write_tetgen(const std::string& path, const TetMesh& mesh) {
  const TetGenPaths paths = tetgen_paths(path);
  const bool tags = !mesh.tet_tags().empty();
  std::ostringstream node;
  node.precision(17);
  node << "# written by pliant\n" << mesh.vertex_count() << " 3 0 0\n";
  for (int i = 0; i < mesh.vertex_count(); ++i) {
    const Vec3& p = mesh.rest_positions()[static_cast<size_t>(i)];
    node << i << ' ' << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  }
  std::ostringstream ele;
  ele << "# written by pliant\n" << mesh.tet_count() << " 4 " << (tags ? 1 : 0) << '\n';
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const auto& tet = mesh.tets()[static_cast<size_t>(t)];
    ele << t << ' ' << tet[0] << ' ' << tet[1] << ' ' << tet[2] << ' ' << tet[3];
    if (tags) ele << ' ' << mesh.tet_tags()[static_cast<size_t>(t)];
    ele << '\n';
  }
  write_file_atomically(paths.node, node.str());
  write_file_atomically(paths.ele, ele.str());
}

}  // namespace pliant
