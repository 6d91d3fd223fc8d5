// ASCII VTK XML writers. Numbers are printed with 17 significant digits so a round trip is exact;
// each file goes to "<path>.tmp" first and is renamed, so a viewer never opens half a file.
#include "sim/io/vtu_writer.h"

#include <algorithm>
#include <sstream>

#include "sim/input_error.h"
#include "sim/io/atomic_file.h"

namespace pliant {
namespace {

int points_per_cell(VtuCellType type) {
  switch (type) {
    case VtuCellType::vertex: return 1;
    case VtuCellType::triangle: return 3;
    case VtuCellType::tetra: return 4;
  }
  return 4;
}

// XML attribute-safe text.
std::string xml_escape(const std::string& s) {
  std::string r;
  for (char c : s) {
    switch (c) {
      case '&': r += "&amp;"; break;
      case '<': r += "&lt;"; break;
      case '>': r += "&gt;"; break;
      case '"': r += "&quot;"; break;
      default: r += c;
    }
  }
  return r;
}

}  // namespace

void write_vtu(const std::string& path, std::span<const Vec3> points, const VtuCells& cells,
               std::span<const VtuPointField> fields) {
  const int ppc = points_per_cell(cells.type);
  if (cells.connectivity.size() % static_cast<size_t>(ppc) != 0) {
    throw InputError(InputErrorKind::count_mismatch, path,
                     "connectivity size " + std::to_string(cells.connectivity.size()) +
                         " is not a multiple of " + std::to_string(ppc));
  }
  const long n_points = static_cast<long>(points.size());
  for (int v : cells.connectivity) {
    if (v < 0 || v >= n_points) {
      throw InputError(InputErrorKind::index_out_of_range, path,
                       "cell refers to point " + std::to_string(v) + ", but there are " +
                           std::to_string(n_points) + " points");
    }
  }
  for (const auto& f : fields) {
    if (f.components != 1 && f.components != 3) {
      throw InputError(InputErrorKind::bad_value, path, "field '" + f.name + "' must have 1 or 3 components");
    }
    if (f.values.size() != points.size() * static_cast<size_t>(f.components)) {
      throw InputError(InputErrorKind::count_mismatch, path,
                       "field '" + f.name + "' has " + std::to_string(f.values.size()) + " values, expected " +
                           std::to_string(points.size() * static_cast<size_t>(f.components)));
    }
  }
  const size_t n_cells = cells.connectivity.size() / static_cast<size_t>(ppc);

  std::ostringstream s;
  s.precision(17);
  s << "<?xml version=\"1.0\"?>\n"
    << "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
    << "  <UnstructuredGrid>\n"
    << "    <Piece NumberOfPoints=\"" << points.size() << "\" NumberOfCells=\"" << n_cells << "\">\n";
  s << "      <PointData>\n";
  for (const auto& f : fields) {
    s << "        <DataArray type=\"Float64\" Name=\"" << xml_escape(f.name) << "\" NumberOfComponents=\""
      << f.components << "\" format=\"ascii\">\n";
    for (size_t i = 0; i < points.size(); ++i) {
      s << "         ";
      for (int c = 0; c < f.components; ++c) {
        // Non-finite values stay visible as "nan"/"inf" (debug output must not hide them).
        s << ' ' << f.values[i * static_cast<size_t>(f.components) + static_cast<size_t>(c)];
      }
      s << '\n';
    }
    s << "        </DataArray>\n";
  }
  s << "      </PointData>\n";
  s << "      <Points>\n"
    << "        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
  for (const auto& p : points) s << "          " << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  s << "        </DataArray>\n"
    << "      </Points>\n"
    << "      <Cells>\n"
    << "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (size_t c = 0; c < n_cells; ++c) {
    s << "         ";
    for (int k = 0; k < ppc; ++k) s << ' ' << cells.connectivity[c * static_cast<size_t>(ppc) + static_cast<size_t>(k)];
    s << '\n';
  }
  s << "        </DataArray>\n"
    << "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (size_t c = 0; c < n_cells; ++c) s << "          " << (c + 1) * static_cast<size_t>(ppc) << '\n';
  s << "        </DataArray>\n"
    << "        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n";
  for (size_t c = 0; c < n_cells; ++c) s << "          " << static_cast<int>(cells.type) << '\n';
  s << "        </DataArray>\n"
    << "      </Cells>\n"
    << "    </Piece>\n"
    << "  </UnstructuredGrid>\n"
    << "</VTKFile>\n";
  write_file_atomically(path, s.str());
}

void write_tet_mesh_vtu(const std::string& path, const TetMesh& mesh, std::span<const Vec3> x,
                        std::span<const VtuPointField> fields) {
  if (x.size() != static_cast<size_t>(mesh.vertex_count())) {
    throw InputError(InputErrorKind::count_mismatch, path,
                     "got " + std::to_string(x.size()) + " positions for a mesh of " +
                         std::to_string(mesh.vertex_count()) + " vertices");
  }
  VtuCells cells;
  cells.type = VtuCellType::tetra;
  cells.connectivity.reserve(static_cast<size_t>(mesh.tet_count()) * 4);
  for (const auto& t : mesh.tets()) cells.connectivity.insert(cells.connectivity.end(), t.begin(), t.end());
  write_vtu(path, x, cells, fields);
}

void PvdSeries::add(double time, const std::string& file) {
  entries_.emplace_back(time, file);
  std::ostringstream s;
  s.precision(17);
  s << "<?xml version=\"1.0\"?>\n"
    << "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
    << "  <Collection>\n";
  for (const auto& [t, f] : entries_) {
    s << "    <DataSet timestep=\"" << t << "\" group=\"\" part=\"0\" file=\"" << xml_escape(f) << "\"/>\n";
  }
  s << "  </Collection>\n"
    << "</VTKFile>\n";
  write_file_atomically(path_, s.str());
}

}  // namespace pliant
