// `pliant tradeoff` end to end (issue 8, item 3; the command had no test before session 21): one CSV
// row per setting, the reference compared with itself exactly zero (runs are deterministic), the
// other settings non-zero and the scene's default row marked (bad input: tests/apps/bad_input_test.cpp,
// exit code 2 and nothing written). On the three cubes (the smallest scene where every contact
// searches), past their landing (step ~56), with the held final evaluation's gate (session 21) as a
// sweep dimension: its reference is the exact final evaluation (the smallest gate), and the scene
// ships 3e-3.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "support/run_cli.h"

namespace pliant {
namespace {

namespace fs = std::filesystem;

/// The CSV's rows as column name -> text.
std::vector<std::map<std::string, std::string>> read_csv(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    if (header.empty()) {
      header = cells;
      continue;
    }
    std::map<std::string, std::string> row;
    for (size_t i = 0; i < header.size() && i < cells.size(); ++i) row[header[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

TEST(TradeoffCommand, ReferenceIsExactlyItselfAndTheHeldFinalGateIsASweepDimension) {
  if (!fs::exists(testing::pliant_binary())) GTEST_SKIP() << "pliant binary not built";
  const fs::path out = testing::scratch_dir("tradeoff_test", "cubes");
  const std::string scene = std::string(PLIANT_SOURCE_DIR) + "/assets/scenes/paper/three_cubes.json";
  const testing::CliResult r = testing::run_cli("tradeoff " + scene + " --out " + out.string() +
                              " --steps 120 --binary-search 2 4 --solver 20 --dt 1 --resolution 1"
                              " --held-final-strain 0 0.003 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto rows = read_csv(out / "tradeoff.csv");
  ASSERT_EQ(rows.size(), 4u);  // 2 search iterations x 2 gates
  int references = 0, defaults = 0;
  for (const auto& row : rows) {
    const int bs = std::stoi(row.at("binary_search_iterations"));
    const double gate = std::stod(row.at("held_final_strain"));
    const double surface = std::stod(row.at("surface_rms_error_mm"));
    EXPECT_EQ(row.at("failed"), "0");
    EXPECT_EQ(row.at("steps"), "120");
    const bool is_reference = bs == 4 && gate == 0.0;  // most iterations, smallest gate
    EXPECT_EQ(row.at("is_reference"), is_reference ? "1" : "0") << bs << " " << gate;
    EXPECT_EQ(row.at("is_default"), bs == 4 && gate == 0.003 ? "1" : "0") << bs << " " << gate;
    references += is_reference;
    defaults += row.at("is_default") == "1";
    if (is_reference) {
      EXPECT_EQ(surface, 0.0);  // deterministic: the reference setting reproduces the reference run
    } else {
      EXPECT_GT(surface, 0.0) << bs << " " << gate;  // the setting changed the run
      EXPECT_LT(surface, 1.0) << bs << " " << gate;  // mm: a contact setting, not a different scene
    }
  }
  EXPECT_EQ(references, 1);
  EXPECT_EQ(defaults, 1);
}

}  // namespace
}  // namespace pliant
