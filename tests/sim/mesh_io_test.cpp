// Mesh readers and writers. References: our own writers round-trip a box mesh exactly through every
// format; files written by the real tools (gmsh 2.2/4.1/vtk of one mesh, tetgen .node/.ele and its
// -k .vtk) agree with each other up to vertex and tet order; a catalogue of malformed files each
// gives its InputError kind at the exact "file:line"; a written .vtu parses back to its numbers.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <unistd.h>

#include "sim/input_error.h"
#include "sim/io/gmsh_format.h"
#include "sim/io/tet_mesh_reader.h"
#include "sim/io/tetgen_format.h"
#include "sim/io/vtk_legacy_format.h"
#include "sim/io/vtu_writer.h"
#include "sim/mesh/box_mesh.h"

namespace pliant {
namespace {

namespace fs = std::filesystem;

// A fresh scratch folder per test.
class MeshIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("pliant_mesh_io_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
    return path(name);
  }
  fs::path dir_;
};

std::string asset(const std::string& name) { return std::string(PLIANT_SOURCE_DIR) + "/assets/meshes/" + name; }

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Same vertices (matched by position within tol), same tets as vertex sets, same tag per tet.
void expect_same_mesh(const TetMesh& a, const TetMesh& b, double tol) {
  ASSERT_EQ(a.vertex_count(), b.vertex_count());
  ASSERT_EQ(a.tet_count(), b.tet_count());
  std::vector<int> to_b(static_cast<size_t>(a.vertex_count()), -1);
  std::vector<char> used(static_cast<size_t>(b.vertex_count()), 0);
  for (int i = 0; i < a.vertex_count(); ++i) {
    for (int j = 0; j < b.vertex_count(); ++j) {
      if (!used[static_cast<size_t>(j)] &&
          (a.rest_positions()[static_cast<size_t>(i)] - b.rest_positions()[static_cast<size_t>(j)]).norm() <= tol) {
        to_b[static_cast<size_t>(i)] = j;
        used[static_cast<size_t>(j)] = 1;
        break;
      }
    }
    ASSERT_GE(to_b[static_cast<size_t>(i)], 0) << "vertex " << i << " has no partner";
  }
  auto key = [](TetIndices t) {
    std::sort(t.begin(), t.end());
    return t;
  };
  std::map<TetIndices, int> tets_b;
  for (int t = 0; t < b.tet_count(); ++t) {
    tets_b[key(b.tets()[static_cast<size_t>(t)])] = b.tet_tags().empty() ? 0 : b.tet_tags()[static_cast<size_t>(t)];
  }
  for (int t = 0; t < a.tet_count(); ++t) {
    TetIndices mapped{};
    for (size_t k = 0; k < 4; ++k) mapped[k] = to_b[static_cast<size_t>(a.tets()[static_cast<size_t>(t)][k])];
    const auto it = tets_b.find(key(mapped));
    ASSERT_NE(it, tets_b.end()) << "tet " << t << " missing";
    EXPECT_EQ(it->second, a.tet_tags().empty() ? 0 : a.tet_tags()[static_cast<size_t>(t)]);
  }
  EXPECT_NEAR(a.total_rest_volume(), b.total_rest_volume(), 1e-12 * a.total_rest_volume() + 1e-300);
}

TEST_F(MeshIoTest, OwnWritersRoundTripExactlyThroughEveryFormat) {
  const auto box = make_box_mesh({Vec3(0.3, 0.2, 0.1), 3, 2, 2});
  // A tagged variant: tag = 1 + (tet index mod 3).
  std::vector<int> tags(static_cast<size_t>(box->tet_count()));
  for (size_t t = 0; t < tags.size(); ++t) tags[t] = 1 + static_cast<int>(t % 3);
  const auto tagged = TetMesh::build(box->rest_positions(), box->tets(), "tagged", nullptr, tags);
  for (const auto& mesh : {box, tagged}) {
    for (const std::string name : {"m.node", "m.msh", "m.vtk"}) {
      write_tet_mesh(path(name), *mesh);
      TetMeshReadReport report;
      const auto back = read_tet_mesh(path(name), &report);
      SCOPED_TRACE(name);
      EXPECT_TRUE(report.build.reoriented_tets.empty());
      EXPECT_EQ(back->rest_positions(), mesh->rest_positions());  // 17 digits: exact
      EXPECT_EQ(back->tets(), mesh->tets());
      EXPECT_EQ(back->tet_tags(), mesh->tet_tags());
    }
  }
  // The TetGen pair is found from either file or the base name.
  write_tetgen(path("pair"), *box);
  EXPECT_TRUE(fs::exists(path("pair.node")) && fs::exists(path("pair.ele")));
  expect_same_mesh(*read_tetgen(path("pair.ele")), *box, 0.0);
  expect_same_mesh(*read_tet_mesh(path("pair")), *box, 0.0);
}

TEST_F(MeshIoTest, GmshFilesOfOneMeshAgreeAcrossVersions) {
  TetMeshReadReport r22, r41, rvtk;
  const auto v22 = read_tet_mesh(asset("gmsh_cube_v22.msh"), &r22);
  const auto v41 = read_tet_mesh(asset("gmsh_cube_v41.msh"), &r41);
  const auto vtk = read_tet_mesh(asset("gmsh_cube.vtk"), &rvtk);
  EXPECT_EQ(r22.format, "gmsh 2.2");
  EXPECT_EQ(r41.format, "gmsh 4.1");
  EXPECT_GT(r22.skipped_elements, 0);  // the physical surface's triangles
  EXPECT_EQ(r22.skipped_elements, r41.skipped_elements);
  EXPECT_NEAR(v22->total_rest_volume(), 1e-3, 1e-15);  // the 0.1 m cube
  ASSERT_FALSE(v22->tet_tags().empty());
  for (int tag : v22->tet_tags()) EXPECT_EQ(tag, 7);
  expect_same_mesh(*v22, *v41, 1e-12);
  expect_same_mesh(*v22, *vtk, 1e-9);
}

TEST_F(MeshIoTest, TetgenFilesAgreeWithTetgensOwnVtk) {
  TetMeshReadReport report;
  const auto ele = read_tet_mesh(asset("tetgen_box.ele"), &report);
  EXPECT_EQ(report.format, "tetgen");
  EXPECT_EQ(ele->vertex_count(), 58);  // 1-based in the file
  EXPECT_EQ(ele->tet_count(), 92);
  EXPECT_NEAR(ele->total_rest_volume(), 1e-3, 1e-15);
  for (int tag : ele->tet_tags()) EXPECT_EQ(tag, 7);
  expect_same_mesh(*ele, *read_tet_mesh(asset("tetgen_box.vtk")), 1e-12);
  expect_same_mesh(*ele, *read_tet_mesh(asset("tetgen_box.node")), 0.0);
}

TEST_F(MeshIoTest, GmshFourOneMapsSparseNodeTagsAndEntityPhysicalTags) {
  const std::string text =
      "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"
      "$Comments\nanything $Nodes at all\n$EndComments\n"
      "$Entities\n0 0 0 1\n5 0 0 0 1 1 1 1 9 0\n$EndEntities\n"
      "$Nodes\n1 5 10 50\n3 5 0 5\n10\n20\n30\n40\n50\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n$EndNodes\n"
      "$Elements\n2 2 1 2\n2 5 2 1\n1 10 20 30\n3 5 4 1\n2 10 30 20 40\n$EndElements\n";
  TetMeshReadReport report;
  const auto mesh = read_gmsh_text("inline.msh", text, &report);
  EXPECT_EQ(mesh->vertex_count(), 4);  // node 50 is used by no tet and dropped
  EXPECT_EQ(report.unused_vertices_removed, 1);
  EXPECT_EQ(report.skipped_elements, 1);
  EXPECT_EQ(report.build.reoriented_tets, std::vector<int>{0});  // (10, 30, 20, 40) is negative
  EXPECT_EQ(mesh->tet_tags(), std::vector<int>{9});
  EXPECT_NEAR(mesh->total_rest_volume(), 1.0 / 6.0, 1e-15);
}

TEST_F(MeshIoTest, VtkFiveOffsetsLayoutIsRead) {
  const std::string text =
      "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET UNSTRUCTURED_GRID\n"
      "POINTS 4 float\n0 0 0 1 0 0\n0 1 0 0 0 1\nMETADATA\nINFORMATION 0\n\n"
      "CELLS 3 7\nOFFSETS vtktypeint64\n0 3 7\nCONNECTIVITY vtktypeint64\n0 1 2 0 1 2 3\n"
      "CELL_TYPES 2\n5\n10\n";
  TetMeshReadReport report;
  const auto mesh = read_vtk_legacy_text("five.vtk", text, &report);
  EXPECT_EQ(mesh->tet_count(), 1);
  EXPECT_EQ(report.skipped_elements, 1);
  EXPECT_NEAR(mesh->total_rest_volume(), 1.0 / 6.0, 1e-15);
}

// One malformed file: its text, the error kind and the line the message must name.
struct Malformed {
  std::string label;
  std::string file;  // name to write `text` to
  std::string text;
  InputErrorKind kind;
  long line;  // 0: the message names the file without a line
};

const std::string kNode = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
const std::string kMsh22Head = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
const std::string kMsh22Nodes = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";  // lines 4-10
const std::string kVtkHead = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n";

std::vector<Malformed> malformed_catalogue() {
  return {
      // TetGen (the .ele partner of a broken .node is well formed, and vice versa).
      {"node truncated", "a.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n", InputErrorKind::truncated, 3},
      {"node NaN", "a.node", "4 3 0 0\n0 0 0 0\n1 nan 0 0\n2 0 1 0\n3 0 0 1\n", InputErrorKind::non_finite, 3},
      {"node infinity", "a.node", "4 3 0 0\n0 0 0 0\n1 1e999 0 0\n2 0 1 0\n3 0 0 1\n", InputErrorKind::non_finite, 3},
      {"node garbage number", "a.node", "4 3 0 0\n0 0 0 0\n1 1.0x 0 0\n2 0 1 0\n3 0 0 1\n", InputErrorKind::syntax, 3},
      {"node too many points", "a.node", kNode + "4 1 1 1\n", InputErrorKind::count_mismatch, 6},
      {"node numbering gap", "a.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n3 0 1 0\n4 0 0 1\n", InputErrorKind::syntax, 4},
      {"node 2-d", "a.node", "4 2 0 0\n", InputErrorKind::unsupported, 1},
      {"ele index out of range", "a.ele", "1 4 0\n0 0 1 2 4\n", InputErrorKind::index_out_of_range, 2},
      {"ele negative index", "a.ele", "# c\n\n1 4 0\n0 0 1 -2 3\n", InputErrorKind::index_out_of_range, 4},
      {"ele fewer than promised", "a.ele", "2 4 0\n0 0 1 2 3\n", InputErrorKind::truncated, 2},
      {"ele more than promised", "a.ele", "1 4 0\n0 0 1 2 3\n1 0 1 2 3\n", InputErrorKind::count_mismatch, 3},
      {"ele missing a node", "a.ele", "1 4 0\n0 0 1 2\n", InputErrorKind::syntax, 2},
      {"ele repeated vertex", "a.ele", "1 4 0\n0 0 1 1 3\n", InputErrorKind::degenerate_element, 2},
      {"ele zero volume", "b.ele", "2 4 0\n# the second tet is flat\n0 0 1 2 3\n1 0 1 2 4\n",
       InputErrorKind::degenerate_element, 4},
      // Gmsh.
      {"msh binary", "a.msh", "$MeshFormat\n2.2 1 8\n", InputErrorKind::unsupported, 2},
      {"msh version 3", "a.msh", "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", InputErrorKind::unsupported, 2},
      {"msh no format", "a.msh", kMsh22Nodes, InputErrorKind::syntax, 1},
      {"msh fewer nodes than promised", "a.msh",
       kMsh22Head + "$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n", InputErrorKind::count_mismatch, 10},
      {"msh NaN node", "a.msh", kMsh22Head + "$Nodes\n4\n1 0 0 0\n2 NaN 0 0\n", InputErrorKind::non_finite, 7},
      {"msh garbage number", "a.msh", kMsh22Head + "$Nodes\n4\n1 0 0 0\n2 1,5 0 0\n", InputErrorKind::syntax, 7},
      {"msh unknown node", "a.msh",
       kMsh22Head + kMsh22Nodes + "$Elements\n1\n1 4 2 1 1 1 2 3 9\n$EndElements\n", InputErrorKind::index_out_of_range, 13},
      {"msh truncated elements", "a.msh", kMsh22Head + kMsh22Nodes + "$Elements\n2\n1 4 2 1 1 1 2 3 4\n",
       InputErrorKind::truncated, 13},
      {"msh unclosed unknown section", "a.msh", kMsh22Head + "$Comments\nhello\n", InputErrorKind::truncated, 5},
      {"msh zero volume", "a.msh",
       kMsh22Head + "$Nodes\n5\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 0\n$EndNodes\n"
                    "$Elements\n2\n1 4 2 1 1 1 2 3 4\n2 4 2 1 1 1 2 3 5\n$EndElements\n",
       InputErrorKind::degenerate_element, 15},
      {"msh 4.1 node blocks short", "a.msh",
       "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 5 1 5\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
       "$EndNodes\n",
       InputErrorKind::count_mismatch, 14},
      // Legacy VTK.
      {"vtk binary", "a.vtk", "# vtk DataFile Version 3.0\nt\nBINARY\n", InputErrorKind::unsupported, 3},
      {"vtk fewer points than promised", "a.vtk",
       kVtkHead + "POINTS 5 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
       InputErrorKind::count_mismatch, 10},
      {"vtk unknown keyword", "a.vtk", kVtkHead + "POINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nPOLYGONS 1 5\n",
       InputErrorKind::syntax, 10},
      {"vtk tet out of range", "a.vtk",
       kVtkHead + "POINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nCELLS 1 5\n4 0 1 2 4\nCELL_TYPES 1\n10\n",
       InputErrorKind::index_out_of_range, 11},
      {"vtk cell list size wrong", "a.vtk",
       kVtkHead + "POINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nCELLS 1 6\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
       InputErrorKind::count_mismatch, 11},
      {"vtk truncated", "a.vtk", kVtkHead + "POINTS 4 double\n0 0 0\n1 0 0\n", InputErrorKind::truncated, 7},
      {"vtk absurd count", "a.vtk", kVtkHead + "POINTS 999999999999 double\n0 0 0\n", InputErrorKind::truncated, 6},
      {"node absurd count", "a.node", "999999999999 3 0 0\n0 0 0 0\n", InputErrorKind::truncated, 2},
      {"vtk NaN", "a.vtk", kVtkHead + "POINTS 4 double\n0 0 0\n1 0 nan\n", InputErrorKind::non_finite, 7},
  };
}

TEST_F(MeshIoTest, MalformedFilesGiveTheirKindAndLine) {
  for (const auto& m : malformed_catalogue()) {
    SCOPED_TRACE(m.label);
    // TetGen files need a well-formed partner.
    if (m.file.ends_with(".node")) write("a.ele", "1 4 0\n0 0 1 2 3\n");
    if (m.file == "a.ele") write("a.node", kNode);
    if (m.file == "b.ele") write("b.node", "5 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 1 1 0\n");
    const std::string file = write(m.file, m.text);
    try {
      read_tet_mesh(file);
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_EQ(e.kind(), m.kind) << e.what();
      EXPECT_EQ(e.where(), m.line > 0 ? file_line(file, m.line) : file) << e.what();
      EXPECT_NE(std::string(e.what()).find(e.where()), std::string::npos);
    }
  }
}

TEST_F(MeshIoTest, MissingFilesAndUnknownExtensions) {
  auto kind_of = [](const std::string& p) {
    try {
      read_tet_mesh(p);
    } catch (const InputError& e) {
      return e.kind();
    }
    return InputErrorKind::bad_value;  // no error: fails the checks below
  };
  EXPECT_EQ(kind_of(path("none.msh")), InputErrorKind::io);
  write("only.node", kNode);
  EXPECT_EQ(kind_of(path("only.node")), InputErrorKind::io);  // the .ele partner is missing
  EXPECT_EQ(kind_of(write("mesh.stl", "solid x\n")), InputErrorKind::unsupported);
  const auto box = make_box_mesh({});
  EXPECT_THROW(write_tet_mesh(path("m.obj"), *box), InputError);
}

// Values of the DataArray named `name` in a .vtu text.
std::vector<double> data_array(const std::string& xml, const std::string& name) {
  const std::string open = "Name=\"" + name + "\"";
  const size_t start = xml.find('>', xml.find(open)) + 1;
  const size_t end = xml.find("</DataArray>", start);
  std::istringstream in(xml.substr(start, end - start));
  std::vector<double> v;
  for (double d; in >> d;) v.push_back(d);
  return v;
}

TEST_F(MeshIoTest, VtuParsesBackToItsCountsAndFields) {
  const auto box = make_box_mesh({Vec3(1.0, 2.0, 3.0), 2, 1, 1});
  std::vector<Vec3> x = box->rest_positions();
  VtuPointField height{"height", 1, {}}, displacement{"displacement", 3, {}};
  for (const Vec3& p : x) {
    height.values.push_back(p.z() / 3.0);
    for (int k = 0; k < 3; ++k) displacement.values.push_back(0.1 * p[k]);
  }
  const std::vector<VtuPointField> fields = {height, displacement};
  write_tet_mesh_vtu(path("box.vtu"), *box, x, fields);
  EXPECT_FALSE(fs::exists(path("box.vtu.tmp")));
  const std::string xml = read_text(path("box.vtu"));
  std::smatch m;
  ASSERT_TRUE(std::regex_search(xml, m, std::regex("NumberOfPoints=\"(\\d+)\" NumberOfCells=\"(\\d+)\"")));
  EXPECT_EQ(std::stoi(m[1]), box->vertex_count());
  EXPECT_EQ(std::stoi(m[2]), box->tet_count());
  EXPECT_EQ(data_array(xml, "height"), height.values);  // 17 digits: exact
  EXPECT_EQ(data_array(xml, "displacement"), displacement.values);
  const auto conn = data_array(xml, "connectivity");
  ASSERT_EQ(conn.size(), 4u * static_cast<size_t>(box->tet_count()));
  for (size_t i = 0; i < conn.size(); ++i) EXPECT_EQ(conn[i], box->tets()[i / 4][i % 4]);
  const auto types = data_array(xml, "types");
  EXPECT_EQ(types, std::vector<double>(static_cast<size_t>(box->tet_count()), 10.0));

  // Triangles and wrong field sizes.
  VtuCells tris{VtuCellType::triangle, {0, 1, 2}};
  write_vtu(path("tri.vtu"), x, tris);
  EXPECT_EQ(data_array(read_text(path("tri.vtu")), "offsets"), std::vector<double>{3.0});
  VtuPointField bad{"bad", 3, {1.0}};
  EXPECT_THROW(write_vtu(path("bad.vtu"), x, tris, std::span(&bad, 1)), InputError);
  EXPECT_THROW(write_vtu(path("bad.vtu"), x, VtuCells{VtuCellType::tetra, {0, 1, 2}}), InputError);
}

TEST_F(MeshIoTest, PvdListsEveryStepInOrder) {
  PvdSeries series(path("run.pvd"));
  series.add(0.0, "frame_0.vtu");
  series.add(0.125, "frame_1.vtu");
  const std::string xml = read_text(path("run.pvd"));
  const std::regex dataset("<DataSet timestep=\"([^\"]+)\"[^>]*file=\"([^\"]+)\"");
  std::vector<std::pair<double, std::string>> found;
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), dataset); it != std::sregex_iterator(); ++it) {
    found.emplace_back(std::stod((*it)[1]), (*it)[2]);
  }
  const std::vector<std::pair<double, std::string>> expected = {{0.0, "frame_0.vtu"}, {0.125, "frame_1.vtu"}};
  EXPECT_EQ(found, expected);
  EXPECT_FALSE(fs::exists(path("run.pvd.tmp")));
}

}  // namespace
}  // namespace pliant

namespace pliant {
namespace {

// Robustness: truncated and byte-mutated versions of real files either load or throw InputError;
// nothing else escapes (no crash, no bad_alloc from a huge count, no FP trap).
TEST_F(MeshIoTest, DamagedFilesOnlyEverThrowInputError) {
  std::srand(11);
  const std::string alphabet = "0123456789-+.eE$# \n\txn";
  int loaded = 0, rejected = 0;
  for (const std::string name : {"gmsh_cube_v22.msh", "gmsh_cube_v41.msh", "gmsh_cube.vtk", "tetgen_box.node",
                                 "tetgen_box.ele", "tetgen_box.vtk"}) {
    const std::string original = read_text(asset(name));
    const std::string ext = fs::path(name).extension().string();
    // The TetGen partner stays intact.
    if (ext == ".node") write("t.ele", read_text(asset("tetgen_box.ele")));
    if (ext == ".ele") write("t.node", read_text(asset("tetgen_box.node")));
    std::vector<std::string> damaged;
    for (int k = 1; k < 40; ++k) damaged.push_back(original.substr(0, original.size() * static_cast<size_t>(k) / 40));
    for (int k = 0; k < 60; ++k) {
      std::string text = original;
      for (int m = 0; m < 1 + k % 3; ++m) {
        text[static_cast<size_t>(std::rand()) % text.size()] = alphabet[static_cast<size_t>(std::rand()) % alphabet.size()];
      }
      damaged.push_back(std::move(text));
    }
    damaged.push_back(std::string(original).replace(original.find('\n') + 1, 1, "999999999999999"));
    for (const auto& text : damaged) {
      const std::string file = write("t" + ext, text);
      try {
        read_tet_mesh(file);
        ++loaded;
      } catch (const InputError& e) {
        ++rejected;
        EXPECT_EQ(e.where().rfind(path("t"), 0), 0u) << e.what();  // names the file
      } catch (const std::exception& e) {
        ADD_FAILURE() << name << ": " << e.what();
      }
    }
  }
  EXPECT_GT(rejected, loaded / 10);  // the damage is mostly detected
}

}  // namespace
}  // namespace pliant
