// Bad input across every format and the command line (issue 9, item 3; docs/reliability.md).
// Library cases: each malformed file is written to a scratch folder and loaded the way `pliant`
// loads it (read_tet_mesh, load_scene, load_tool_script_file, PoseStream::open); the error must be
// an InputError of the expected kind whose message names the file and the line or JSON path.
// CLI cases: `pliant` must exit with 2, say where the problem is, and leave nothing in --out
// (no summary.json, steps.csv, tool_forces.csv or *.partial) since it loads everything first.
#include <gtest/gtest.h>

#include "support/run_cli.h"

#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "interaction/pose_stream.h"
#include "interaction/scene/scene.h"
#include "interaction/tool_script.h"
#include "sim/input_error.h"
#include "sim/io/tet_mesh_reader.h"
#include "support/fp_traps.h"

namespace pliant {
namespace {

namespace fs = std::filesystem;

fs::path scratch_root() {
  static const fs::path root = fs::temp_directory_path() / ("pliant_bad_input_" + std::to_string(::getpid()));
  return root;
}

void write_file(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

// One bad input: files to write (name -> text), the loader to call on the first file, the kind
// and a substring of the message that locates the problem ("<file>:<line>" or "<file>: /path").
enum class Loader { mesh, scene, script, pose };

struct BadInput {
  std::string label;
  Loader loader;
  std::vector<std::pair<std::string, std::string>> files;
  InputErrorKind kind;
  std::string where;  // with "{dir}" replaced by the case's folder
  bool overflows = false;  // strtod overflows on purpose (1e999): FP traps off for this case
};

const std::string kNode = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";
const std::string kEle = "1 4 0\n0 0 1 2 3\n";
const std::string kMshHead = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n";
const std::string kMshNodes = "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";  // lines 4-10
const std::string kVtkHead = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n";
const std::string kBox = R"({"shape": "box", "size": [0.1, 0.1, 0.04], "cells": [2, 2, 1]})";

// A scene with one box body plus `extra` top-level members (text starting with ", ").
std::string scene_with(const std::string& body_extra, const std::string& extra = "") {
  return R"({"bodies": [{"name": "tissue", "mesh": )" + kBox + body_extra + "}]" + extra + "}\n";
}
const std::string kProbe = R"(, "instruments": [{"name": "probe", "type": "probe", "position": [0, 0, 0.05],
    "tip_radius": 0.01, "shaft_radius": 0.004, "shaft_length": 0.06, "resolution": 3}])";

std::vector<BadInput> catalogue() {
  using K = InputErrorKind;
  return {
      // Meshes: TetGen.
      {"node truncated", Loader::mesh, {{"a.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n"}, {"a.ele", kEle}}, K::truncated, "{dir}/a.node:3"},
      {"node NaN", Loader::mesh, {{"a.node", "4 3 0 0\n0 0 0 0\n1 nan 0 0\n2 0 1 0\n3 0 0 1\n"}, {"a.ele", kEle}}, K::non_finite, "{dir}/a.node:3"},
      {"node header not a number", Loader::mesh, {{"a.node", "four 3 0 0\n"}, {"a.ele", kEle}}, K::syntax, "{dir}/a.node:1"},
      {"node empty file", Loader::mesh, {{"a.node", ""}, {"a.ele", kEle}}, K::truncated, "{dir}/a.node"},
      {"ele index out of range", Loader::mesh, {{"a.node", kNode}, {"a.ele", "1 4 0\n0 0 1 2 7\n"}}, K::index_out_of_range, "{dir}/a.ele:2"},
      {"node more points than promised", Loader::mesh, {{"a.node", kNode + "4 1 1 0\n"}, {"a.ele", kEle}}, K::count_mismatch, "{dir}/a.node:6"},
      {"ele flat tet", Loader::mesh, {{"a.node", "5 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n4 1 1 0\n"}, {"a.ele", "2 4 0\n0 0 1 2 3\n1 0 1 2 4\n"}},
       K::degenerate_element, "{dir}/a.ele:3"},
      {"ele missing partner", Loader::mesh, {{"a.node", kNode}}, K::io, "{dir}/a.ele"},
      {"ele 3 nodes per tet", Loader::mesh, {{"a.node", kNode}, {"a.ele", "1 3 0\n0 0 1 2\n"}}, K::unsupported, "{dir}/a.ele:1"},
      // Meshes: Gmsh.
      {"msh binary", Loader::mesh, {{"a.msh", "$MeshFormat\n2.2 1 8\n"}}, K::unsupported, "{dir}/a.msh:2"},
      {"msh NaN node", Loader::mesh, {{"a.msh", kMshHead + "$Nodes\n4\n1 0 0 0\n2 NaN 0 0\n"}}, K::non_finite, "{dir}/a.msh:7"},
      {"msh unknown node", Loader::mesh, {{"a.msh", kMshHead + kMshNodes + "$Elements\n1\n1 4 2 1 1 1 2 3 9\n$EndElements\n"}},
       K::index_out_of_range, "{dir}/a.msh:13"},
      {"msh no tets", Loader::mesh, {{"a.msh", kMshHead + kMshNodes + "$Elements\n1\n1 2 2 1 1 1 2 3\n$EndElements\n"}},
       K::bad_value, "{dir}/a.msh: the file holds no 4-node tetrahedra"},
      // Meshes: legacy VTK.
      {"vtk truncated points", Loader::mesh, {{"a.vtk", kVtkHead + "POINTS 4 double\n0 0 0\n1 0 0\n"}}, K::truncated, "{dir}/a.vtk:7"},
      {"vtk tet out of range", Loader::mesh,
       {{"a.vtk", kVtkHead + "POINTS 4 double\n0 0 0\n1 0 0\n0 1 0\n0 0 1\nCELLS 1 5\n4 0 1 2 4\nCELL_TYPES 1\n10\n"}},
       K::index_out_of_range, "{dir}/a.vtk:11"},
      {"vtk not unstructured", Loader::mesh, {{"a.vtk", "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n"}},
       K::unsupported, "{dir}/a.vtk:4"},
      {"mesh unknown extension", Loader::mesh, {{"a.stl", "solid x\n"}}, K::unsupported, "{dir}/a.stl"},
      {"mesh missing file", Loader::mesh, {{"none.msh", ""}}, K::io, "{dir}/none.msh"},  // written, then removed below
      // Scenes.
      {"scene not JSON", Loader::scene, {{"s.json", "{\n  \"bodies\": [\n    {\"name\": \"a\",,}\n"}}, K::syntax, "{dir}/s.json:3"},
      {"scene unknown key", Loader::scene, {{"s.json", scene_with("", ", \"gravty\": [0, 0, -9.81]")}}, K::unknown_key, "{dir}/s.json: /gravty"},
      {"scene negative time step", Loader::scene, {{"s.json", scene_with("", ", \"time_step\": -0.001")}}, K::bad_value, "{dir}/s.json: /time_step"},
      {"scene time step string", Loader::scene, {{"s.json", scene_with("", ", \"time_step\": \"fast\"")}}, K::wrong_type, "{dir}/s.json: /time_step"},
      {"scene no bodies", Loader::scene, {{"s.json", "{\"name\": \"x\"}"}}, K::bad_value, "{dir}/s.json: /: missing required key 'bodies'"},
      {"scene gravity two numbers", Loader::scene, {{"s.json", scene_with("", ", \"gravity\": [0, -9.81]")}}, K::wrong_type, "{dir}/s.json: /gravity"},
      {"scene negative Young's modulus", Loader::scene, {{"s.json", scene_with(", \"material\": {\"young_modulus\": -3}")}},
       K::bad_value, "{dir}/s.json: /bodies/0/material/young_modulus"},
      {"scene Poisson ratio 0.5", Loader::scene, {{"s.json", scene_with(", \"material\": {\"poisson_ratio\": 0.5}")}},
       K::bad_value, "{dir}/s.json: /bodies/0/material/poisson_ratio"},
      {"scene zero cells", Loader::scene,
       {{"s.json", R"({"bodies": [{"mesh": {"shape": "box", "size": [0.1, 0.1, 0.1], "cells": [0, 1, 1]}}]})"}},
       K::bad_value, "{dir}/s.json: /bodies/0/mesh/cells/0"},
      {"scene duplicate name", Loader::scene,
       {{"s.json", R"({"bodies": [{"name": "a", "mesh": )" + kBox + R"(}, {"name": "a", "mesh": )" + kBox + "}]}"}},
       K::bad_value, "{dir}/s.json: /bodies/1/name"},
      {"scene unknown contact method", Loader::scene, {{"s.json", scene_with("", ", \"contact\": {\"method\": \"magic\"}")}},
       K::bad_value, "{dir}/s.json: /contact/method"},
      {"scene unknown instrument type", Loader::scene,
       {{"s.json", scene_with("", R"(, "instruments": [{"name": "x", "type": "laser"}])")}}, K::bad_value,
       "{dir}/s.json: /instruments/0/type"},
      {"scene missing mesh file", Loader::scene, {{"s.json", R"({"bodies": [{"mesh": {"file": "nope.msh"}}]})"}},
       K::io, "nope.msh"},
      {"scene broken mesh file", Loader::scene,
       {{"s.json", R"({"bodies": [{"mesh": {"file": "m.vtk"}}]})"}, {"m.vtk", kVtkHead + "POINTS 4 double\n0 0 0\n1 0 nan\n"}},
       K::non_finite, "{dir}/m.vtk:7"},
      {"scene unknown disabled pair", Loader::scene,
       {{"s.json", scene_with("", R"(, "collision": {"disabled_pairs": [["tissue", "floor"]]})")}}, K::bad_value,
       "{dir}/s.json: /collision/disabled_pairs/0/1"},
      {"scene output path", Loader::scene, {{"s.json", scene_with("", R"(, "output": {"dir": "/tmp/elsewhere"})")}},
       K::unknown_key, "{dir}/s.json: /output/dir"},
      {"scene script file missing", Loader::scene, {{"s.json", scene_with("", kProbe + R"(, "script": {"file": "none.json"})")}},
       K::io, "none.json"},
      {"scene script bad op", Loader::scene,
       {{"s.json", scene_with("", kProbe + R"(, "script": [{"t": 1, "instrument": "probe", "op": "teleport"}])")}},
       K::bad_value, "{dir}/s.json: /script/0/op"},
      // Tool-script files (root is the keyframe array; instruments probe and grasper).
      {"script times not increasing", Loader::script,
       {{"t.json", R"([{"t": 1, "instrument": "probe", "op": "hold"}, {"t": 0.5, "instrument": "probe", "op": "hold"}])"}},
       K::bad_value, "{dir}/t.json: /1/t"},
      {"script unknown instrument", Loader::script, {{"t.json", R"([{"t": 1, "instrument": "scalpel", "op": "hold"}])"}},
       K::bad_value, "{dir}/t.json: /0/instrument"},
      {"script infinite position", Loader::script,
       {{"t.json", R"([{"t": 1, "instrument": "probe", "op": "move", "position": [0, 1e999, 0]}])"}}, K::non_finite,
       "{dir}/t.json:1", true},
      {"pose infinite coordinate", Loader::pose, {{"p.csv", "0,probe,0,-1e400,0,1,0,0,0\n"}}, K::non_finite, "{dir}/p.csv:1", true},
      {"node infinite coordinate", Loader::mesh, {{"a.node", "4 3 0 0\n0 0 0 0\n1 1e999 0 0\n2 0 1 0\n3 0 0 1\n"}, {"a.ele", kEle}},
       K::non_finite, "{dir}/a.node:3", true},
      {"script jaws on a probe", Loader::script, {{"t.json", R"([{"t": 1, "instrument": "probe", "op": "jaws", "opening_deg": 30}])"}},
       K::bad_value, "{dir}/t.json: /0/op"},
      {"script neither array nor {\"script\": [...]}", Loader::script, {{"t.json", R"({"t": 1})"}}, K::unknown_key, "{dir}/t.json: /t"},
      {"script keyframe not an object", Loader::script, {{"t.json", R"([1])"}}, K::wrong_type, "{dir}/t.json: /0"},
      {"script unknown field", Loader::script, {{"t.json", R"([{"t": 1, "instrument": "probe", "op": "hold", "speed": 2}])"}},
       K::unknown_key, "{dir}/t.json: /0/speed"},
      {"script bad JSON", Loader::script, {{"t.json", "[\n{\"t\": 1,\n"}}, K::syntax, "{dir}/t.json:"},
      // Pose streams.
      {"pose too few columns", Loader::pose, {{"p.csv", "# t,instrument,...\n0,probe,0,0,0,1,0,0\n"}}, K::syntax, "{dir}/p.csv:2"},
      {"pose NaN", Loader::pose, {{"p.csv", "0,probe,0,0,0,1,0,0,0\n0.1,probe,nan,0,0,1,0,0,0\n"}}, K::non_finite, "{dir}/p.csv:2"},
      {"pose zero quaternion", Loader::pose, {{"p.csv", "\n\n0,probe,0,0,0,0,0,0,0\n"}}, K::bad_value, "{dir}/p.csv:3"},
      {"pose time backwards", Loader::pose, {{"p.csv", "1,probe,0,0,0,1,0,0,0\n0.5,probe,0,0,0,1,0,0,0\n"}}, K::bad_value, "{dir}/p.csv:2"},
      {"pose number garbage", Loader::pose, {{"p.csv", "0,probe,0,0,0x,1,0,0,0\n"}}, K::syntax, "{dir}/p.csv:1"},
      {"pose missing file", Loader::pose, {{"none.csv", ""}}, K::io, "{dir}/none.csv"},
  };
}

std::string replace_dir(std::string s, const std::string& dir) {
  const auto at = s.find("{dir}");
  if (at != std::string::npos) s.replace(at, 5, dir);
  return s;
}

void load(Loader loader, const std::string& path) {
  switch (loader) {
    case Loader::mesh: read_tet_mesh(path); break;
    case Loader::scene: load_scene(path); break;
    case Loader::script: load_tool_script_file(path, {"probe", "grasper"}, {"grasper"}); break;
    case Loader::pose: PoseStream::open(path); break;
  }
}

TEST(BadInput, EveryMalformedInputGivesItsKindAndLocation) {
  const auto cases = catalogue();
  ASSERT_GE(cases.size(), 30u);
  for (size_t i = 0; i < cases.size(); ++i) {
    const BadInput& c = cases[i];
    SCOPED_TRACE(c.label);
    const fs::path dir = scratch_root() / ("lib" + std::to_string(i));
    for (const auto& [name, text] : c.files) write_file(dir / name, text);
    const std::string first = (dir / c.files.front().first).string();
    if (c.label.find("missing file") != std::string::npos) fs::remove(first);
    try {
      std::optional<testing::ScopedFpTrapsOff> traps_off;
      if (c.overflows) traps_off.emplace();
      load(c.loader, first);
      ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
      EXPECT_EQ(e.kind(), c.kind) << to_string(e.kind()) << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find(replace_dir(c.where, dir.string())), std::string::npos)
          << "expected '" << replace_dir(c.where, dir.string()) << "' in: " << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "exception other than InputError: " << e.what();
    }
  }
}

// ---- the command line ----

using testing::CliResult;
using testing::pliant_binary;
using testing::run_cli;

// Files `pliant run` writes; none may exist after a failed load.
std::vector<std::string> leftovers(const fs::path& out) {
  std::vector<std::string> found;
  if (!fs::exists(out)) return found;
  for (const auto& entry : fs::recursive_directory_iterator(out)) {
    const std::string name = entry.path().filename().string();
    if (name == "summary.json" || name == "steps.csv" || name == "tool_forces.csv" ||
        entry.path().extension() == ".partial" || name.rfind("frame_", 0) == 0) {
      found.push_back(entry.path().string());
    }
  }
  return found;
}

struct BadCommand {
  std::string label;
  std::string args;        // "{out}" and "{dir}" are replaced
  std::string message;     // must appear in the output
};

TEST(BadInput, CommandLineRejectsBadInputWithExitCode2AndNoOutput) {
  if (!fs::exists(pliant_binary())) GTEST_SKIP() << "pliant binary not built at " << pliant_binary();
  const fs::path dir = scratch_root() / "cli";
  const std::string scene = std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/probe_coarse.json";
  write_file(dir / "bad.json", scene_with(", \"material\": {\"young_modulus\": -3}"));
  write_file(dir / "syntax.json", "{\"bodies\": [\n");
  write_file(dir / "mesh.json", R"({"bodies": [{"mesh": {"file": "m.node"}}]})");
  write_file(dir / "m.node", "4 3 0 0\n0 0 0 0\n1 1 0 0\n");
  write_file(dir / "m.ele", kEle);
  write_file(dir / "script.json", scene_with("", kProbe + R"(, "script": {"file": "t.json"})"));
  write_file(dir / "t.json", R"([{"t": 1, "instrument": "probe", "op": "hold", "depth": 1}])");
  write_file(dir / "bad.vtk", kVtkHead + "POINTS 4 double\n0 0 0\n");
  const std::vector<BadCommand> commands = {
      {"no subcommand", "", "subcommand"},
      {"unknown subcommand", "fly", "subcommand"},
      {"unknown flag", "run " + scene + " --out {out} --fast", "--fast"},
      {"missing scene", "run {dir}/none.json --out {out}", "none.json"},
      {"steps 0", "run " + scene + " --out {out} --steps 0", "--steps"},
      {"steps negative", "run " + scene + " --out {out} --steps -5", "--steps"},
      {"steps not a number", "run " + scene + " --out {out} --steps many", "--steps"},
      {"steps and duration", "run " + scene + " --out {out} --steps 3 --duration 1", "--duration"},
      {"duration 0", "run " + scene + " --out {out} --duration 0", "--duration"},
      {"unknown contact", "run " + scene + " --out {out} --contact magic", "--contact"},
      {"iterations out of range", "run " + scene + " --out {out} --iterations 99", "--iterations"},
      {"scene bad value", "run {dir}/bad.json --out {out}", "bad.json: /bodies/0/material/young_modulus"},
      {"scene syntax", "run {dir}/syntax.json --out {out}", "syntax.json:"},
      {"scene broken mesh", "run {dir}/mesh.json --out {out}", "m.node:3"},
      {"scene broken script file", "run {dir}/script.json --out {out}", "t.json: /0/depth"},
      {"mesh info missing", "mesh info {dir}/none.msh", "none.msh"},
      {"mesh info broken", "mesh info {dir}/bad.vtk", "bad.vtk:"},
      {"mesh convert bad output", "mesh convert " + std::string(PLIANT_SOURCE_DIR) + "/assets/meshes/gmsh_cube_v22.msh {out}/x.stl", "x.stl"},
      {"tradeoff missing scene", "tradeoff {dir}/none.json --out {out}", "none.json"},
      {"tradeoff steps 0", "tradeoff " + scene + " --out {out} --steps 0", "--steps"},
      {"tradeoff negative gate", "tradeoff " + scene + " --out {out} --held-final-strain 0 -0.001", "--held-final-strain"},
      {"run threads 0", "run " + scene + " --out {out} --threads 0", "--threads"},
      {"experiment threads 0", "experiment " + scene + " --out {out} --threads 0", "--threads"},
      {"experiment threads not a number", "experiment " + scene + " --out {out} --threads two", "--threads"},
  };
  for (size_t i = 0; i < commands.size(); ++i) {
    const BadCommand& c = commands[i];
    SCOPED_TRACE(c.label);
    const fs::path out = dir / ("out" + std::to_string(i));
    std::string args = c.args;
    for (const auto& [key, value] : {std::pair<std::string, std::string>{"{out}", out.string()}, {"{dir}", dir.string()}}) {
      for (auto at = args.find(key); at != std::string::npos; at = args.find(key)) args.replace(at, key.size(), value);
    }
    const CliResult r = run_cli(args);
    EXPECT_EQ(r.exit_code, 2) << "pliant " << args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.message), std::string::npos) << "expected '" << c.message << "' in:\n" << r.output;
    EXPECT_EQ(leftovers(out), std::vector<std::string>{}) << "partial output left after a failed load";
  }
}

}  // namespace
}  // namespace pliant
