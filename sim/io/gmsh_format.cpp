#include "sim/io/gmsh_format.h"

#include <sstream>
#include <unordered_map>

#include "sim/io/atomic_file.h"
#include "sim/io/text_scanner.h"

namespace pliant {
namespace {

constexpr long kGmshTetrahedron = 4;

// State shared by the section parsers.
struct GmshParse {
  TextScanner& in;
  TetMeshFileData data;
  std::unordered_map<long, int> node_index;       // node tag -> 0-based index
  std::unordered_map<long, int> volume_physical;  // 4.1: volume entity tag -> first physical tag
  bool any_tag = false;
  int skipped = 0;
};

// Expects the line "$End<name>" next.
void expect_end(TextScanner& in, const std::string& name, const std::string& what) {
  const ScannedLine& line = in.next_line("$End" + name);
  if (line.tokens[0] != "$End" + name) {
    in.fail(InputErrorKind::count_mismatch, "expected $End" + name + " after " + what + ", got '" + std::string(line.tokens[0]) + "'");
  }
}

// Reads one record line inside a section; a '$' line here means the header's count was too big.
const ScannedLine& record(TextScanner& in, const std::string& section, const std::string& expected,
                          long promised) {
  const ScannedLine& line = in.next_line(expected);
  if (line.tokens[0].starts_with("$")) {
    in.fail(InputErrorKind::count_mismatch, "'" + std::string(line.tokens[0]) + "' before the " +
                                                std::to_string(promised) + " records the " + section +
                                                " header promises; expected " + expected);
  }
  return line;
}

void expect_tokens(const TextScanner& in, const ScannedLine& line, size_t expected, const std::string& what) {
  if (line.tokens.size() != expected) {
    in.fail(InputErrorKind::syntax, "expected " + std::to_string(expected) + " values (" + what + "), found " +
                                        std::to_string(line.tokens.size()));
  }
}

void add_node(GmshParse& p, long tag, const Vec3& x) {
  if (!p.node_index.emplace(tag, static_cast<int>(p.data.positions.size())).second) {
    p.in.fail(InputErrorKind::syntax, "node tag " + std::to_string(tag) + " is defined twice");
  }
  p.data.positions.push_back(x);
}

int node_of(GmshParse& p, std::string_view token, long element) {
  const long tag = p.in.parse_int(token, "node tag");
  const auto it = p.node_index.find(tag);
  if (it == p.node_index.end()) {
    p.in.fail(InputErrorKind::index_out_of_range, "element " + std::to_string(element) + " refers to node tag " +
                                                      std::to_string(tag) + ", which $Nodes does not define");
  }
  return it->second;
}

// --- version 2.2 ---------------------------------------------------------------------------------

void read_nodes_22(GmshParse& p) {
  TextScanner& in = p.in;
  const long n = in.parse_int(in.next_line("the number of nodes").tokens[0], "number of nodes");
  for (long i = 0; i < n; ++i) {
    const ScannedLine& line = record(in, "$Nodes", "node '<tag> <x> <y> <z>'", n);
    expect_tokens(in, line, 4, "node tag, x, y, z");
    const long tag = in.parse_int(line.tokens[0], "node tag");
    Vec3 x;
    for (int k = 0; k < 3; ++k) x[k] = in.parse_double(line.tokens[static_cast<size_t>(k) + 1], "coordinate");
    add_node(p, tag, x);
  }
  expect_end(in, "Nodes", std::to_string(n) + " nodes");
}

void read_elements_22(GmshParse& p) {
  TextScanner& in = p.in;
  const long n = in.parse_int(in.next_line("the number of elements").tokens[0], "number of elements");
  for (long i = 0; i < n; ++i) {
    const ScannedLine& line = record(in, "$Elements", "element '<tag> <type> <#tags> <tags> <nodes>'", n);
    if (line.tokens.size() < 3) in.fail(InputErrorKind::syntax, "expected '<tag> <type> <#tags> ...'");
    const long tag = in.parse_int(line.tokens[0], "element tag");
    const long type = in.parse_int(line.tokens[1], "element type");
    const long n_tags = in.parse_int(line.tokens[2], "number of tags");
    if (n_tags < 0 || n_tags > 1000) in.fail(InputErrorKind::bad_value, "number of tags must be in [0, 1000]");
    if (type != kGmshTetrahedron) {
      ++p.skipped;
      continue;
    }
    expect_tokens(in, line, static_cast<size_t>(3 + n_tags + 4), "tag, type, #tags, tags, 4 nodes");
    int physical = 0;
    if (n_tags > 0) {
      physical = static_cast<int>(in.parse_int(line.tokens[3], "physical tag"));
      p.any_tag = true;
    }
    TetIndices tet{};
    for (size_t k = 0; k < 4; ++k) tet[k] = node_of(p, line.tokens[static_cast<size_t>(3 + n_tags) + k], tag);
    p.data.tets.push_back(tet);
    p.data.tet_lines.push_back(line.number);
    p.data.tet_tags.push_back(physical);
  }
  expect_end(in, "Elements", std::to_string(n) + " elements");
}

// --- version 4.1 ---------------------------------------------------------------------------------

void read_entities_41(GmshParse& p) {
  TextScanner& in = p.in;
  const ScannedLine& header = in.next_line("'<#points> <#curves> <#surfaces> <#volumes>'");
  expect_tokens(in, header, 4, "numbers of points, curves, surfaces, volumes");
  long counts[4];
  for (size_t k = 0; k < 4; ++k) counts[k] = in.parse_int(header.tokens[k], "entity count");
  for (int dim = 0; dim < 4; ++dim) {
    for (long i = 0; i < counts[dim]; ++i) {
      const ScannedLine& line = record(in, "$Entities", "an entity of dimension " + std::to_string(dim),
                                       counts[0] + counts[1] + counts[2] + counts[3]);
      if (dim < 3) continue;
      // "<tag> <minX> <minY> <minZ> <maxX> <maxY> <maxZ> <#physical> <physical tags> ..."
      if (line.tokens.size() < 8) in.fail(InputErrorKind::syntax, "expected a volume entity '<tag> <bbox> <#physical> ...'");
      const long tag = in.parse_int(line.tokens[0], "volume tag");
      const long n_phys = in.parse_int(line.tokens[7], "number of physical tags");
      if (n_phys < 0 || n_phys > static_cast<long>(line.tokens.size()) - 8) {
        in.fail(InputErrorKind::syntax, "volume entity lists fewer physical tags than it announces");
      }
      if (n_phys > 0) {
        p.volume_physical[tag] = static_cast<int>(in.parse_int(line.tokens[8], "physical tag"));
        p.any_tag = true;
      }
    }
  }
  expect_end(in, "Entities", "the entities");
}

void read_nodes_41(GmshParse& p) {
  TextScanner& in = p.in;
  const ScannedLine& header = in.next_line("'<#blocks> <#nodes> <min tag> <max tag>'");
  expect_tokens(in, header, 4, "numbers of entity blocks and nodes, min and max node tag");
  const long blocks = in.parse_int(header.tokens[0], "number of entity blocks");
  const long total = in.parse_int(header.tokens[1], "number of nodes");
  long seen = 0;
  for (long b = 0; b < blocks; ++b) {
    const ScannedLine& bh = record(in, "$Nodes", "a node block '<dim> <entity> <parametric> <#nodes>'", blocks);
    expect_tokens(in, bh, 4, "entity dimension, entity tag, parametric, number of nodes");
    const long dim = in.parse_int(bh.tokens[0], "entity dimension");
    const long parametric = in.parse_int(bh.tokens[2], "parametric flag");
    if (dim < 0 || dim > 3) in.fail(InputErrorKind::bad_value, "entity dimension must be 0..3");
    const long n = in.parse_int(bh.tokens[3], "number of nodes in block");
    if (n < 0 || n > total - seen) {
      in.fail(InputErrorKind::count_mismatch, "node blocks hold more than the " + std::to_string(total) +
                                                  " nodes the $Nodes header promises");
    }
    std::vector<long> tags;
    tags.reserve(in.reserve_hint(n, 4));
    for (long i = 0; i < n; ++i) {
      const ScannedLine& line = record(in, "$Nodes", "a node tag", n);
      expect_tokens(in, line, 1, "node tag");
      tags.push_back(in.parse_int(line.tokens[0], "node tag"));
    }
    const size_t coords = 3 + static_cast<size_t>(parametric != 0 ? dim : 0);
    for (long i = 0; i < n; ++i) {
      const ScannedLine& line = record(in, "$Nodes", "node coordinates '<x> <y> <z>'", n);
      expect_tokens(in, line, coords, "x, y, z and parametric coordinates");
      Vec3 x;
      for (int k = 0; k < 3; ++k) x[k] = in.parse_double(line.tokens[static_cast<size_t>(k)], "coordinate");
      add_node(p, tags[static_cast<size_t>(i)], x);
    }
    seen += n;
  }
  if (seen != total) {
    in.fail(InputErrorKind::count_mismatch, "the $Nodes header promises " + std::to_string(total) +
                                                " nodes, the blocks hold " + std::to_string(seen));
  }
  expect_end(in, "Nodes", std::to_string(blocks) + " node blocks");
}

void read_elements_41(GmshParse& p) {
  TextScanner& in = p.in;
  const ScannedLine& header = in.next_line("'<#blocks> <#elements> <min tag> <max tag>'");
  expect_tokens(in, header, 4, "numbers of entity blocks and elements, min and max element tag");
  const long blocks = in.parse_int(header.tokens[0], "number of entity blocks");
  const long total = in.parse_int(header.tokens[1], "number of elements");
  long seen = 0;
  for (long b = 0; b < blocks; ++b) {
    const ScannedLine& bh = record(in, "$Elements", "an element block '<dim> <entity> <type> <#elements>'", blocks);
    expect_tokens(in, bh, 4, "entity dimension, entity tag, element type, number of elements");
    const long entity = in.parse_int(bh.tokens[1], "entity tag");
    const long type = in.parse_int(bh.tokens[2], "element type");
    const long n = in.parse_int(bh.tokens[3], "number of elements in block");
    if (n < 0 || n > total - seen) {
      in.fail(InputErrorKind::count_mismatch, "element blocks hold more than the " + std::to_string(total) +
                                                  " elements the $Elements header promises");
    }
    const auto phys = p.volume_physical.find(entity);
    const int tag = phys != p.volume_physical.end() ? phys->second : 0;
    for (long i = 0; i < n; ++i) {
      const ScannedLine& line = record(in, "$Elements", "an element '<tag> <nodes>'", n);
      if (type != kGmshTetrahedron) {
        ++p.skipped;
        continue;
      }
      expect_tokens(in, line, 5, "element tag and 4 node tags");
      const long element = in.parse_int(line.tokens[0], "element tag");
      TetIndices tet{};
      for (size_t k = 0; k < 4; ++k) tet[k] = node_of(p, line.tokens[k + 1], element);
      p.data.tets.push_back(tet);
      p.data.tet_lines.push_back(line.number);
      p.data.tet_tags.push_back(tag);
    }
    seen += n;
  }
  if (seen != total) {
    in.fail(InputErrorKind::count_mismatch, "the $Elements header promises " + std::to_string(total) +
                                                " elements, the blocks hold " + std::to_string(seen));
  }
  expect_end(in, "Elements", std::to_string(blocks) + " element blocks");
}

// Skips an unknown section up to its $End line.
void skip_section(TextScanner& in, const std::string& name) {
  const long start = in.line();
  for (;;) {
    const ScannedLine& line = in.next_line("$End" + name + " closing the section opened at line " + std::to_string(start));
    if (line.tokens[0] == "$End" + name) return;
  }
}

TetMeshPtr read_gmsh_scanner(TextScanner& in, TetMeshReadReport* report) {
  GmshParse p{in, {}, {}, {}, false, 0};
  p.data.tet_file = in.name();
  int version = 0;  // 22 or 41
  bool have_nodes = false;
  while (!in.at_end()) {
    const ScannedLine& line = in.next_line("a section");
    const std::string_view word = line.tokens[0];
    if (!word.starts_with("$")) in.fail(InputErrorKind::syntax, "expected a section like $Nodes, got '" + std::string(word) + "'");
    const std::string name(word.substr(1));
    if (name == "MeshFormat") {
      const ScannedLine& f = in.next_line("'<version> <file-type> <data-size>'");
      expect_tokens(in, f, 3, "version, file type, data size");
      if (f.tokens[1] != "0") in.fail(InputErrorKind::unsupported, "binary .msh files are not supported (save as ASCII)");
      if (f.tokens[0] == "2.2" || f.tokens[0] == "2.1" || f.tokens[0] == "2" || f.tokens[0] == "2.0") {
        version = 22;
      } else if (f.tokens[0] == "4.1") {
        version = 41;
      } else {
        in.fail(InputErrorKind::unsupported, "MSH version " + std::string(f.tokens[0]) + " is not supported (2.2 or 4.1)");
      }
      expect_end(in, "MeshFormat", "the format line");
    } else if (version == 0) {
      in.fail(InputErrorKind::syntax, "expected $MeshFormat first, got '" + std::string(word) + "'");
    } else if (name == "Nodes") {
      version == 22 ? read_nodes_22(p) : read_nodes_41(p);
      have_nodes = true;
    } else if (name == "Elements") {
      if (!have_nodes) in.fail(InputErrorKind::syntax, "$Elements before $Nodes");
      version == 22 ? read_elements_22(p) : read_elements_41(p);
    } else if (name == "Entities" && version == 41) {
      read_entities_41(p);
    } else if (name.starts_with("End")) {
      in.fail(InputErrorKind::syntax, "'" + std::string(word) + "' without a matching section start");
    } else {
      skip_section(in, name);
    }
  }
  if (version == 0) in.fail(InputErrorKind::syntax, "no $MeshFormat section: not a .msh file");
  if (!p.any_tag) p.data.tet_tags.clear();
  if (report != nullptr) {
    report->format = version == 22 ? "gmsh 2.2" : "gmsh 4.1";
    report->skipped_elements = p.skipped;
  }
  return build_tet_mesh_from_file(std::move(p.data), in.name(), report);
}

}  // namespace

TetMeshPtr read_gmsh(const std::string& path, TetMeshReadReport* report) {
  TextScanner in = TextScanner::open(path);
  return read_gmsh_scanner(in, report);
}

TetMeshPtr read_gmsh_text(const std::string& name, std::string text, TetMeshReadReport* report) {
  TextScanner in(name, std::move(text));
  return read_gmsh_scanner(in, report);
}

void write_gmsh22(const std::string& path, const TetMesh& mesh) {
  std::ostringstream s;
  s.precision(17);
  s << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n" << mesh.vertex_count() << '\n';
  for (int i = 0; i < mesh.vertex_count(); ++i) {
    const Vec3& p = mesh.rest_positions()[static_cast<size_t>(i)];
    s << i + 1 << ' ' << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  }
  s << "$EndNodes\n$Elements\n" << mesh.tet_count() << '\n';
  for (int t = 0; t < mesh.tet_count(); ++t) {
    const auto& tet = mesh.tets()[static_cast<size_t>(t)];
    s << t + 1 << ' ' << kGmshTetrahedron;
    if (mesh.tet_tags().empty()) {
      s << " 0";
    } else {
      const int tag = mesh.tet_tags()[static_cast<size_t>(t)];
      s << " 2 " << tag << ' ' << tag;
    }
    s << ' ' << tet[0] + 1 << ' ' << tet[1] + 1 << ' ' << tet[2] + 1 << ' ' << tet[3] + 1 << '\n';
  }
  s << "$EndElements\n";
  write_file_atomically(path, s.str());
}

}  // namespace pliant
