#include "sim/io/vtk_legacy_format.h"

#include <cctype>
#include <limits>
#include <sstream>

#include "sim/io/atomic_file.h"
#include "sim/io/text_scanner.h"

namespace pliant {
namespace {

constexpr long kVtkTetra = 10;

long parse_count(TextScanner& in, const std::string& what) {
  const long n = in.parse_int(in.next_token(what), what);
  if (n < 0) in.fail(InputErrorKind::bad_value, "negative " + what);
  return n;
}

// Integer cell scalars that hold region tags: ours, meshio's, gmsh's and tetgen's (-k) names.
bool is_tag_scalar_name(std::string_view name) {
  return name == "tag" || name == "gmsh:physical" || name == "CellEntityIds" || name == "cell_scalars";
}

// A point id; ids outside int range are out of range for any mesh we can hold.
int parse_point_id(TextScanner& in, const std::string& what) {
  const long id = in.parse_int(in.next_token(what), "point id");
  if (id < std::numeric_limits<int>::min() || id > std::numeric_limits<int>::max()) {
    in.fail(InputErrorKind::index_out_of_range, "point id " + std::to_string(id) + " is out of range");
  }
  return static_cast<int>(id);
}

// Checks the keyword line "<KEYWORD> ..." starts with `keyword`.
void expect_keyword(TextScanner& in, std::string_view token, const std::string& keyword) {
  if (token != keyword) in.fail(InputErrorKind::syntax, "expected " + keyword + ", got '" + std::string(token) + "'");
}

TetMeshPtr read_vtk_scanner(TextScanner& in, TetMeshReadReport* report) {
  const ScannedLine& head = in.next_line("'# vtk DataFile Version x.y'");
  if (head.number != 1 || !head.text.starts_with("# vtk DataFile")) {
    in.fail(InputErrorKind::syntax, "expected '# vtk DataFile Version x.y' on line 1");
  }
  // Line 2 is a free title (possibly blank), then the ASCII/BINARY line.
  const ScannedLine* format = &in.next_line("a title line");
  if (format->number == 2) format = &in.next_line("ASCII or BINARY");
  if (format->tokens[0] == "BINARY") in.fail(InputErrorKind::unsupported, "binary VTK files are not supported (save as ASCII)");
  expect_keyword(in, format->tokens[0], "ASCII");
  const ScannedLine& dataset = in.next_line("DATASET UNSTRUCTURED_GRID");
  expect_keyword(in, dataset.tokens[0], "DATASET");
  if (dataset.tokens.size() != 2 || dataset.tokens[1] != "UNSTRUCTURED_GRID") {
    in.fail(InputErrorKind::unsupported, "only DATASET UNSTRUCTURED_GRID is supported");
  }

  TetMeshFileData data;
  data.tet_file = in.name();
  std::vector<std::vector<int>> cells;  // point ids per cell
  std::vector<long> cell_lines;
  bool have_points = false, have_cells = false, have_types = false;
  int skipped = 0;
  std::vector<long> tet_cells;  // cell index of each kept tet
  std::string_view pending;  // a keyword read ahead
  while (!pending.empty() || !in.at_end()) {
    const std::string_view key = pending.empty() ? in.next_token("a section keyword") : pending;
    pending = {};
    if (key == "POINTS") {
      const long n = parse_count(in, "number of points");
      in.next_token("the point data type");
      data.positions.reserve(in.reserve_hint(n, 3));
      for (long i = 0; i < n; ++i) {
        Vec3 p;
        for (int k = 0; k < 3; ++k) {
          const std::string_view t = in.next_token("coordinates of point " + std::to_string(i));
          if (t.size() > 1 && std::isalpha(static_cast<unsigned char>(t[0])) && t != "nan" && t != "inf" &&
              t != "NaN" && t != "Infinity") {
            in.fail(InputErrorKind::count_mismatch, "POINTS promises " + std::to_string(n) + " points, but '" +
                                                        std::string(t) + "' comes after " + std::to_string(i));
          }
          p[k] = in.parse_double(t, "coordinate");
        }
        data.positions.push_back(p);
      }
      have_points = true;
    } else if (key == "CELLS") {
      const long n_cells_or_offsets = parse_count(in, "number of cells");
      const long size = parse_count(in, "cell list size");
      const long cells_line = in.line();
      std::string_view next = in.next_token("cell data or OFFSETS");
      if (next == "OFFSETS") {  // VTK 5.x: offsets (n+1) then connectivity
        in.next_token("the offsets data type");
        std::vector<long> offsets, offset_lines;
        for (long i = 0; i < n_cells_or_offsets; ++i) {
          offsets.push_back(in.parse_int(in.next_token("an offset"), "offset"));
          offset_lines.push_back(in.line());
        }
        expect_keyword(in, in.next_token("CONNECTIVITY"), "CONNECTIVITY");
        in.next_token("the connectivity data type");
        std::vector<int> conn;
        std::vector<long> conn_lines;
        for (long i = 0; i < size; ++i) {
          conn.push_back(parse_point_id(in, "a point id"));
          conn_lines.push_back(in.line());
        }
        for (size_t c = 0; c + 1 < offsets.size(); ++c) {
          if (offsets[c] < 0 || offsets[c + 1] < offsets[c] || offsets[c + 1] > size) {
            throw InputError(InputErrorKind::index_out_of_range, file_line(in.name(), offset_lines[c + 1]),
                             "offset " + std::to_string(offsets[c + 1]) + " outside the connectivity of " +
                                 std::to_string(size) + " ids");
          }
          cells.emplace_back(conn.begin() + offsets[c], conn.begin() + offsets[c + 1]);
          cell_lines.push_back(offsets[c + 1] > offsets[c] ? conn_lines[static_cast<size_t>(offsets[c])] : cells_line);
        }
      } else if (n_cells_or_offsets == 0) {
        pending = next;
      } else {  // classic: n lines "<k> <id_1> ... <id_k>", size = total number of integers
        long used = 0;
        for (long c = 0; c < n_cells_or_offsets; ++c) {
          const std::string_view count_token = c == 0 ? next : in.next_token("cell " + std::to_string(c));
          const long k = in.parse_int(count_token, "number of points in cell " + std::to_string(c));
          const long line = in.line();
          if (k < 0) in.fail(InputErrorKind::bad_value, "negative point count");
          std::vector<int> ids;
          for (long i = 0; i < k; ++i) ids.push_back(parse_point_id(in, "a point id of cell " + std::to_string(c)));
          cells.push_back(std::move(ids));
          cell_lines.push_back(line);
          used += k + 1;
        }
        if (used != size) {
          in.fail(InputErrorKind::count_mismatch, "CELLS promises a list of " + std::to_string(size) +
                                                      " integers, the cells hold " + std::to_string(used));
        }
      }
      have_cells = true;
    } else if (key == "CELL_TYPES") {
      if (!have_cells) in.fail(InputErrorKind::syntax, "CELL_TYPES before CELLS");
      const long n = parse_count(in, "number of cell types");
      if (n != static_cast<long>(cells.size())) {
        in.fail(InputErrorKind::count_mismatch, "CELL_TYPES lists " + std::to_string(n) + " types for " +
                                                    std::to_string(cells.size()) + " cells");
      }
      for (long c = 0; c < n; ++c) {
        const long type = in.parse_int(in.next_token("the type of cell " + std::to_string(c)), "cell type");
        const auto& ids = cells[static_cast<size_t>(c)];
        if (type != kVtkTetra) {
          ++skipped;
          continue;
        }
        if (ids.size() != 4) {
          throw InputError(InputErrorKind::syntax, file_line(in.name(), cell_lines[static_cast<size_t>(c)]),
                           "tetra cell " + std::to_string(c) + " has " + std::to_string(ids.size()) + " points, expected 4");
        }
        for (int id : ids) {
          if (id < 0 || id >= static_cast<long>(data.positions.size())) {
            throw InputError(InputErrorKind::index_out_of_range, file_line(in.name(), cell_lines[static_cast<size_t>(c)]),
                             "cell " + std::to_string(c) + " refers to point " + std::to_string(id) + ", but there are " +
                                 std::to_string(data.positions.size()) + " points");
          }
        }
        data.tets.push_back({ids[0], ids[1], ids[2], ids[3]});
        data.tet_lines.push_back(cell_lines[static_cast<size_t>(c)]);
        tet_cells.push_back(c);
      }
      have_types = true;
    } else if (key == "CELL_DATA" && have_types) {
      // Optional integer tags: "CELL_DATA n / SCALARS <name> <type> [1] / LOOKUP_TABLE default / n values".
      const long n = parse_count(in, "number of cell data values");
      if (n != static_cast<long>(cells.size())) {
        in.fail(InputErrorKind::count_mismatch, "CELL_DATA has " + std::to_string(n) + " values for " +
                                                    std::to_string(cells.size()) + " cells");
      }
      const ScannedLine& scalars = in.next_line("SCALARS");
      if (scalars.tokens[0] != "SCALARS" || scalars.tokens.size() < 3 ||
          !is_tag_scalar_name(scalars.tokens[1])) {
        break;  // other cell data is not ours to read
      }
      expect_keyword(in, in.next_line("LOOKUP_TABLE").tokens[0], "LOOKUP_TABLE");
      std::vector<int> values;
      for (long i = 0; i < n; ++i) values.push_back(static_cast<int>(in.parse_int(in.next_token("a cell tag"), "cell tag")));
      for (long c : tet_cells) data.tet_tags.push_back(values[static_cast<size_t>(c)]);
      break;
    } else if (have_points && have_cells && have_types) {
      break;  // POINT_DATA, FIELD, ...: not needed for the mesh
    } else if (key == "METADATA") {
      // VTK 5.x metadata block: skip to the next section keyword.
      for (;;) {
        const std::string_view t = in.next_token("a section after METADATA");
        if (t == "POINTS" || t == "CELLS" || t == "CELL_TYPES" || t == "CELL_DATA" || t == "POINT_DATA") {
          pending = t;
          break;
        }
      }
    } else if (!have_points || !have_cells || !have_types) {
      in.fail(InputErrorKind::syntax, "expected POINTS, CELLS or CELL_TYPES, got '" + std::string(key) + "'");
    }
  }
  if (!have_points) in.fail(InputErrorKind::truncated, "file ends without POINTS");
  if (!have_cells || !have_types) in.fail(InputErrorKind::truncated, "file ends without CELLS and CELL_TYPES");
  if (report != nullptr) {
    report->format = "vtk legacy";
    report->skipped_elements = skipped;
  }
  return build_tet_mesh_from_file(std::move(data), in.name(), report);
}

}  // namespace

TetMeshPtr read_vtk_legacy(const std::string& path, TetMeshReadReport* report) {
  TextScanner in = TextScanner::open(path);
  return read_vtk_scanner(in, report);
}

TetMeshPtr read_vtk_legacy_text(const std::string& name, std::string text, TetMeshReadReport* report) {
  TextScanner in(name, std::move(text));
  return read_vtk_scanner(in, report);
}

void write_vtk_legacy(const std::string& path, const TetMesh& mesh) {
  std::ostringstream s;
  s.precision(17);
  s << "# vtk DataFile Version 3.0\npliant tet mesh\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS "
    << mesh.vertex_count() << " double\n";
  for (const Vec3& p : mesh.rest_positions()) s << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  s << "CELLS " << mesh.tet_count() << ' ' << 5 * mesh.tet_count() << '\n';
  for (const auto& t : mesh.tets()) s << "4 " << t[0] << ' ' << t[1] << ' ' << t[2] << ' ' << t[3] << '\n';
  s << "CELL_TYPES " << mesh.tet_count() << '\n';
  for (int t = 0; t < mesh.tet_count(); ++t) s << kVtkTetra << '\n';
  if (!mesh.tet_tags().empty()) {
    s << "CELL_DATA " << mesh.tet_count() << "\nSCALARS tag int 1\nLOOKUP_TABLE default\n";
    for (int tag : mesh.tet_tags()) s << tag << '\n';
  }
  write_file_atomically(path, s.str());
}

}  // namespace pliant
